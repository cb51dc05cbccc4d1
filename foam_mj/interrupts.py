"""How the ``foam-mj`` process stops: Ctrl-C and SIGTERM become a KeyboardInterrupt (exit 130, temporary files
removed, no output half-written) while a command runs, and end the process at once after it has returned."""

from __future__ import annotations

import os
import signal
import sys

EXIT_INTERRUPTED = 130


def install() -> None:
    """Make Ctrl-C and `kill` (SIGTERM) stop the command as Ctrl-C does (SIGTERM ended the process at once, exit
    143, leaving a write's temporary file); from the interpreter's exit on, both are ignored (:func:`ignore_signals`)."""
    import atexit

    signal.signal(signal.SIGTERM, interrupt)
    signal.signal(signal.SIGINT, interrupt)
    atexit.register(ignore_signals)  # registered first, so it runs after every library's exit handler
    if getattr(sys.unraisablehook, "__name__", "") != "_unraisable":
        _UNRAISABLE[:] = [sys.unraisablehook]
        sys.unraisablehook = _unraisable


#: The unraisable-exception hook :func:`install` replaced (the one :func:`_unraisable` passes other exceptions on to).
_UNRAISABLE: list = []


def _unraisable(unraisable) -> None:
    """``sys.unraisablehook`` of the ``foam-mj`` process. Python runs a signal handler wherever the main thread is,
    also in a weak reference's callback or a finalizer (importlib's module-lock callback, a ``__del__``), whose
    exceptions it cannot raise: the KeyboardInterrupt of a Ctrl-C or `kill` was printed as "Exception ignored in ...
    Traceback" and dropped, and the command ran on and wrote its files (exit 0, or 3 after a plan's whole budget). Such
    an interruption is delivered again a millisecond later (SIGALRM), once this hook has returned: a signal raised in
    the hook itself would be handled in it and dropped the same way."""
    if issubclass(unraisable.exc_type, KeyboardInterrupt) and SIGNALLED and not RETURNED:
        if hasattr(signal, "setitimer"):
            signal.signal(signal.SIGALRM, _interrupt_again)
            signal.setitimer(signal.ITIMER_REAL, 0.001)
        return
    (_UNRAISABLE[0] if _UNRAISABLE else sys.__unraisablehook__)(unraisable)


def _interrupt_again(signum: int, frame) -> None:
    """The interruption :func:`_unraisable` saw dropped, raised again (or, once the command has returned, the exit)."""
    if RETURNED:
        exit_now(EXIT_INTERRUPTED)
    raise KeyboardInterrupt


def ignore_signals() -> None:
    """The ``foam-mj`` process's last exit handler: ignore Ctrl-C and SIGTERM from here on. Python then clears its
    modules with the default handlers back (a SIGTERM there killed the finished process, exit 143); an ignored signal
    stays ignored, and the process ends with its command's exit code."""
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "SIGALRM"):  # an interruption delivered again (_unraisable) a moment too late
        signal.signal(signal.SIGALRM, signal.SIG_IGN)


def exit_now(code: int) -> None:
    """End the process with ``code`` at once, its standard streams flushed (:data:`foam_mj.cli.FAST_EXIT_COMMANDS`)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (`| head`) or a closed stream: nothing more to show
            pass
    os._exit(code)


#: The signals (SIGINT, SIGTERM) the ``foam-mj`` process has received: once the user has asked it to stop, an
#: exception on the way out (a library that catches the KeyboardInterrupt and raises its own) is still an interruption.
SIGNALLED: list[int] = []

#: Set once the command has returned (or failed): its files are complete or removed.
RETURNED: list[bool] = []


def interrupt(signum: int, frame) -> None:
    """The ``foam-mj`` process's handler of Ctrl-C and SIGTERM: note the signal, then stop as Ctrl-C does; once the
    command has returned, end the process at once with 130 (a KeyboardInterrupt raised in the interpreter's teardown,
    joining threads or in a library's exit handler, printed "Exception ignored ... Traceback" and exited 0)."""
    SIGNALLED.append(signum)
    if RETURNED:
        exit_now(EXIT_INTERRUPTED)
    raise KeyboardInterrupt


def caused_by_interrupt(exc: BaseException) -> bool:
    """True when a KeyboardInterrupt (Ctrl-C, SIGTERM) is among the causes of ``exc``, or the process was signalled."""
    if SIGNALLED:
        return True
    seen: set[int] = set()
    cause: BaseException | None = exc
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return True
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return False


def forget_handled_interrupt() -> None:
    """Clear CPython's note of an unhandled KeyboardInterrupt once the command has handled it. CPython notes one whenever
    a KeyboardInterrupt leaves code run by ``exec`` of a string (dataclasses and namedtuples build their methods so
    while a module loads), caught later or not, and at the end of a ``python -m`` process kills itself with SIGINT: a
    Ctrl-C or SIGTERM in those moments printed "foam-mj: interrupted" and then ended by SIGINT (status -2 to a parent,
    not 130). A string run by ``exec`` that completes clears the note."""
    exec("pass", {})
