"""How large the blocks of a call are: checks that ``torchirid.options(chunk_size=...)`` reaches
a function's own block loop (tests of the functions that evaluate block by block).

``largest_tensor(call, chunk_size)`` runs ``call()`` under ``options(chunk_size=chunk_size)``
and returns its result and the largest tensor any torch op created meanwhile (elements of the
op output's storage; a view counts its base). A call evaluated in blocks of ``chunk_size``
elements has a much smaller largest tensor than the same call in one piece (``None``), as long
as its per-point intermediates are wider than its output.
"""

from __future__ import annotations

import torch
from torch.utils._python_dispatch import TorchDispatchMode
from torch.utils._pytree import tree_leaves

import torchirid as ti


class _Largest(TorchDispatchMode):
    def __init__(self):
        super().__init__()
        self.elements = 0

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        out = func(*args, **(kwargs or {}))
        for t in tree_leaves(out):
            if isinstance(t, torch.Tensor) and t.element_size():
                self.elements = max(self.elements, t.untyped_storage().nbytes() // t.element_size())
        return out


def largest_tensor(call, chunk_size):
    """``(call(), elements of the largest tensor it created)`` under ``options(chunk_size=chunk_size)``."""
    mode = _Largest()
    with ti.options(chunk_size=chunk_size), mode:
        out = call()
    return out, mode.elements
