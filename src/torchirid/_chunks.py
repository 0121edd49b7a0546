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

With a gradient, the autograd graph of a whole batch holds every intermediate (~1 kB per point
for Bragg): batches above :data:`CHECKPOINT_POINTS` are evaluated in blocks under activation
checkpointing, which keeps one block's graph alive at a time and recomputes it in the backward
pass (about one more forward pass of time). Smaller batches with a gradient are evaluated at once.

One knob: ``torchirid.options(chunk_size=...)`` (process-wide, or scoped as a ``with`` statement;
``TORCHIRID_CHUNK_SIZE`` in the environment). ``None``/0 turns chunking off; the default, ``"auto"``,
takes the block size from the inputs' device (``torchirid._chunks.default_chunk_size``: cache-sized blocks on
the CPU, much larger ones on GPUs, where a block's cost is its kernel launches). Under ``torch.func``
transforms or ``torch.compile`` (:func:`torchirid._checks.traceable`) the whole batch is
evaluated at once.
"""

from __future__ import annotations

import contextlib
import itertools
import math
import os
import threading

import torch

from . import _checks, _threads

__all__ = ["default_chunk_size", "evaluate", "get_chunk_size"]

#: default block size in points (measured: docs/performance.md, benchmarks/throughput.py). On
#: 10⁷-point grids, paired against the 36k grid, blocks of 2¹⁵ points cost 0.97–1.14× the small
#: grid's time per point and blocks of 2¹⁷ 1.6–2.0×: a 2¹⁷-point block's complex intermediates
#: (2 MB each) are returned to the OS and faulted in again block after block by the C allocator.
DEFAULT_CHUNK_SIZE = 1 << 15

#: default block size on accelerators (CUDA, MPS, ...): there a block costs its kernel launches
#: (~10 µs per op whatever its size; a 10-film multilayer launches hundreds) and the
#: intermediates live in GPU memory, not a CPU cache, so blocks are as large as memory
#: comfortably allows: 2²⁴ points, 256 MB per complex128 intermediate. Measured on an H200 at
#: 10⁸ points (docs/performance.md, "GPU"): 2²⁴-point blocks cost 1.08–1.26× one piece, 2²¹-point
#: blocks 2.4–6.7×, the CPU's 2¹⁵ ~100×.
DEVICE_CHUNK_SIZE = 1 << 24

#: the block size when none was set: per device type (``torchirid._chunks.default_chunk_size``)
AUTO = "auto"


def _initial() -> int | str | None:
    text = os.environ.get("TORCHIRID_CHUNK_SIZE", "").strip()
    if not text:
        return AUTO
    try:
        value = int(text)
    except ValueError:
        return AUTO
    return value if value > 0 else None


_STATE = {"points": _initial()}


def default_chunk_size(device=None) -> int:
    """The block size used when none is set: :data:`DEFAULT_CHUNK_SIZE` on the CPU (and for
    ``device=None``), :data:`DEVICE_CHUNK_SIZE` on any other device type."""
    kind = torch.device(device).type if device is not None else "cpu"
    return DEFAULT_CHUNK_SIZE if kind in ("cpu", "meta") else DEVICE_CHUNK_SIZE


def get_chunk_size(device=None) -> int | None:
    """The block size in points on ``device`` (default: the CPU's); None: chunking off.

    >>> import torchirid
    >>> torchirid._chunks.get_chunk_size(), torchirid._chunks.get_chunk_size("cuda")  # the defaults per device
    (32768, 16777216)
    """
    points = _STATE["points"]
    return default_chunk_size(device) if points == AUTO else points


def _wants_grad(tensors) -> bool:
    return torch.is_grad_enabled() and any(isinstance(t, torch.Tensor) and t.requires_grad for t in tensors)


#: a block holds at least this many points however wide the kernel (each block costs ~0.5 ms of
#: Python and dispatch; 64 points of the widest kernel, a 3 760-node quadrature per colour, keep
#: ~15 MB per intermediate)
MIN_BLOCK_POINTS = 64

#: with a gradient, batches above this many points are evaluated block by block under
#: activation checkpointing (one block's graph alive at a time, recomputed in the backward pass)
CHECKPOINT_POINTS = 1 << 20


def evaluate(kernel, tensors, batch, *, core=None, out_core: int = 0, width: int = 1, grad_inputs=(), **options):
    """``kernel(*tensors, **options)`` broadcast to ``batch``, block by block when that pays.

    ``tensors`` broadcast to ``batch`` (right-aligned, after dropping their ``core`` trailing
    axes: ``core[i]`` per tensor, default 0; None entries and Python numbers pass through); the
    kernel must be elementwise in the batch and return one real tensor, or a tuple of them,
    broadcastable to ``batch`` followed by ``out_core`` trailing axes of its own (e.g. 1 for XYZ).
    ``width`` is the kernel's inner work per point (e.g. quadrature nodes × wavelengths): a
    block holds ``get_chunk_size() // width`` points (at least :data:`MIN_BLOCK_POINTS`), so
    that its intermediates stay about the size of a block of a one-wide kernel.

    Without a gradient, batches over twice that many points are evaluated in blocks into
    preallocated outputs (under ``torch.inference_mode``). With a gradient, batches over
    :data:`CHECKPOINT_POINTS` (and over twice the block size) are evaluated in blocks under
    :func:`torch.utils.checkpoint.checkpoint`: only each block's inputs and outputs are kept for
    the backward pass, which recomputes one block's graph at a time (about one more forward
    pass of time, memory of one block's graph instead of the whole batch's).
    """
    batch = tuple(batch)
    chunk = _STATE["points"]
    total = math.prod(batch)
    # a few points: one piece whatever the block size (a block holds at least min(chunk,
    # MIN_BLOCK_POINTS) points) — no block-size lookup, no gradient test
    if total <= 2 * MIN_BLOCK_POINTS and (chunk is None or chunk == AUTO or total <= 2 * min(chunk, MIN_BLOCK_POINTS)):
        with _threads.limited(total * max(1, int(width))):  # one thread for small work (torchirid._threads)
            return _expand(kernel(*tensors, **options), batch, out_core)
    if chunk == AUTO:
        chunk = default_chunk_size(next((t.device for t in tensors if isinstance(t, torch.Tensor)), None))
    points = None if chunk is None else max(min(chunk, MIN_BLOCK_POINTS), chunk // max(1, int(width)))
    core = (0,) * len(tensors) if core is None else tuple(core)
    grad = _wants_grad(tensors) or _wants_grad(grad_inputs)
    if (points is None or total <= 2 * points or (grad and total * width <= CHECKPOINT_POINTS)
            or _checks.traceable() or len(batch) == 0 or getattr(_INSIDE, "block", False)):
        with _threads.limited(total * max(1, int(width))):  # one thread for small work (torchirid._threads)
            return _expand(kernel(*tensors, **options), batch, out_core)
    nd = len(batch)
    # the outermost axis k whose inner block (axes after k) fits in one chunk; step along k
    inner = 1
    k = nd - 1
    while k > 0 and inner * batch[k] <= points:
        inner *= batch[k]
        k -= 1
    step = max(1, points // inner)
    blocks = [(*(slice(i, i + 1) for i in outer), slice(begin, min(begin + step, batch[k])))
              for outer in itertools.product(*(range(n) for n in batch[:k]))
              for begin in range(0, batch[k], step)]
    with _threads.limited(total * max(1, int(width))):  # the large-work thread count (torchirid._threads)
        if grad:
            return _checkpointed(kernel, tensors, core, batch, blocks, k, out_core, options)
        return _blocks(kernel, tensors, core, batch, blocks, nd, out_core, options)


def _blocks(kernel, tensors, core, batch, blocks, nd, out_core, options):
    """The blocks one after the other, written into the preallocated outputs."""
    out = None
    for index in blocks:
        args = [_take(t, index, nd, c) for t, c in zip(tensors, core)]
        with torch.inference_mode(), _inside_block():
            part = kernel(*args, **options)
        single = not isinstance(part, tuple)
        parts = (part,) if single else part
        if out is None:
            out = tuple(torch.empty((*batch, *_tail(p, out_core)), dtype=p.dtype, device=p.device) for p in parts)
        for o, p in zip(out, parts):
            block = o[index]
            block.copy_(p.expand(block.shape))
    return out[0] if single else out


#: per thread: whether a block's kernel is running (a chunked function called inside a block —
#: e.g. the Bragg reflectance of a BRDF block, or a table built lazily there — runs at once)
_INSIDE = threading.local()


@contextlib.contextmanager
def _inside_block():
    before = getattr(_INSIDE, "block", False)
    _INSIDE.block = True
    try:
        yield
    finally:
        _INSIDE.block = before


def _tail(t, out_core):
    return tuple(t.shape[t.ndim - out_core:]) if out_core else ()


def _expand(result, batch, out_core=0):
    if isinstance(result, tuple):
        return tuple(_expand(r, batch, out_core) for r in result)
    shape = (*batch, *_tail(result, out_core))
    return result if result.shape == shape else result.expand(shape)


def _checkpointed(kernel, tensors, core, batch, blocks, k, out_core, options):
    """Blocks under activation checkpointing, concatenated along axis ``k`` (the leading axes of
    a block have size 1, so the row-major concatenation reshapes to ``batch``)."""
    from torch.utils.checkpoint import checkpoint

    nd = len(batch)
    pieces = []
    for index in blocks:
        args = [_take(t, index, nd, c) for t, c in zip(tensors, core)]
        shape = tuple(_block_shape(batch, index))

        def block(*a, shape=shape):  # (shape bound now: the backward pass recomputes later)
            with _inside_block():
                return _expand(kernel(*a, **options), shape, out_core)

        part = checkpoint(block, *args, use_reentrant=False)
        pieces.append(part if isinstance(part, tuple) else (part,))
    out = tuple(torch.cat([p[i] for p in pieces], dim=k).reshape((*batch, *_tail(pieces[0][i], out_core)))
                for i in range(len(pieces[0])))
    return out if len(out) > 1 else out[0]


def _block_shape(batch, index):
    return [len(range(*s.indices(n))) for s, n in zip(index, batch)] + list(batch[len(index):])


def _take(t, index, nd, core=0):
    """The block ``index`` (one slice per leading batch axis) of a tensor that broadcasts to a
    batch of ``nd`` dims (right-aligned, after its ``core`` trailing axes); its size-1 axes are
    kept whole."""
    if not isinstance(t, torch.Tensor) or t.ndim <= core:
        return t
    offset = nd - (t.ndim - core)
    sel = []
    for axis, idx in enumerate(index):
        a = axis - offset
        if a >= 0:
            sel.append(slice(None) if t.shape[a] == 1 else idx)
    return t[tuple(sel)] if sel else t
