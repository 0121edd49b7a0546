"""The application: the ``torchirid`` command and its figures, built on the library.

- :mod:`torchirid.app.cli` — :func:`main`, the parser and the registry of subcommands;
- :mod:`torchirid.app.commands` — one module per subcommand (``spectrum``, ``gradients``,
  ``scatterogram``, ``film-table``, ``render-sphere``, ``thin-film``, ``fit-film``);
- :mod:`torchirid.app.figures` — the figures (matplotlib, without pyplot) and their PNG /
  ``.npz`` writers.

The library (every other part of :mod:`torchirid`) never imports this package, argparse,
matplotlib or tqdm; ``import torchirid`` does not import it either.
"""

from .cli import main

__all__ = ["main"]
