"""Output files written atomically, and output locations checked before any work.

Every file foam-mj writes (Rerun recordings, JSON results, figures, benchmark JSON, exports) goes
through this module, so a reader never sees a half-written file:

    from foam_mj.atomic import atomic_path, check_output

    out = check_output(args.json, "--json", suffix=".json")   # before any work: OutputError (exit 2)
    ...
    with atomic_path(out) as tmp:        # tmp: a fresh name in out's folder, same suffix
        write_something(tmp)             # any writer that takes a path
    # here out is complete; on any exception the temporary file is gone and OutputError is raised

:func:`atomic_write_text` and :func:`atomic_write_bytes` cover the common cases. The temporary file
lives in the target's folder (so the final :func:`os.replace` is an atomic rename on one file system)
and is named ``.<name>.<random>.tmp<suffix>`` (hidden; the suffix kept for writers that look at it).

Failures (missing folder, read-only or pseudo file system such as ``/proc``, a name longer than the
file system allows, a full disk) raise :class:`OutputError`, a :class:`~foam_mj.errors.FoamError`, with
a one-line message naming the file: the command line turns it into exit code 2.
"""

from __future__ import annotations

import contextlib
import os
import secrets
from pathlib import Path
from typing import Iterator, overload

from foam_mj.errors import FoamError
from foam_mj.interrupts import SIGNALLED

#: ``check_output`` refuses a file system with less free space than this (bytes): the outputs of one
#: plan are a few MB, and a nearly full disk is better reported before minutes of work than after.
MIN_FREE_BYTES = 1 << 20


class OutputError(FoamError, OSError):
    """An output file cannot be written (or could not be, and nothing was left behind)."""


def _reason(exc: OSError) -> str:
    return exc.strerror or type(exc).__name__


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError):
        return 255


def _target(p: Path) -> Path:
    """The file a write to ``p`` must replace: ``p`` itself, or for a symbolic link the file it points to (a rename
    onto the link would replace the link: ``--out /dev/stdout`` as root turned /dev/stdout into a regular file)."""
    try:
        return Path(os.path.realpath(p)) if p.is_symlink() else p
    except OSError:  # e.g. a name too long to look up: not a link; check_output names the problem
        return p


def _tmp_name(target: Path) -> str:
    suffix = target.suffix if len(target.suffix) <= 16 else ""
    return f".{target.name[:60]}.{secrets.token_hex(4)}.tmp{suffix}"


@overload
def check_output(path: str | os.PathLike, what: str, *, suffix: str | None = None, min_free: int | None = None) -> Path: ...
@overload
def check_output(path: None, what: str, *, suffix: str | None = None, min_free: int | None = None) -> None: ...
@overload
def check_output(path: str | os.PathLike | None, what: str, *, suffix: str | None = None,
                 min_free: int | None = None) -> Path | None: ...
def check_output(path: str | os.PathLike | None, what: str, *, suffix: str | None = None,
                 min_free: int | None = None) -> Path | None:
    """Check, before any work, that ``path`` can be written; return it as a Path (None passes through).

    Refused with :class:`OutputError` naming ``what`` (e.g. "--json"): an empty name, a name too long
    for the file system, a directory, a missing folder, a folder where no file can be created (probed by
    creating and removing a temporary file: catches read-only and pseudo file systems like ``/proc``),
    an existing file that is not writable, an existing path that is not a regular file (``/dev/null``, a
    FIFO, a socket: the final rename would replace it, as root even the device node), a name ending in a
    path separator (a folder, not a file name), less than ``min_free`` bytes free (default
    :data:`MIN_FREE_BYTES`), and (with ``suffix``, lower case) a name not ending in it in any case (``X.JSON`` is a
    JSON file: a suffix names a format, and Rerun's viewer too reads a recording's suffix lower-cased).
    """
    if path is None:
        return None
    text = os.fspath(path)
    if not text:
        raise OutputError(f"{what}: empty file name")
    if text.endswith(("/", os.sep)):
        raise OutputError(f"{what} output {text} ends in '/': it names a folder; give a file name")
    p = Path(text)
    link, p = p, _target(p)  # a link: the checks below are of the file it points to, which the write replaces
    shown = str(p) if p == link else f"{link} (a link to {p})"
    folder = p.parent
    try:
        if not folder.is_dir():
            raise OutputError(f"{what} output {shown}: folder {folder} does not exist")
        limit = _name_max(folder)
        if len(os.fsencode(p.name)) > limit:
            raise OutputError(f"{what} output: file name of {len(os.fsencode(p.name))} bytes is longer than this file system allows ({limit})")
        if p.is_dir():
            raise OutputError(f"{what} output {shown} is a directory")
        if suffix is not None and link.name.lower() == suffix:  # Path(".json").suffix is '': 'must end in .json' puzzled
            raise OutputError(f"{what} output {link} is only the suffix {suffix}: give a name before it (out{suffix})")
        if suffix is not None and link.suffix.lower() != suffix:  # in any case: X.JSON was refused
            raise OutputError(f"{what} output {link} must end in {suffix}")
        if p.exists() and not p.is_file():
            raise OutputError(f"{what} output {shown} exists and is not a regular file ({_kind(p)}): writing it would replace it; give a file name")
        if p.exists() and not os.access(p, os.W_OK):
            raise OutputError(f"{what} output {shown} is not writable")
        _check_writable(folder, f"{what} output {shown}", min_free)
    except OutputError:
        raise
    except OSError as exc:
        raise OutputError(f"{what} output {shown}: {_reason(exc)}") from None
    return link


