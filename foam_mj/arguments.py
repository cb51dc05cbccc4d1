"""Command-line arguments: the parser whose errors are one line (exit 2), and the argument types the commands share
(``--seed``, ``--port``, a configuration such as ``--start``)."""

from __future__ import annotations

import argparse
import re
import sys

from foam_mj.errors import FoamError


#: Seeds are non-negative 64-bit integers (as in a scenario TOML, whose integers are 64-bit).
MAX_SEED = 2**63 - 1


def non_ascii_text(text: str) -> str:
    """'' for a number written in ASCII, else what names its first other character (`` ('١' is U+0661 ARABIC-INDIC
    DIGIT ONE)``). Python's float() and int() read any script's decimal digits (``float('١٢')`` is 12.0, ``'１２'``
    full-width likewise), which TOML, JSON and every other reader of a scenario or result refuse; a number on the
    command line is ASCII too, so that what a command line means does not depend on the font it was typed in."""
    import unicodedata

    other = next((c for c in text if not c.isascii()), None)
    if other is None:
        return ""
    return f" ({other!r} is U+{ord(other):04X} {unicodedata.name(other, 'an unnamed character')}: write numbers with ASCII characters, 0-9)"


def _ascii_only(text: str, expected: str) -> None:
    """Refuse, as an argparse type does, ``text`` written with a non-ASCII character: 'must be {expected}, got ...'."""
    why = non_ascii_text(text)
    if why:
        raise argparse.ArgumentTypeError(f"must be {expected}, got {text!r}{why}")


def real_number(text: str) -> float:
    """argparse type of a float option (``--delta``, ``--time-limit``, ...): Python's float() of ASCII text without
    ``_`` (float() reads ``0_005`` as 5.0: a margin typed for 0.005 m became 5 m)."""
    _ascii_only(text, "a number")
    try:
        if "_" in text:
            raise ValueError
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None


def whole_number(text: str) -> int:
    """argparse type of an integer option (``--workers``, ``--dpi``, ...): Python's int() of ASCII text."""
    _ascii_only(text, "an integer")
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None


def seed_number(text: str) -> int:
    """argparse type of ``--seed``: an integer in [0, 2**63 - 1], decimal (leading zeros too: ``007``, which
    ``int(text, 0)`` refuses) or as Python spells it (``0x10``, ``1_000``), in ASCII."""
    _ascii_only(text, "an integer")
    try:
        value = int(text, 10)
    except ValueError:
        try:
            value = int(text, 0)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be an integer in [0, 2**63 - 1], got {text}")
    return value


class UsageError(FoamError):
    """A command-line argument argparse refused (main prints it as one line and returns 2)."""


