"""Torch threads on a shared machine: one thread for small work, the free cores for large work.

Measured on a 2-core machine (``benchmarks/threads.py``; the figures in docs/performance.md,
"Threads on a shared machine"): for workloads of many small ops — one colour, one fitting step
on an estimation-sized grid — two torch threads gain nothing on a quiet machine and cost several
times the one-thread time while one other process keeps a core busy: the ops that torch does
parallelise then wait for a thread that the other process holds. Large grids gain from the
second thread on a quiet machine and lose under load, a choice only the user can make
(``torch.set_num_threads``) — or the library, by measuring.

Policy, small work: every table-producing function (:func:`torchirid._chunks.evaluate`) runs a batch whose
work is below ``torchirid._threads.SMALL_WORK`` elements with ``torchirid.options("small_work_threads")`` torch threads (1
by default), and restores the previous count after. Set ``None`` (or
``TORCHIRID_SMALL_WORK_THREADS=0``) to leave torch's setting alone. The thread count is
process-wide in torch: while a small call runs, torch work of other Python threads also runs
with one thread.

Policy, large work (``torchirid.options(large_work_threads="auto")``, the default): a call at or
above the threshold (the block evaluation of large tables, the Bragg colour's integrals, the film
estimation, the scatterogram match, the texture fits) runs with as many torch threads as there are
cores that other processes leave free, at most the caller's count. The cores other processes use
are measured, not guessed: the system's busy CPU time (``/proc/stat``) minus this process's own
(``os.times``), sampled every :data:`SAMPLE_S` by a daemon thread that the first large call
starts and averaged over ~:data:`SMOOTH_S` (before its first sample: :func:`other_load`),
rounded to whole cores; a large call decides at its start, and again each time one of its small
calls gives the threads back. A quiet machine
keeps every thread; one busy neighbour on two cores leaves one. An int fixes the count, ``None``
leaves torch's setting alone. Where ``/proc/stat`` does not exist (not Linux), "auto" leaves the
count alone.
"""

from __future__ import annotations

import functools
import math
import os
import threading
import time

import torch

from . import _checks

__all__ = ["limited", "limited_by", "large_work"]

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


def _initial_large():
    text = os.environ.get("TORCHIRID_LARGE_WORK_THREADS", "").strip().lower()
    if not text or text == "auto":
        return "auto"
    try:
        value = int(text)
    except ValueError:
        return "auto"
    return value if value > 0 else None


_LOCK = threading.Lock()
_STATE = {"threads": _initial(), "large": _initial_large(), "depth": 0, "saved": None}

#: the first large call decides on the window since import if it is at most FRESH_S long, else
#: on a window of MIN_WINDOW_S measured then (once per process), before the sampler thread takes over
MIN_WINDOW_S = 0.1
FRESH_S = 2.0

try:
    _TICK = os.sysconf("SC_CLK_TCK")
except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
    _TICK = 100


def _cores() -> int:
    """The cores this process may run on (its affinity, read at import)."""
    return _CORES


try:
    _CORES = len(os.sched_getaffinity(0))
except AttributeError:  # pragma: no cover - not Linux
    _CORES = os.cpu_count() or 1


def _sample():
    """(wall s, the system's busy CPU s, this process's CPU s), or None without ``/proc/stat``."""
    try:
        with open("/proc/stat", "rb") as f:
            fields = f.readline().split()
    except OSError:
        return None
    v = [int(x) for x in fields[1:9]]  # user nice system idle iowait irq softirq steal
    busy = v[0] + v[1] + v[2] + v[5] + v[6] + v[7]
    t = os.times()
    return time.monotonic(), busy / _TICK, t.user + t.system


_LOAD = {"last": _sample(), "free": None, "sampler": None}

#: seconds between two samples of the sampler thread, and the time constant of its average
SAMPLE_S = 0.2
SMOOTH_S = 0.6


def busy_elsewhere(before, after) -> float:
    """Cores that other processes kept busy between two :func:`_sample` readings: the system's
    busy CPU time minus this process's, over the wall time (≥ 0)."""
    wall = after[0] - before[0]
    if wall <= 0:
        return 0.0
    return max(0.0, ((after[1] - before[1]) - (after[2] - before[2])) / wall)


def _watch():
    """The sampler thread's loop: the other processes' busy cores, averaged over ~:data:`SMOOTH_S`."""
    last = _sample()
    while True:
        time.sleep(SAMPLE_S)
        now = _sample()
        wall = now[0] - last[0]
        if wall > 0:
            others = busy_elsewhere(last, now)
            prev = _LOAD["free"]
            _LOAD["free"] = others if prev is None else prev + (others - prev) * min(1.0, wall / SMOOTH_S)
        last = now


