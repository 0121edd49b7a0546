"""The ``torchirid`` command: one parser, one registry of subcommands, one error style.

On the command line, wavelengths and thicknesses are in nm and incidence angles in degrees
(the library itself takes cos θ). Each subcommand is a module of
:mod:`torchirid.app.commands` registered in :data:`COMMANDS`; its figures are in
:mod:`torchirid.app.figures`.

Errors: a bad argument — an argparse error, a ``ValueError`` from the command or the
library about an argument, or an ``--out`` that cannot be written (checked before the command
runs) — prints exactly one line on stderr, ``torchirid <subcommand>: error: <message>`` (no
usage, no traceback), and ends with exit status 2: :func:`main` raises ``SystemExit(2)`` as
argparse itself does. A write that fails after the checks (a full disk), an unreachable
scheduler or a ``fit-batch`` in which no file was fitted prints the same kind of line and
returns 1.
"""

from __future__ import annotations

import argparse
import sys

from .._version import __version__
from . import _args
from .commands import (build_table, design, explore, film_table, fit_batch, fit_film, gradients, montecarlo, render_mitsuba, render_sphere,
                       scatterogram, spectrum, thin_film)

__all__ = ["COMMANDS", "build_parser", "main"]

#: The subcommands, in the order of ``torchirid --help``: modules with ``NAME``,
#: ``add_parser(subparsers)`` and ``run(args) -> int``.
COMMANDS = (spectrum, gradients, scatterogram, film_table, render_sphere, render_mitsuba, thin_film, fit_film, build_table, fit_batch,
            montecarlo, design, explore)

#: the subcommands whose ``--out`` is a file (the others write into an ``--out`` folder)
FILE_OUTPUTS = frozenset({"fit-batch", "montecarlo"})


def build_parser() -> argparse.ArgumentParser:
    """The parser of ``torchirid`` with every subcommand of :data:`COMMANDS`."""
    parser = _args.ArgumentParser(
        prog=_args.PROG,
        formatter_class=_args.HelpFormatter,
        description=(
            "torchirid: exact, differentiable reflectance of iridescent materials\n"
            "(thin films, multilayers, Bragg mirrors) in PyTorch.\n\n"
            "Units on the command line: wavelengths and thicknesses in nm, incidence\n"
            "angles in degrees (the Python API takes cos θ)."
        ),
        epilog=(
            "examples:\n"
            "  torchirid spectrum                       # Fourneau et al. 2024, Fig. 1 Bragg mirror\n"
            "  torchirid spectrum --kind thin-film --n-film 1.33 --thickness 400\n"
            "  torchirid gradients                      # Fourneau et al. 2024, Fig. 4 atlas\n"
            "  torchirid scatterogram                   # jewel-beetle scatterograms, Fig. 9\n"
            "  torchirid thin-film                      # Kneiphof et al. 2019 Fig. 7: thin films under IBL\n"
            "  torchirid render-sphere                  # Hirayama 2000 Fig. 8: coated rough spheres\n"
            "  torchirid film-table --stack teapot --check  # Hirayama 2000 §5: k_r/k_t table → LUT .npz\n"
            "  torchirid fit-film CUBE.npz --out fit/   # Kobayashi: film n and thickness map from a hyperspectral cube\n"
            "  torchirid design examples/design/mirror.toml --out mirror/  # inverse design of a stack from a TOML spec\n"
            "  torchirid spectrum --help                # all options"
        ),
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for command in COMMANDS:
        command.add_parser(subparsers)
    return parser


#: packages of the ``app`` extra (pyproject.toml): the command's figures and progress bars
_APP_EXTRA = ("matplotlib", "tqdm")


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``torchirid`` command; returns the exit status (0, or 1 for a write that
    failed after the checks, an unreachable scheduler, a batch with no file fitted) and raises
    ``SystemExit(2)`` for a bad argument (an ``--out`` that cannot be written included), after its
    one-line message."""
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    if extra:  # reported by the subcommand's parser, so that the line names the subcommand
        args.parser.error(f"unrecognized arguments: {' '.join(extra)}")
    if getattr(args, "out", None) is not None:  # every command that writes: before any work
        try:
            _args.check_out(args.out, file=args.command in FILE_OUTPUTS)
        except ValueError as error:
            raise SystemExit(_args.fail(args.command, error)) from None
    try:
        status = args.func(args)
    except ModuleNotFoundError as error:
        if error.name not in _APP_EXTRA:
            raise
        # the library does not need matplotlib or tqdm; the command's figures and bars do
        print(f"torchirid: this command needs {error.name}, part of the application's extra: "
              f"pip install 'torchirid[app]'", file=sys.stderr)
        raise SystemExit(_args.USAGE_ERROR) from None
    if status == _args.USAGE_ERROR:
        raise SystemExit(status)
    return status


if __name__ == "__main__":
    raise SystemExit(main())
