"""Atomic file writes: every file torchirid writes (LUTs, figures, ``.npz`` products, fitted
coefficients) goes through :func:`atomic_write`."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import IO, Callable


def atomic_write(path: str | os.PathLike, write: Callable[[IO[bytes]], object]) -> Path:
    """Call ``write(f)`` on a temporary file in ``path``'s directory, then rename it over ``path``.

    A reader never sees a half-written file, and a failed write leaves ``path`` as it was;
    the data are flushed and fsynced before the rename.
    The file gets the usual permissions (0666 minus the umask), not ``mkstemp``'s 0600.
    The directory must exist; ``OSError`` propagates. Returns ``path`` as a ``Path``.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600 files; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path
