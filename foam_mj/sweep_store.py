"""A sweep's output folder: its manifest (``sweep.json``) and its rows, a Parquet dataset written in batches by
atomic rename (:class:`RowStore`); :mod:`foam_mj.sweep_run` runs the sweep that fills it (layout and guarantees in
that module's docstring)."""

from __future__ import annotations

import fcntl
import json
import os
import signal
import sys
import time
from pathlib import Path
from typing import IO, Iterable

from foam_mj.atomic import OutputError, atomic_write_bytes
from foam_mj.sweep import FORMAT, VERSION, Sweep, SweepError

ROWS = "rows"
MANIFEST = "sweep.json"


def _pyarrow():
    try:
        import pyarrow
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        raise SweepError("sweeps write Parquet with pyarrow, which is not installed: pip install 'foam-mj[sweep]'") from None
    return pyarrow


# ------------------------------------------------------------------------------------------- the store


def _row_files(folder: Path) -> list[Path]:
    """The batches of a rows folder (hidden temporary files left out)."""
    return sorted(f for f in folder.glob("*.parquet") if not f.name.startswith("."))


def _read_batch(f: Path, required: Iterable[str], columns: list[str] | None = None):
    """One batch of rows as a pyarrow Table; SweepError naming the file when it is not a Parquet file of this
    sweep (unreadable, truncated, or without one of the ``required`` columns)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        schema = pq.read_schema(f)
        missing = [c for c in required if c not in schema.names]
        if missing:
            raise SweepError(f"{f}: not a row file of this sweep (no column(s) {missing[:5]}); move it out of {f.parent}")
        return pq.read_table(f, columns=columns)
    except (pa.ArrowException, OSError) as exc:
        raise SweepError(f"{f}: not a readable Parquet file ({' '.join(str(exc).split())[:200]}); move it out of {f.parent}") from None


def read_manifest(out: Path) -> dict | None:
    p = Path(out) / MANIFEST
    if not p.is_file():
        return None
    try:
        doc = json.loads(p.read_text(encoding="utf-8-sig"))  # UTF-8 whatever the locale; an editor's byte-order mark let through
    except RecursionError:
        raise SweepError(f"{p}: unreadable sweep manifest: nested too deeply to read") from None
    except (OSError, ValueError) as exc:
        raise SweepError(f"{p}: unreadable sweep manifest: {exc}") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise SweepError(f"{p} is not a foam-mj sweep manifest")
    version = doc.get("version")
    if version != VERSION:  # another format was read as this one
        newer = isinstance(version, int) and not isinstance(version, bool) and version > VERSION
        raise SweepError(f"{p}: field 'version' is {version!r}: "
                         f"{f'written by a foam-mj that writes sweep format version {version}; ' if newer else ''}this one "
                         f"reads {VERSION} (run the sweep again into a new folder)")
    names = lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v)  # noqa: E731
    for key, ok, what in (("keys", lambda v: isinstance(v, dict) and all(isinstance(x, str) for x in v.values()),
                           "an object of swept key: kind"),
                          ("columns", names, "a list of column names"), ("paths", names, "a list of path names"),
                          ("model_hash", lambda v: isinstance(v, dict), "an object (the base scene's fingerprint)")):
        # a list of keys or a number of paths was an internal error (exit 1) in report; a model_hash string skipped the
        # rerun's check that the scene still compiles to the same model
        if key in doc and not ok(doc[key]):
            raise SweepError(f"{p}: field '{key}' must be {what}, got {json.dumps(doc[key])[:60]} (restore it, or run the "
                             "sweep again into a new folder)")
    return doc


def _versions_text(v) -> str:
    return f"foam-mj {v.get('foam_mj_version', '?')}, MuJoCo {v.get('mujoco_version', '?')}" if isinstance(v, dict) else "an unknown foam-mj"


def _differences(old, new, prefix: str = "") -> list[str]:
    """The dotted fields where two JSON documents differ, each as "field: old -> new" (old first)."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for k in list(old) + [k for k in new if k not in old]:
            out += _differences(old.get(k, "(none)"), new.get(k, "(none)"), f"{prefix}{k}.")
        return out
    if old == new:
        return []
    return [f"{prefix.rstrip('.') or 'value'}: {json.dumps(old)[:60]} -> {json.dumps(new)[:60]}"]


