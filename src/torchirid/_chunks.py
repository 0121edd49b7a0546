"""Chunked evaluation of elementwise kernels over large broadcast batches.

Eager torch materialises every intermediate of the whole batch: on a 10⁷-point grid a kernel
of ~50 elementwise ops allocates gigabytes and runs at memory speed. When no gradient is
wanted, the table-producing functions evaluate their kernel block by block (blocks of
:func:`get_chunk_size` points along the broadcast batch) into one preallocated output, so the
intermediates stay cache-sized and the peak memory is the output plus one block's
intermediates. The values are those of the unchunked call to the last bit or so: every op is
elementwise in the batch, but a vectorised loop computes the few elements of its tail with
scalar code, and where a block boundary falls moves which elements those are (the same happens
between two unchunked calls whose tensors are aligned differently): differences of a few ulp.
Bragg's real closed form chooses its guarded branch near critical angles from the minimum over
the batch it is given; a block may take the other, equally accurate branch (≤ 5e-13 apart,
both within 1e-12 of tmm).

One knob: :func:`set_chunk_size` (process-wide; ``TORCHIRID_CHUNK_SIZE`` in the environment) or
the :func:`chunk_size` context manager. ``None``/0 turns chunking off. With gradients, under
``torch.func`` transforms or ``torch.compile`` (:func:`torchirid._checks.traceable`) the whole
batch is evaluated at once.
"""

from __future__ import annotations

import contextlib
import itertools
import math
import os

import torch

from . import _checks

__all__ = ["chunk_size", "evaluate", "get_chunk_size", "set_chunk_size"]

#: default block size in points (measured: docs/performance.md, benchmarks/throughput.py)
DEFAULT_CHUNK_SIZE = 1 << 15


def _initial() -> int | None:
    text = os.environ.get("TORCHIRID_CHUNK_SIZE", "").strip()
    if not text:
        return DEFAULT_CHUNK_SIZE
    try:
        value = int(text)
    except ValueError:
        return DEFAULT_CHUNK_SIZE
    return value if value > 0 else None


_STATE = {"points": _initial()}


def _check(points):
    if points is None:
        return None
    if isinstance(points, bool) or not isinstance(points, int) or points < 0:
        raise ValueError(f"points must be an int >= 1 (points per block), or 0 / None for no chunking; got {points!r}")
    return points or None


def set_chunk_size(points: int | None = DEFAULT_CHUNK_SIZE) -> None:
    """Points per block of the chunked kernels (default 32768); ``None`` or 0: no chunking.

    A batch of up to twice this many points is evaluated in one piece.

    >>> import torchirid
    >>> torchirid.set_chunk_size(1 << 16); torchirid.get_chunk_size()
    65536
    >>> torchirid.set_chunk_size()  # back to the default
    """
    _STATE["points"] = _check(points)


def get_chunk_size() -> int | None:
    """The current block size in points (None: chunking off)."""
    return _STATE["points"]


@contextlib.contextmanager
def chunk_size(points: int | None):
    """Context manager: the block size inside the ``with`` block (:func:`set_chunk_size`)."""
    points = _check(points)
    before = _STATE["points"]
    _STATE["points"] = points
    try:
        yield
    finally:
        _STATE["points"] = before


def _wants_grad(tensors) -> bool:
    return torch.is_grad_enabled() and any(isinstance(t, torch.Tensor) and t.requires_grad for t in tensors)


def evaluate(kernel, tensors, batch, **options) -> torch.Tensor:
    """``kernel(*tensors, **options)`` broadcast to ``batch``, block by block when that pays.

    ``tensors`` broadcast to ``batch`` (right-aligned; None entries pass through); the kernel
    must be elementwise in the batch and return one real tensor broadcastable to it.
    """
    points = _STATE["points"]
    total = math.prod(batch)
    if (points is None or total <= 2 * points or _wants_grad(tensors) or _checks.traceable()
            or len(batch) == 0):
        return kernel(*tensors, **options).expand(batch)
    nd = len(batch)
    # the outermost axis k whose inner block (axes after k) fits in one chunk; step along k
    inner = 1
    k = nd - 1
    while k > 0 and inner * batch[k] <= points:
        inner *= batch[k]
        k -= 1
    step = max(1, points // inner)
    out = None
    for outer in itertools.product(*(range(n) for n in batch[:k])):
        for begin in range(0, batch[k], step):
            index = (*(slice(i, i + 1) for i in outer), slice(begin, min(begin + step, batch[k])))
            args = [_take(t, index, nd) for t in tensors]
            with torch.inference_mode():
                part = kernel(*args, **options)
            if out is None:
                out = torch.empty(batch, dtype=part.dtype, device=part.device)
            block = out[index]
            block.copy_(part.expand(block.shape))
    return out


def _take(t, index, nd):
    """The block ``index`` (one slice per leading batch axis) of a tensor that broadcasts to a
    batch of ``nd`` dims (right-aligned); its size-1 axes are kept whole."""
    if not isinstance(t, torch.Tensor) or t.ndim == 0:
        return t
    offset = nd - t.ndim
    sel = []
    for axis, idx in enumerate(index):
        a = axis - offset
        if a >= 0:
            sel.append(slice(None) if t.shape[a] == 1 else idx)
    return t[tuple(sel)] if sel else t
