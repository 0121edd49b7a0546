"""What every subcommand of ``torchirid`` shares: the parser class and its one error style,
the help formatter, the number parsers, the checks of names and grids, progress bars.

One error style: a bad argument — an argparse error, or a ``ValueError`` raised by a command
or by the library about an argument, an ``--out`` that cannot be written included — prints
exactly one line on stderr, ``torchirid <subcommand>: error: <message>``, and ends with exit
status 2 (no usage dump, no traceback). A write that fails after the checks (a full disk) prints
the same kind of line and exits 1.
"""

from __future__ import annotations

import argparse
import functools
import math
import os
import sys

from .. import _checks

PROG = "torchirid"
#: exit status of a bad argument (argparse's own; an --out that cannot be written too), and of
#: a write that fails after the checks (a full disk) or an unreachable scheduler
USAGE_ERROR = 2
WRITE_ERROR = 1
POLARIZATIONS = ("s", "p", "unpolarized")

__all__ = [
    "POLARIZATIONS",
    "PROG",
    "USAGE_ERROR",
    "WRITE_ERROR",
    "ArgumentParser",
    "HelpFormatter",
    "add_command_parser",
    "add_preview_option",
    "add_size_option",
    "cannot_write",
    "check_name",
    "check_out",
    "check_range",
    "check_size",
    "count",
    "fail",
    "index",
    "nonnegative",
    "number",
    "one_line",
    "parse_wavelengths",
    "positive",
    "progress_bar",
    "reports_bad_arguments",
    "resolve_preview",
]


def one_line(message) -> str:
    """``message`` on one line: newlines and runs of blanks become single spaces."""
    return " ".join(str(message).split())


def fail(command: str, message, status: int = USAGE_ERROR) -> int:
    """Print ``torchirid <command>: error: <message>`` (one line) on stderr; return ``status``."""
    prefix = f"{PROG} {command}" if command else PROG
    print(f"{prefix}: error: {one_line(message)}", file=sys.stderr)
    return status


def cannot_write(command: str, directory, exc: OSError) -> int:
    """The one-line error of a write that failed after :func:`check_out` passed (a full disk, a
    file name taken by a folder); returns the exit status 1."""
    return fail(command, f"cannot write to --out {directory}: {exc}", WRITE_ERROR)


def check_out(path, *, file: bool = False, option: str = "--out") -> None:
    """ValueError naming ``option`` unless the outputs can be written at ``path``: a folder
    (created later if missing) or, with ``file``, a file in a folder. Checked before any work —
    a slow command does not compute for minutes and then fail to write — and without creating
    anything: ``path`` (or the folder of a file) must be a folder or not exist yet, and its
    nearest existing parent must be a folder this process may write into."""
    given = os.fspath(path)
    target = os.path.abspath(given)
    if file:
        if os.path.isdir(target):
            raise ValueError(f"{option} {given}: is a folder; give a file name")
        folder = os.path.dirname(target)
    else:
        folder = target
    if os.path.lexists(folder) and not os.path.isdir(folder):
        raise ValueError(f"{option} {given}: {folder} is a file, not a folder; choose another {option}")
    existing = folder
    while not os.path.lexists(existing):
        existing = os.path.dirname(existing)
    if not os.path.isdir(existing):
        raise ValueError(f"{option} {given}: cannot create a folder there, {existing} is a file; choose another {option}")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ValueError(f"{option} {given}: {existing} is not writable (permission denied); choose another {option}")