def _check_same_sweep(out: Path, old: dict, mine: dict) -> None:
    """SweepError unless the manifest ``old`` (in the folder) describes the same rows as ``mine``: same base scenario
    (its TOML table and its compiled scene), replay mode, swept keys and columns; more values, seeds or smoothers are
    the same sweep grown."""
    from foam_mj.fingerprint import fingerprint_differences

    what = None
    if old.get("scenario") != mine["scenario"]:
        what = f"base scenario: {old.get('scenario')!r} there, {mine['scenario']!r} here"
    elif old.get("base") != mine["base"]:
        diff = _differences(old.get("base"), mine["base"])
        what = f"base scenario's field{'s' * (len(diff) > 1)} {'; '.join(diff[:3])}{' ...' * (len(diff) > 3)}"
    elif old.get("replay") != mine["replay"]:
        what = f"replay mode: {old.get('replay')!r} there, {mine['replay']!r} here"
    elif old.get("keys") != mine["keys"]:
        was, now = old.get("keys") or {}, mine["keys"]
        gone, new = [k for k in was if k not in now], [k for k in now if k not in was]
        kinds = [f"{k}: {was[k]} -> {now[k]}" for k in now if k in was and was[k] != now[k]]
        what = "swept keys: " + "; ".join(
            part for part in (f"{gone} not swept here" * bool(gone), f"{new} not swept there" * bool(new),
                              f"kinds {kinds}" * bool(kinds)) if part) if (gone or new or kinds) else "swept keys' order"
    elif isinstance(old.get("model_hash"), dict) and mine["model_hash"] and old["model_hash"] != mine["model_hash"]:
        parts = fingerprint_differences(old["model_hash"], mine["model_hash"]) or ["sha256"]
        what = f"base scene compiles to another model now ({', '.join(parts)} differ{'s' * (len(parts) == 1)}: the MJCF was edited)"
    elif old.get("columns") != mine["columns"]:
        was, now = old.get("columns") or [], mine["columns"]
        gone, new = [c for c in was if c not in now], [c for c in now if c not in was]
        what = f"columns: {gone} only there, {new} only here" if gone or new else "columns' order"
        if old.get("versions") != mine["versions"]:
            what += f"; written by {_versions_text(old.get('versions'))}, this is {_versions_text(mine['versions'])}"
    if what is not None:
        raise SweepError(f"--out {out} holds rows of another sweep (its {what}); use another folder")