def _check_writable(folder: Path, shown: str, min_free: int | None = None) -> None:
    """Create and remove a file in ``folder`` (catches read-only and pseudo file systems) and check that it has
    ``min_free`` bytes free (default :data:`MIN_FREE_BYTES`); OutputError starting with ``shown`` otherwise."""
    probe = folder / f".foam-mj-probe.{secrets.token_hex(4)}.tmp"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except OSError as exc:
        raise OutputError(f"{shown}: cannot create a file in {folder}: {_reason(exc)}") from None
    os.close(fd)
    os.unlink(probe)
    st = os.statvfs(folder)
    free = st.f_bavail * st.f_frsize
    if free < (MIN_FREE_BYTES if min_free is None else min_free):
        raise OutputError(f"{shown}: no space left on its file system ({free} bytes free)")


def _kind(p: Path) -> str:
    """What a non-regular file is, for a message."""
    for test, kind in ((Path.is_char_device, "a character device"), (Path.is_block_device, "a block device"),
                       (Path.is_fifo, "a FIFO"), (Path.is_socket, "a socket")):
        if test(p):
            return kind
    return "a special file"


def _same_file(a: Path, b: Path) -> bool:
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
        return a.resolve() == b.resolve()
    except OSError:
        return False


def check_distinct(outputs: "dict[str, Path | None]", inputs: "dict[str, str | os.PathLike | None] | None" = None) -> None:
    """Refuse, before any work, an output that is the same file as an input or as another output
    (``foam-mj export r.json --out r.json`` would replace the result with its table; ``plan --json x.rrd
    --rrd x.rrd`` would keep only one of the two). Keys name the flag or the input, e.g. "--json", "the
    scenario"; None values are skipped. Raises :class:`OutputError` naming both."""
    outs = [(k, Path(v)) for k, v in outputs.items() if v is not None]
    ins = [(k, Path(v)) for k, v in (inputs or {}).items() if v is not None]
    for i, (what, out) in enumerate(outs):
        for name, src in ins:
            if _same_file(out, src):
                raise OutputError(f"{what} output {out} is {name} ({src}): it would be overwritten; choose another name")
        for other, out2 in outs[i + 1:]:
            if _same_file(out, out2):
                raise OutputError(f"{what} and {other} name the same file {out}; choose two names")


@overload
def check_output_dir(path: str | os.PathLike, what: str) -> Path: ...
@overload
def check_output_dir(path: None, what: str) -> None: ...
@overload
def check_output_dir(path: str | os.PathLike | None, what: str) -> Path | None: ...
def check_output_dir(path: str | os.PathLike | None, what: str) -> Path | None:
    """Check, before any work, that a folder for outputs exists and is writable, or can be created
    (its parent exists and is writable); return it as a Path (None passes through)."""
    if path is None:
        return None
    text = os.fspath(path)
    if not text:
        raise OutputError(f"{what}: empty folder name")
    p = Path(text)
    try:
        if p.exists() and not p.is_dir():
            raise OutputError(f"{what} {p} is a file, not a folder")
        if p.is_dir():
            _check_writable(p, f"{what} {p}")
            return p
        if not p.parent.is_dir():
            raise OutputError(f"{what} {p}: folder {p.parent} does not exist")
        _check_writable(p.parent, f"{what} {p}")
        limit = _name_max(p.parent)
        if len(os.fsencode(p.name)) > limit:
            raise OutputError(f"{what}: folder name of {len(os.fsencode(p.name))} bytes is longer than this file system allows ({limit})")
    except OutputError:
        raise
    except OSError as exc:
        raise OutputError(f"{what} {p}: {_reason(exc)}") from None
    return p


@contextlib.contextmanager
def atomic_path(target: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path in ``target``'s folder; rename it onto ``target`` when the block succeeds.

    When the block raises (or the rename fails), the temporary file is removed and the exception
    propagates, an :class:`OSError` turned into :class:`OutputError` naming ``target``. An existing
    ``target`` is left untouched until the rename. A symbolic link is kept: the file it points to is replaced.
    """
    target = _target(Path(target))
    tmp = target.parent / _tmp_name(target)
    try:
        yield tmp
        if not tmp.exists():
            raise OutputError(f"could not write {target}: the writer produced no file")
        if target.exists() and not target.is_file():  # never rename onto /dev/null, a FIFO, a socket
            raise OutputError(f"could not write {target}: it exists and is not a regular file ({_kind(target)})")
        if SIGNALLED:  # the command was interrupted, and a library swallowed the KeyboardInterrupt: write nothing
            raise KeyboardInterrupt
        os.replace(tmp, target)
    except OutputError:
        _remove(tmp)
        raise
    except OSError as exc:
        _remove(tmp)
        raise OutputError(f"could not write {target}: {_reason(exc)}") from None
    except BaseException:
        _remove(tmp)
        raise


def _remove(p: Path) -> None:
    with contextlib.suppress(OSError):
        p.unlink()


def atomic_write_bytes(target: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``target`` atomically (flushed and fsync'ed before the rename)."""
    target = Path(target)
    with atomic_path(target) as tmp:
        with open(tmp, "xb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
    return target


def atomic_write_text(target: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``target`` atomically."""
    return atomic_write_bytes(target, text.encode("utf-8"))