class ArgumentParser(argparse.ArgumentParser):
    """An argparse parser whose usage errors are one line, ``<prog>: error: <message>``, and
    exit status 2 (argparse's default prints the usage first)."""

    def error(self, message):  # noqa: D102 (argparse API)
        self.exit(USAGE_ERROR, f"{self.prog}: error: {one_line(message)}\n")


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Show defaults and keep the hand-made line breaks of descriptions and epilogs.

    The default is appended as ``(default: X)`` except where it would mislead or repeat: a flag
    (``store_true`` / ``store_false``: its help says in words what it does, and ``--no-white
    (default: True)`` read as if the row were off), an option whose help already states its
    default, and a default of None (the help says what happens then)."""

    def _get_help_string(self, action):
        if (action.default is None or action.default is argparse.SUPPRESS or not action.option_strings
                or action.nargs == 0 or "default" in (action.help or "").lower()):
            return action.help
        if isinstance(action.default, (list, tuple)):
            return f"{action.help} (default: {' '.join(map(str, action.default))})"
        return super()._get_help_string(action)


def add_command_parser(subparsers, name: str, **kwargs) -> argparse.ArgumentParser:
    """``subparsers.add_parser(name, ...)`` with the program name ``torchirid <name>`` (the
    prefix of its error lines) and the help formatter.

    The subparser has its parent's class: :class:`ArgumentParser` under :func:`build_parser
    <torchirid.app.cli.build_parser>` (one-line errors); a plain argparse parent (a test
    registering one command) keeps argparse's behaviour.
    """
    kwargs.setdefault("prog", f"{PROG} {name}")
    kwargs.setdefault("formatter_class", HelpFormatter)
    return subparsers.add_parser(name, **kwargs)


def reports_bad_arguments(command: str):
    """Decorator of a command's ``run(args) -> int``: a ``ValueError`` raised inside (a bad
    argument, named by the command or the library) becomes the one-line error and status 2."""

    def wrap(run):
        @functools.wraps(run)
        def checked(args) -> int:
            try:
                return run(args)
            except ValueError as exc:
                return fail(command, exc)

        return checked

    return wrap


# ----------------------------------------------------------------------------- numbers
def number(text: str) -> float:
    """A finite real number (the library checks its range and names the parameter)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def positive(text: str) -> float:
    """A finite number > 0."""
    value = number(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return value


def nonnegative(text: str) -> float:
    """A finite number >= 0."""
    value = number(text)
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}")
    return value


#: the shortest length (nm) taken at face value on the command line (the library's)
MIN_LENGTH_NM = _checks.MIN_LENGTH_NM


def _length(text: str, allow_zero: bool) -> float:
    value = number(text)
    if value < 0 or (value == 0 and not allow_zero):
        raise argparse.ArgumentTypeError(f"expected a length in nm {'>= 0' if allow_zero else '> 0'}, got {text!r}")
    if 0 < value < MIN_LENGTH_NM:
        raise argparse.ArgumentTypeError(
            f"expected a length in nm, got {text!r}: lengths are in nm (metres or micrometres? "
            f"300 nm is 300, not 3e-7 or 0.3)")
    return value


def length(text: str) -> float:
    """A length in nm, finite, >= 0, not below MIN_LENGTH_NM unless 0 (a unit mistake)."""
    return _length(text, allow_zero=True)


def positive_length(text: str) -> float:
    """A length in nm, finite, > 0, not below MIN_LENGTH_NM (a unit mistake)."""
    return _length(text, allow_zero=False)


def whole_number(minimum: int, why: str = ""):
    """The argparse type of a whole number >= ``minimum`` (``why``: a reason added to the message
    of a value below it, e.g. "a gradient needs two angles")."""
    reason = f" ({why})" if why else ""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number >= {minimum}, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected a whole number >= {minimum}{reason}, got {value}")
        return value

    return parse


#: a whole number >= 1
count = whole_number(1)


def index(text: str):
    """A refractive index n or n + iκ from the command line: ``1.5``, ``1.5+0.02j`` (finite;
    the library checks κ >= 0)."""
    try:
        z = complex(text.replace(" ", "").replace("i", "j"))
    except ValueError:
        z = None
    if z is None or not (math.isfinite(z.real) and math.isfinite(z.imag)):
        raise argparse.ArgumentTypeError(
            f"expected a refractive index such as 1.5 or 1.5+0.02j (n + iκ), got {text!r}"
        )
    return z.real if z.imag == 0 else z


# ----------------------------------------------------------------------------- checks
def parse_wavelengths(raw) -> tuple[float, float, int]:
    """``--wavelengths MIN MAX COUNT`` (strings) → ``(min_nm, max_nm, count)``; ValueError if bad."""
    lo, hi, n = raw
    try:
        lo, hi = float(lo), float(hi)
    except ValueError:
        raise ValueError(f"--wavelengths: MIN and MAX must be numbers (nm); got {raw[0]!r} {raw[1]!r}") from None
    try:
        n = count(n)
    except argparse.ArgumentTypeError as e:
        raise ValueError(f"--wavelengths COUNT: {e}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo <= 0 or hi < lo:
        raise ValueError(f"--wavelengths: need 0 < MIN <= MAX (nm); got MIN={lo:g} MAX={hi:g}")
    if n > 1 and hi == lo:
        raise ValueError("--wavelengths: MIN == MAX needs COUNT 1")
    return lo, hi, n


def check_range(pair, option: str, unit: str = "") -> tuple[float, float]:
    """``MIN MAX`` of an option (numbers already parsed) as ``(min, max)``; ValueError naming the
    option unless MIN < MAX (``torchirid fit-film --thickness-range 500 100``)."""
    lo, hi = pair
    if not lo < hi:
        raise ValueError(f"{option}: MIN must be < MAX{f' ({unit})' if unit else ''}; got {lo:g} {hi:g}")
    return lo, hi


def check_name(name: str, option: str = "--name") -> None:
    """A file stem: not empty, no directory separator; ValueError otherwise."""
    if not name or os.sep in name or (os.altsep and os.altsep in name):
        raise ValueError(f"{option} must be a plain file stem, got {name!r}")


# ----------------------------------------------------------------------------- sizes
#: a grid larger than this (points, or bytes of output) runs only with --yes
LARGE_POINTS = 10**8
LARGE_BYTES = 1 << 30


def human_bytes(n: float) -> str:
    """``n`` bytes as ``'8.0 GB'`` (powers of 1000, as disks are sold)."""
    for unit in ("bytes", "kB", "MB", "GB", "TB", "PB"):
        if n < 1000 or unit == "PB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1000


def add_size_option(parser: argparse.ArgumentParser) -> None:
    """``--yes``: run a grid over :data:`LARGE_POINTS` points or :data:`LARGE_BYTES` of output."""
    parser.add_argument("--yes", action="store_true",
                        help=f"run even a grid of more than 10^{int(math.log10(LARGE_POINTS))} points or "
                             f"{LARGE_BYTES >> 30} GiB of output (without it such a grid is refused, its size stated)")


def check_size(command: str, what: str, points: int, nbytes: int, *, yes: bool, smaller: str, quiet: bool = False) -> None:
    """Refuse (ValueError, before any work) a grid of more than :data:`LARGE_POINTS` points or
    :data:`LARGE_BYTES` bytes unless ``yes`` (``--yes``); the message states the size and the ways
    on (``smaller``: the options that shrink it, and --yes). With ``yes``, a large grid is announced
    on stderr (unless ``quiet``)."""
    if points <= LARGE_POINTS and nbytes <= LARGE_BYTES:
        return
    size = f"{what}: {points:,} points, {human_bytes(nbytes)}"
    if not yes:
        raise ValueError(f"{size} — more than {LARGE_POINTS:,} points or {LARGE_BYTES >> 30} GiB, which may take "
                         f"long and fill memory or disk; {smaller}, or pass --yes to run it as asked")
    if not quiet:
        print(f"{PROG} {command}: {size} (--yes)", file=sys.stderr, flush=True)


# ----------------------------------------------------------------------------- preview
def add_preview_option(parser: argparse.ArgumentParser, sizes: dict, full: str, quick: str) -> None:
    """``--preview``: the command at the coarse ``sizes`` (``{dest: (full value, preview value)}``,
    options whose default is None so that a value given on the command line wins); ``full`` and
    ``quick`` are the rough durations of the two runs, stated in the help."""
    given = ", ".join(f"--{dest.replace('_', '-')} {small:g}" for dest, (_, small) in sizes.items())
    parser.add_argument("--preview", action="store_true",
                        help=f"a quick, coarse run ({quick}): {given}, unless given; the full run takes {full}")
    parser.set_defaults(preview_sizes=sizes)


def resolve_preview(args) -> None:
    """Set the options of :func:`add_preview_option` left at None: their preview value with
    ``--preview``, else their full value."""
    for dest, (full, small) in args.preview_sizes.items():
        if getattr(args, dest) is None:
            setattr(args, dest, small if args.preview else full)


# ----------------------------------------------------------------------------- progress, outputs
def progress_bar(desc: str, total: int | None = None, unit: str = "step", *, quiet: bool = False, **kwargs):
    """A tqdm bar on stderr (with a total: count, rate and ETA) that appears only after 2 s and
    vanishes when closed; silent with ``quiet`` (``--quiet``) or when stderr is not a terminal."""
    from tqdm.auto import tqdm

    kwargs.setdefault("delay", 2.0)
    kwargs.setdefault("leave", False)
    kwargs.setdefault("file", sys.stderr)
    kwargs.setdefault("disable", True if quiet else None)  # None: off when not a TTY
    return tqdm(total=total, desc=desc, unit=unit, **kwargs)


def setting(text: str):
    """``NAME=VALUE`` (VALUE a JSON value — number, list, true/false — or a bare string) → (name, value)."""
    import json

    name, sep, raw = text.partition("=")
    if not sep or not name.isidentifier():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE (e.g. n1=1.0 or method=envelope); got {text!r}")
    try:
        value = json.loads(raw)
    except ValueError:
        value = raw
    return name, value


def add_scheduler_options(parser: argparse.ArgumentParser, unit: str) -> None:
    """``--scheduler`` ('local' or a Dask address; default this process), ``--workers`` and
    ``--timeout``: where the ``unit``s of a scale-out command run (:mod:`torchirid.scale`)."""
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help=f"where the {unit}s run: 'local' (an embedded Dask cluster) or a scheduler address "
                             "(tcp://HOST:PORT); default: this process")
    parser.add_argument("--workers", type=count, default=2, help="worker processes of --scheduler local (default 2)")
    parser.add_argument("--timeout", type=positive, default=10.0, help="seconds to reach --scheduler (default 10)")


def progress_callback(bar):
    """``progress(done, total)`` that moves a :func:`progress_bar` (the library's ``progress`` callbacks)."""

    def progress(done, total):
        bar.total = total
        bar.n = done
        bar.refresh()

    return progress


def add_output_options(parser: argparse.ArgumentParser, *, figures: bool = True) -> None:
    """``--quiet`` (no progress bar) and, for commands that draw, ``--format png[,pdf,svg]``."""
    parser.add_argument("--quiet", action="store_true", help="no progress bar (there is none when stderr is not a terminal)")
    if figures:
        from .figures._format import FIGURE_FORMATS

        def formats(text: str) -> tuple[str, ...]:
            items = tuple(dict.fromkeys(t.strip().lower().lstrip(".") for t in text.split(",") if t.strip()))
            bad = [t for t in items if t not in FIGURE_FORMATS]
            if not items or bad:
                raise argparse.ArgumentTypeError(f"expected a comma-separated list of {', '.join(FIGURE_FORMATS)}; "
                                                 f"got {text!r}")
            return items

        parser.add_argument("--format", type=formats, default=("png",), metavar="FMT[,FMT]",
                            help="figure file format(s): png, pdf, svg, comma-separated (default png)")


def figure_paths(out, name: str, formats) -> list:
    """``out/name.<fmt>`` for each figure format."""
    from pathlib import Path

    return [Path(out) / f"{name}.{fmt}" for fmt in formats]
