"""``foam-mj view``: a Rerun recording opened in Rerun's viewer, a native window or the web viewer (``--web``), in
its own process group so that Ctrl-C or SIGTERM stops all of it."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from pathlib import Path

from foam_mj.errors import FoamError, file_problem_text


def _has_display() -> bool:
    """Can a native window open here? (Linux/BSD: an X11 or Wayland display; macOS and Windows: yes.)"""
    if sys.platform.startswith(("darwin", "win")):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _free_port(bind: str) -> int:
    """A port the OS reports free on ``bind`` (for ``--web-port 0`` / ``--grpc-port 0``)."""
    import socket

    family = socket.AF_INET6 if ":" in bind else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.bind((bind, 0))
        return int(s.getsockname()[1])


def _check_port(bind: str, port: int, flag: str) -> None:
    """FoamError unless ``port`` can be bound on ``bind`` now: Rerun's viewer said "Address already in use" in a log line
    and exited 1 (an internal error by foam-mj's exit codes) when another viewer held its port."""
    import errno
    import socket

    family = socket.AF_INET6 if ":" in bind else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as a server binds: a port in TIME_WAIT is free
        try:
            s.bind((bind, port))
        except OSError as exc:
            why = "is in use (another viewer?)" if exc.errno == errno.EADDRINUSE else f"cannot be bound: {exc.strerror}"
            raise FoamError(f"{flag} {port} on {bind} {why}: give another port, or 0 for a free one") from None


def _rerun_executable() -> str:
    import shutil

    viewer = Path(sys.executable).with_name("rerun")
    exe = str(viewer) if viewer.exists() else shutil.which("rerun")
    if exe is None:
        raise FoamError("the Rerun viewer ('rerun', shipped with rerun-sdk) was not found on PATH")
    return exe


def console_command(name: str) -> str:
    """How to type the console script ``name`` (``rerun``, ``foam-mj``) in a hint: ``name`` where PATH finds it, else
    the path of the one beside this interpreter (an environment used without activating it, as the README's
    `.venv/bin/foam-mj`: a hint naming plain `foam-mj` or `rerun` there is "command not found")."""
    import shutil

    beside = Path(sys.executable).with_name(name)
    return str(beside) if shutil.which(name) is None and beside.exists() else name


#: The first bytes of every Rerun recording file (its stream header, "RRF2" in the rerun-sdk foam-mj uses).
RRD_MAGIC = b"RRF"
#: A closed recording ends with Rerun's footer marker, then 4 bytes (rerun-sdk 0.41); a file cut short lacks it.
RRD_FOOTER = b"FOOT"


def _check_decodes(p: Path) -> None:
    """FoamError unless Rerun decodes every message of ``p``: a file with its header and footer but damaged between
    (a bad copy, a disk error) was served with Rerun's warnings in its own log format, the viewer showing part of it."""
    from rerun.chunk import RrdReader

    try:
        for _ in RrdReader(p).stream():
            pass
    except Exception as exc:  # Rerun raises RuntimeError ("Failed to read RRD file at ...: Codec error: ...")
        reason = " ".join(str(exc).split()).removeprefix(f"Failed to read RRD file at {p}: ")
        raise FoamError(f"{p} is damaged: Rerun cannot decode it ({reason})") from None


def cmd_view(args: argparse.Namespace) -> int:
    """``foam-mj view``: open a recording in the Rerun viewer (native window, or the web viewer with --web)."""
    p = Path(args.recording)
    problem = file_problem_text(p, "recording")
    if problem:
        raise FoamError(problem)
    if p.suffix.lower() != ".rrd":  # X.RRD too: Rerun's viewer reads the suffix lower-cased
        raise FoamError(f"{p} is not a Rerun recording (.rrd)")
    try:
        with open(p, "rb") as f:
            head = f.read(len(RRD_MAGIC))
            f.seek(max(0, p.stat().st_size - 12))
            tail = f.read(12)
    except OSError as exc:
        raise FoamError(f"{p}: cannot read: {exc.strerror}") from None
    if head != RRD_MAGIC:  # the viewer would open it and show nothing, or an error in its own window
        raise FoamError(f"{p} is not a Rerun recording: it does not start with Rerun's file header {RRD_MAGIC.decode()!r}"
                        f"{' (the file is empty)' if not head else ''}")
    cut = tail[:3] != RRD_MAGIC or tail[4:8] != RRD_FOOTER
    if not cut:
        _check_decodes(p)
    import ipaddress

    try:
        ipaddress.ip_address(args.bind)
    except ValueError:
        raise FoamError(f"--bind must be an IP address (127.0.0.1, 0.0.0.0, ::1), got {args.bind!r}") from None
    if not args.web and not _has_display():
        raise FoamError(
            f"no display (DISPLAY and WAYLAND_DISPLAY are unset): serve the web viewer with `{console_command('foam-mj')} view --web {p}` "
            f"(then open the URL it prints, e.g. through an SSH tunnel), or summarise the file with `{console_command('rerun')} rrd stats {p}`"
        )
    if cut:  # the viewer shows what the file holds, without a word
        print(f"note: {p} does not end with Rerun's footer: the file was cut short (a copy or a run that was stopped); "
              "the viewer shows only what it holds", file=sys.stderr)
    exe = _rerun_executable()
    if not args.web:
        return _run_viewer([exe, str(p), "--bind", args.bind])
    from urllib.parse import quote

    host = "127.0.0.1" if args.bind in ("0.0.0.0", "::") else args.bind
    if args.web_port and args.web_port == args.grpc_port:  # Rerun refused it only once started (exit 1)
        raise FoamError(f"--web-port and --grpc-port are both {args.web_port}: the web viewer and its data server need two ports")
    for flag, port in (("--web-port", args.web_port), ("--grpc-port", args.grpc_port)):
        if port:
            _check_port(args.bind, port, flag)
    web_port, grpc_port = (p or _free_port(args.bind) for p in (args.web_port, args.grpc_port))
    host = f"[{host}]" if ":" in host else host
    url = f"http://{host}:{web_port}?url={quote(f'rerun+http://{host}:{grpc_port}/proxy', safe='')}"
    print(f"serving {p} in Rerun's web viewer (bound to {args.bind}; Ctrl-C stops it): open {url}", flush=True)
    cmd = [exe, str(p), "--serve-web", "--bind", args.bind, "--web-viewer-port", str(web_port), "--port", str(grpc_port)]
    return _run_viewer(cmd)


def _run_viewer(cmd: list[str]) -> int:
    """Run the Rerun viewer in its own process group; Ctrl-C or SIGTERM stops the whole group (the
    ``rerun`` launcher starts the viewer binary as a child: it must not outlive us)."""
    import subprocess

    # Rerun logs each step of serving at INFO (telemetry, loading, hosting, listening), repeating our own line; its
    # warnings and errors still show. A user's RUST_LOG wins.
    env = {**os.environ, "RUST_LOG": os.environ.get("RUST_LOG", "warn")}
    proc = subprocess.Popen(cmd, start_new_session=True, env=env)
    previous = signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        return proc.wait()
    except KeyboardInterrupt:
        for sig in (signal.SIGTERM, signal.SIGKILL):
            try:
                os.killpg(proc.pid, sig)
                proc.wait(timeout=10)
                break
            except (ProcessLookupError, subprocess.TimeoutExpired):
                continue
        raise
    finally:
        signal.signal(signal.SIGTERM, previous)