def other_load() -> float | None:
    """Cores that other processes keep busy (≥ 0; None where it cannot be measured).

    The first call starts a daemon thread that samples ``/proc/stat`` and this process's CPU time
    every :data:`SAMPLE_S` (a file read) and keeps their smoothed difference, so that a large call
    decides on the last second, not on a stale average. Until its first sample, the window since
    import stands in if it is at most :data:`FRESH_S` long, else one of :data:`MIN_WINDOW_S`
    measured then (once per process)."""
    last = _LOAD["last"]
    if last is None:
        return None
    if _LOAD["sampler"] is None:
        with _LOCK_SAMPLER:
            if _LOAD["sampler"] is None:
                now = _sample()
                if now[0] - last[0] > FRESH_S:  # the window since import is stale: measure a short one
                    last = now
                    time.sleep(MIN_WINDOW_S)
                    now = _sample()
                _LOAD["free"] = busy_elsewhere(last, now)
                thread = threading.Thread(target=_watch, name="torchirid-load", daemon=True)
                thread.start()
                _LOAD["sampler"] = thread
    return _LOAD["free"]


_LOCK_SAMPLER = threading.Lock()


def large_work_threads(current: int) -> int:
    """The torch threads for large work, given the caller's ``current`` count (see the module
    docstring): ``current`` unless other processes hold cores, then the free ones (≥ 1)."""
    setting = _STATE["large"]
    if setting is None:
        return current
    if setting != "auto":
        return min(current, setting)
    others = other_load()
    if others is None:
        return current
    free = _cores() - math.floor(others + 0.5)
    return max(1, min(current, free))


class limited:
    """Context manager: run the ``with`` block with the small-work thread count if ``work``
    (elements) is below ``torchirid._threads.SMALL_WORK``, else with the large-work count (the free
    cores by default). ``limited(math.inf)``: a large workload of unknown size.

    The two levels nest: inside a large workload, its small calls still run on the small-work count
    and give back the large one after — re-decided on the sampler's latest estimate, so that a
    long fit follows a neighbour that starts or stops. Each level counts its nested and concurrent
    uses and restores the caller's count when the last one leaves.

    A class rather than a generator-based context manager: small calls enter it on every call,
    and this costs them a lock and a thread-count read (a switch only where the caller runs on
    more threads than the policy's).
    """

    __slots__ = ("work", "level")

    def __init__(self, work: int):
        self.work = work
        self.level = None

    def __enter__(self):
        if _checks.traceable():
            return None
        if self.work < SMALL_WORK:
            n = _STATE["threads"]
            if n is None:
                return None
            with _LOCK:
                if _STATE["depth"] == 0:
                    current = torch.get_num_threads()
                    _STATE["saved"] = current if current > n else None
                    if _STATE["saved"] is not None:
                        torch.set_num_threads(n)
                _STATE["depth"] += 1
            self.level = "small"
            return None
        if _STATE["large"] is None:
            return None
        with _LOCK:
            if _LARGE["depth"] == 0:
                current = torch.get_num_threads()
                n = large_work_threads(current)
                _LARGE["saved"], _LARGE["now"], _LARGE["at"] = current, n, time.monotonic()
                if n != current:
                    torch.set_num_threads(n)
            _LARGE["depth"] += 1
        self.level = "large"
        return None

    def __exit__(self, *exc):
        level, self.level = self.level, None
        if level == "small":
            with _LOCK:
                _STATE["depth"] -= 1
                if _STATE["depth"] == 0:
                    restore = _STATE["saved"]
                    if _LARGE["depth"] > 0:  # back to the large workload: its count, re-decided each SAMPLE_S
                        now = time.monotonic()
                        if now - _LARGE["at"] >= SAMPLE_S:
                            _LARGE["now"], _LARGE["at"] = large_work_threads(_LARGE["saved"]), now
                        restore = _LARGE["now"]
                    if restore is not None and restore != torch.get_num_threads():
                        torch.set_num_threads(restore)
                    _STATE["saved"] = None
        elif level == "large":
            with _LOCK:
                _LARGE["depth"] -= 1
                if _LARGE["depth"] == 0:
                    if torch.get_num_threads() != _LARGE["saved"]:
                        torch.set_num_threads(_LARGE["saved"])
                    _LARGE["saved"] = _LARGE["now"] = None
        return False


#: the large-work level of :class:`limited`: nesting depth, the caller's count, the count now
_LARGE = {"depth": 0, "saved": None, "now": None, "at": 0.0}


def large_work(fn):
    """Decorator for a workload that is large whatever its arguments (a fit over a cube, a
    texture fit): ``fn`` runs under ``limited(math.inf)``, with the large-work thread count."""

    @functools.wraps(fn)
    def run(*args, **kwargs):
        with limited(math.inf):
            return fn(*args, **kwargs)

    return run


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