class HelpFormatter(argparse.HelpFormatter):
    """argparse's help layout, but lines break at spaces only: argparse's wrapping also broke at hyphens, so
    ``foam-mj-<scenario>.rrd`` read 'foam-' at the end of one line and 'mj-<scenario>.rrd' on the next."""

    def _split_lines(self, text, width):
        import textwrap

        return textwrap.wrap(" ".join(text.split()), width, break_on_hyphens=False, break_long_words=False)

    def _fill_text(self, text, width, indent):
        import textwrap

        return textwrap.fill(" ".join(text.split()), width, initial_indent=indent, subsequent_indent=indent,
                             break_on_hyphens=False, break_long_words=False)


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (exit 2), like every other foam-mj error, help lines broken at spaces only, and
    no abbreviated options: argparse took ``--sce obstacle`` for ``--scene`` (any unambiguous prefix), so a flag added
    later could change what an existing command line means; an option is now named in full (``--scene``) or refused."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str):  # noqa: D401 - argparse's hook
        raise UsageError(f"{self.prog}: error: {' '.join(message.split())}{self._greedy_hint(message)}{self._near_hint(message)} "
                         f"(see {self.prog} --help)")

    def _near_hint(self, message: str) -> str:
        """'; did you mean ...?' for a mistyped command (`foam-mj plna`) or option (`plan --sceen`), as every other
        name foam-mj checks is answered (argparse listed the choices, or said only 'unrecognized arguments')."""
        import difflib

        choice = re.match(r"argument \S+: invalid choice: '([^']*)' \(choose from (.*)\)$", " ".join(message.split()))
        if choice:
            wrong, known, cutoff = [choice.group(1)], re.findall(r"'([^']*)'", choice.group(2)), 0.75
        elif message.startswith("unrecognized arguments: "):
            wrong = [a.split("=", 1)[0] for a in message.split()[2:] if a.startswith("--")]
            known, cutoff = [o for o in self._option_string_actions if o.startswith("--")], 0.8  # their '--' alike: replay --no-rrd is no --rrd
        else:
            return ""
        near = [m[0] for w in wrong if (m := difflib.get_close_matches(w, known, n=1, cutoff=cutoff))]
        return f"; did you mean {', '.join(near)}?" if near else ""

    def _greedy_hint(self, message: str) -> str:
        """For 'the following arguments are required' after an option of several values: which option took them.
        `foam-mj figures --paths optimal r.json figs` said only 'the following arguments are required: RESULT.json,
        DIR': --paths had taken the file and the folder as path names."""
        args = getattr(self, "_last_args", None) or []
        if not message.startswith("the following arguments are required") or "--" in args:
            return ""
        greedy = [i for i, a in enumerate(args) if getattr(self._option_string_actions.get(a), "nargs", None) in ("+", "*")]
        if not greedy:
            return ""
        i = greedy[-1]
        values = [a for a in args[i + 1 :] if not a.startswith("-")]
        if not values:
            return ""
        return (f"; {args[i]} took every value after it ({', '.join(values)}): give the positional arguments before "
                f"{args[i]}, or end its values with --")

    def parse_args(self, args=None, namespace=None):
        """argparse's, but an argument the command does not take is refused by that command's parser: argparse's
        top-level parser said 'foam-mj: error: unrecognized arguments: --no-rrd (see foam-mj --help)' for
        ``foam-mj replay r.json --no-rrd``, whose flags that help does not list. An option before the command that
        this parser does not take is named: argparse said only 'the following arguments are required: COMMAND' for
        ``foam-mj --bogus``."""
        args = sys.argv[1:] if args is None else list(args)
        commands = [a for a in self._actions if isinstance(a, argparse._SubParsersAction)]
        if commands:
            for arg in args:
                if arg == "--" or not arg.startswith("-"):
                    break
                if arg.split("=", 1)[0] not in self._option_string_actions:
                    self.error(f"unrecognized arguments: {arg}")
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            command = commands[0].choices.get(getattr(parsed, commands[0].dest, "")) if commands else None
            (command or self).error(f"unrecognized arguments: {' '.join(extras)}")
        return parsed

    def parse_known_args(self, args=None, namespace=None):
        """argparse's, but a value that starts with a minus sign stays its option's value: argparse took
        ``--start "-0.1,0.3,0.08"`` (or ``--delta -1e-3``) for an option of its own and said only 'expected one
        argument'; it passes a lone negative decimal or a value with a space. Here such a value is attached to an
        option that takes one (``--start=-0.1,0.3,0.08``), up to a ``--``. A configuration given unquoted
        (``--start 0.2 -0.3 0.08``: argparse said 'unrecognized arguments: -0.3 0.08') is read as one value: the
        numbers that follow a configuration option (``metavar`` ``CONFIGURATION_METAVAR``) are joined."""
        self._last_args = None if args is None else list(args)
        if args is not None:
            args = list(args)
            i = 0
            while i < len(args) - 1 and args[i] != "--":
                action = self._option_string_actions.get(args[i])
                if action is not None and action.nargs is None:
                    end = i + 2
                    if action.metavar == CONFIGURATION_METAVAR:
                        while end < len(args) and _is_number_list(args[end]):
                            end += 1
                    if end > i + 2 or _NEGATIVE_VALUE.match(args[i + 1]) or self._file_name_value(action, args[i + 1]):
                        args[i:end] = [f"{args[i]}={' '.join(args[i + 1 : end])}"]
                i += 1
        return super().parse_known_args(args, namespace)

    def _file_name_value(self, action: argparse.Action, value: str) -> bool:
        """True for a file or folder name that begins with one minus sign (``--out -.csv``, ``--json -r.json``) given to
        an option that takes a file or folder (its metavar in :data:`FILE_METAVARS`): argparse said 'expected one
        argument'. A flag of this command (``--out --hz``, ``--out -h``) stays a flag."""
        return (action.metavar in FILE_METAVARS and len(value) > 1 and value.startswith("-") and not value.startswith("--")
                and value.split("=", 1)[0] not in self._option_string_actions)


#: The metavars of the options whose value is a file or folder name, which may begin with a minus sign.
FILE_METAVARS = frozenset({"FILE", "DIR", "FIGDIR", "OUT.json", "OUT.rrd", "ROBOT.xml", "SCENE"})

#: The metavar of an option whose value is a configuration (--start, --goal, --q): numbers, quoted or not.
CONFIGURATION_METAVAR = '"q1 q2 ..."'


def _is_number_list(text: str) -> bool:
    """True for "0.3", "-1e-3" or "0.1,0.2": a further number of an unquoted configuration."""
    parts = text.replace(",", " ").split()
    try:
        [float(v) for v in parts]
    except ValueError:
        return False
    return bool(parts)


#: A value that begins like a negative number ("-0.1,0.3", "-1e-3", "-.5", "-inf"), which argparse reads as an option.
_NEGATIVE_VALUE = re.compile(r"-(\.?[0-9]|inf|nan)", re.IGNORECASE)


def port_number(text: str) -> int:
    """argparse type of ``--web-port`` and ``--grpc-port``: an integer in [0, 65535]."""
    _ascii_only(text, "a port number")
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a port number, got {text!r}") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be a port number in [0, 65535], got {value}")
    return value
