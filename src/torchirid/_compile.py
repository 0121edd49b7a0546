"""Optional ``torch.compile`` of the elementwise hot kernels.

Off by default: compiling costs seconds per kernel variant and needs a C++ compiler at run
time, which a library should not impose.  Switch it on for large grids (LUT builds, speed
benchmarks) with ``torchirid.options(compile=True)`` or the environment variable ``TORCHIRID_COMPILE=1``.
The compiled kernels fuse the ~60 elementwise operations of Yeh's closed form into a few
loops (faster on large grids: docs/performance.md, "Compiled Bragg kernel") and agree with the
eager kernels to ~1e-13 in float64.  If compilation fails, torchirid warns once and falls
back to eager evaluation.
"""

from __future__ import annotations

import functools
import os
import warnings

import torch

__all__ = ["kernel"]

#: inputs smaller than this many points always run eagerly (compiled launch overhead dominates)
MIN_POINTS = 4096

_state = {"enabled": os.environ.get("TORCHIRID_COMPILE", "0").strip().lower() in ("1", "true", "yes", "on")}
_compiled: dict[str, object] = {}
_failed: set[str] = set()


def kernel(name: str, eager, static, points: int):
    """The function to run: ``static`` compiled when enabled and worth it, else ``eager``.

    ``static`` must be free of data-dependent Python control flow (``fullgraph=True``).
    """
    if not _state["enabled"] or points < MIN_POINTS or name in _failed:
        return eager
    fn = _compiled.get(name)
    if fn is None:
        fn = torch.compile(static, dynamic=True, fullgraph=True)
        _compiled[name] = fn

    @functools.wraps(eager)
    def run(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except Exception as exc:  # compiler missing or unsupported: stay correct, go eager
            _failed.add(name)
            warnings.warn(f"torchirid: torch.compile of {name!r} failed ({exc!r}); using eager kernels",
                          RuntimeWarning, stacklevel=3)
            return eager(*args, **kwargs)

    return run