class RowStore:
    """The Parquet dataset under ``out/rows``: the keys already there, and batches written by atomic rename."""

    def __init__(self, out: Path, sweep: Sweep, *, batch: int = 200, flush_seconds: float = 10.0, notes: bool = True) -> None:
        pa = _pyarrow()
        self.out = Path(out)
        self.dir = self.out / ROWS
        self.schema = pa.schema([(name, pa.bool_() if kind == "bool" else getattr(pa, kind)()) for name, kind in sweep.columns()])
        self.batch, self.flush_seconds = max(1, int(batch)), float(flush_seconds)
        self.pending: list[dict] = []
        self._written: set[str] = set()  # keys written by this run
        self.on_disk: set[str] = set()  # keys already in the folder when this run began (done_keys)
        self.files_written = 0
        self.rows_written = 0
        self._last_flush = time.monotonic()
        self._lock: IO[str] | None = None
        self.notes = notes  # a note on stderr when the folder's rows were made by other versions

    def open(self, sweep: Sweep) -> None:
        """Create the folder, take its lock, check or write its manifest, remove stale temporary files. A folder of
        another sweep is refused before anything is created in it (it was refused after its rows/ folder and .lock
        file had been made), and again under the lock (a sweep that wrote its manifest meanwhile)."""
        if self.out.exists() and not self.out.is_dir():
            raise SweepError(f"--out {self.out} is a file, not a folder")
        if not self.out.parent.is_dir():
            raise SweepError(f"--out {self.out}: folder {self.out.parent} does not exist")
        mine = sweep.manifest()
        early = read_manifest(self.out)
        if early is not None:
            _check_same_sweep(self.out, early, mine)
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
            self._lock = open(self.out / ".lock", "a")
        except OSError as exc:
            raise SweepError(f"--out {self.out}: cannot write: {exc}") from None
        try:
            fcntl.flock(self._lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self._lock.close()
            self._lock = None
            raise SweepError(f"--out {self.out}: another sweep is writing to this folder") from None
        try:
            old = read_manifest(self.out)
            if old is not None:
                _check_same_sweep(self.out, old, mine)
        except SweepError:
            self.close()  # a refused folder is not kept locked (the Python API may go on to use it)
            raise
        if old is not None and old.get("versions") not in (None, mine["versions"]) and self.notes:
            was, now = _versions_text(old["versions"]), _versions_text(mine["versions"])
            print(f"sweep: {self.out} holds rows made by {was}; this run is {now} (each row names its versions)", file=sys.stderr)
        atomic_write_bytes(self.out / MANIFEST, json.dumps(mine, indent=1).encode())
        for stale in self.dir.glob(".*.tmp"):
            stale.unlink(missing_ok=True)

    def close(self) -> None:
        if self._lock is not None:
            self._lock.close()
            self._lock = None

    def done_keys(self) -> tuple[set[str], set[str]]:
        """Keys of the rows already written, and of those among them whose outcome is not 'reached'."""
        import pyarrow.compute as pc

        keys: set[str] = set()
        not_reached: set[str] = set()
        for f in _row_files(self.dir):
            table = _read_batch(f, self.schema.names, columns=["key", "outcome"])
            keys.update(table.column("key").to_pylist())
            bad = pc.fill_null(pc.not_equal(table.column("outcome"), "reached"), True)
            not_reached.update(table.filter(bad).column("key").to_pylist())
        self.on_disk = keys
        return keys, not_reached

    def add(self, rows: Iterable[dict]) -> None:
        self.pending.extend(rows)
        if len(self.pending) >= self.batch or time.monotonic() - self._last_flush >= self.flush_seconds:
            self.flush()

    def tick(self) -> None:
        if self.pending and time.monotonic() - self._last_flush >= self.flush_seconds:
            self.flush()

    def flush(self) -> None:
        """Write the pending rows as one Parquet file (temporary name, fsync, rename).

        Ctrl-C and SIGTERM are held back until the file is in place and the rows are marked written, so an
        interrupt can neither lose the batch nor make the final flush write it twice.
        """
        self._last_flush = time.monotonic()
        # A task re-run because one of its paths is new (a smoother added to the sweep) returns every path's row:
        # those already in the folder are not written twice.
        self.pending = [r for r in self.pending if r["key"] not in self._written and r["key"] not in self.on_disk]
        if not self.pending:
            return
        with _interrupts_deferred():
            self._write()

    def _write(self) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        names = self.schema.names
        table = pa.Table.from_pylist([{n: r.get(n) for n in names} for r in self.pending], schema=self.schema)
        name = f"part-{time.time_ns():016x}-{os.getpid()}-{self.files_written:05d}.parquet"
        final = self.dir / name
        # Not foam_mj.atomic.atomic_path: its temporary name keeps the ".parquet" suffix, and DuckDB's
        # 'DIR/rows/*.parquet' (like pathlib's glob) matches hidden files, so a batch cut short by a kill
        # would break every query. Ours ends in ".tmp", and the next sweep on DIR removes it.
        tmp = self.dir / f".{name}.tmp"
        try:
            pq.write_table(table, tmp)
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            os.replace(tmp, final)
            dfd = os.open(self.dir, os.O_RDONLY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)
        except OSError as exc:  # a full disk, a folder gone read-only: exit 2 like any output that cannot be written
            reason = os.strerror(exc.errno) if exc.errno else " ".join(str(exc).split())
            n = len(self.pending)
            raise OutputError(
                f"--out {self.out}: could not write a batch of {n} row{'s' * (n != 1)} to {self.dir}: {reason}; "
                "the batches written before are kept (free space, then run the same command again)"
            ) from None
        finally:
            if tmp.exists():
                tmp.unlink()
        self._written.update(r["key"] for r in self.pending)
        self.rows_written += len(self.pending)
        self.files_written += 1
        self.pending = []


class _interrupts_deferred:
    """Hold SIGINT and SIGTERM back for the duration of the block (main thread only), then act on them."""

    def __enter__(self):
        import threading

        self.saved: dict = {}
        self.got: list[int] = []
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self.saved[sig] = signal.signal(sig, lambda signum, frame: self.got.append(signum))
        return self

    def __exit__(self, *exc) -> None:
        for sig, handler in self.saved.items():
            signal.signal(sig, handler)
        if self.got:
            handler = self.saved.get(self.got[0])
            if callable(handler):
                handler(self.got[0], None)
            elif handler != signal.SIG_IGN:
                raise KeyboardInterrupt


def read_rows(out: str | Path, columns: Iterable[str] = ("key",)):
    """Every row of a sweep folder as one pyarrow Table; every file must hold ``columns`` (the manifest's).
    SweepError when there is no row: no Parquet file, or only files of 0 rows."""
    pa = _pyarrow()
    rows = Path(out) / ROWS
    files = _row_files(rows)
    if not files:
        raise SweepError(f"{out}: no rows to report: no Parquet file in {rows}")
    table = pa.concat_tables([_read_batch(f, columns) for f in files], promote_options="default")
    if table.num_rows == 0:  # was "wrote 0 figure(s)", exit 0
        raise SweepError(f"{out}: no rows to report: the {len(files)} Parquet file(s) in {rows} hold 0 rows")
    return table
