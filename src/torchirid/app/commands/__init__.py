"""The subcommands of ``torchirid``, one module each.

Every module has ``NAME`` (the subcommand), ``add_parser(subparsers)`` (registers it on an
argparse subparsers object, with ``func=run`` and ``parser`` as defaults, and returns its
parser) and ``run(args) -> int`` (does the work; exit status 0, 1 for a write that failed, 2 for a
bad argument after printing the one-line error). :func:`torchirid.app.cli.main` checks ``--out``
before ``run`` (status 2 if it cannot be written). The registry is
:data:`torchirid.app.cli.COMMANDS`.
"""

from . import (build_table, explore, film_table, fit_batch, fit_film, gradients, montecarlo, render_mitsuba, render_sphere, scatterogram, spectrum,
               thin_film)

__all__ = ["build_table", "explore", "film_table", "fit_batch", "fit_film", "gradients", "montecarlo", "render_mitsuba", "render_sphere", "scatterogram",
           "spectrum", "thin_film"]
