"""``python -m torchirid``: the same as the ``torchirid`` command."""

from torchirid.cli import main

raise SystemExit(main())
