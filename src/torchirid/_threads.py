"""Torch threads for small workloads: one thread below a work threshold.

Measured on a 2-core machine (``benchmarks/threads.py``; the figures in docs/performance.md,
"Threads on a shared machine"): for workloads of many small ops — one colour, one fitting step
on an estimation-sized grid — two torch threads gain nothing on a quiet machine and cost several
times the one-thread time while one other process keeps a core busy: the ops that torch does
parallelise then wait for a thread that the other process holds. Large grids gain from the
second thread on a quiet machine and lose under load, a choice only the user can make
(``torch.set_num_threads``).

Policy: every table-producing function (:func:`torchirid._chunks.evaluate`) runs a batch whose
work is below ``torchirid._threads.SMALL_WORK`` elements with ``torchirid.options("small_work_threads")`` torch threads (1
by default), and restores the previous count after. Set ``None`` (or
``TORCHIRID_SMALL_WORK_THREADS=0``) to leave torch's setting alone. The thread count is
process-wide in torch: while a small call runs, torch work of other Python threads also runs
with one thread.
"""

from __future__ import annotations

import functools
import os
import threading

import torch

from . import _checks

__all__ = ["limited", "limited_by"]

#: work (points × inner width) below which a call runs with the small-work thread count: torch's
#: parallel grain, below which its elementwise ops run on one thread anyway
SMALL_WORK = 1 << 15


def _initial() -> int | None:
    text = os.environ.get("TORCHIRID_SMALL_WORK_THREADS", "").strip()
    if not text:
        return 1
    try:
        value = int(text)
    except ValueError:
        return 1
    return value if value > 0 else None


_LOCK = threading.Lock()
_STATE = {"threads": _initial(), "depth": 0, "saved": None}


class limited:
    """Context manager: run the ``with`` block with the small-work thread count if ``work``
    (elements) is below ``torchirid._threads.SMALL_WORK``; nested and concurrent uses restore the
    count once the last one leaves.

    A class rather than a generator-based context manager: small calls enter it on every call,
    and this costs them a lock and a thread-count read (a switch only where the caller runs on
    more threads than the policy's).
    """

    __slots__ = ("work", "counted")

    def __init__(self, work: int):
        self.work = work
        self.counted = False

    def __enter__(self):
        n = _STATE["threads"]
        if n is None or self.work >= SMALL_WORK or _checks.traceable():
            return None
        with _LOCK:
            if _STATE["depth"] == 0:
                current = torch.get_num_threads()
                _STATE["saved"] = current if current > n else None
                if _STATE["saved"] is not None:
                    torch.set_num_threads(n)
            _STATE["depth"] += 1
        self.counted = True
        return None

    def __exit__(self, *exc):
        if self.counted:
            self.counted = False
            with _LOCK:
                _STATE["depth"] -= 1
                if _STATE["depth"] == 0 and _STATE["saved"] is not None:
                    torch.set_num_threads(_STATE["saved"])
                    _STATE["saved"] = None
        return False


def limited_by(work):
    """Decorator: run ``fn(*args, **kwargs)`` under :func:`limited` with
    ``work(*args, **kwargs)`` elements (a cheap estimate from the arguments)."""

    def wrap(fn):
        @functools.wraps(fn)
        def run(*args, **kwargs):
            with limited(work(*args, **kwargs)):
                return fn(*args, **kwargs)

        return run

    return wrap
