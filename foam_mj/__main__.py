"""The ``foam-mj`` command's entry point, also run by ``python -m foam_mj``: Ctrl-C and SIGTERM end it cleanly from here on.

:func:`foam_mj.cli.main` installs the command's own handlers (:mod:`foam_mj.interrupts`), but only once the command
line's module has loaded: argparse, pathlib and ipaddress take 20-70 ms, and ``python -m foam_mj.cli`` compiles that
module's source on every run (about 75 ms more). A Ctrl-C in that time printed a KeyboardInterrupt traceback of an
import and exited 1. Until main replaces them, both signals now print "foam-mj: interrupted" and end the process with
130: nothing has been written yet. (A signal during the interpreter's own start-up, before this line, is Python's.)
"""

import os
import signal
import sys


def _interrupted_while_loading(signum, frame) -> None:
    os.write(2, b"foam-mj: interrupted\n")
    os._exit(130)  # foam_mj.interrupts.EXIT_INTERRUPTED, not imported: this handler must be in place first


for _signal in (signal.SIGINT, signal.SIGTERM):
    signal.signal(_signal, _interrupted_while_loading)

from foam_mj.cli import main  # noqa: E402  (after the handlers, on purpose)

if __name__ == "__main__":
    sys.exit(main())
