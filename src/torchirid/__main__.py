"""``python -m torchirid``: the same as the ``torchirid`` command."""

from torchirid.app.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
