"""Autograd modes around public calls: inference mode when no gradient can flow, autograd kept on
inside fits that differentiate, ordinary tensors in caches (torch's modes, not argument checks)."""

from __future__ import annotations

import functools
import numbers

import torch

from ._checks import traceable


def normal_tensors(fn):
    """Decorator for cache builders: run ``fn`` outside :func:`torch.inference_mode` (so a
    cache first filled by a call in inference mode holds ordinary tensors, usable with autograd)."""

    @functools.wraps(fn)
    def run(*args, **kwargs):
        with torch.inference_mode(False):
            return fn(*args, **kwargs)

    return run


def fits_with_autograd(fn):
    """Decorator for fits that differentiate internally (L-BFGS, Levenberg–Marquardt Jacobians):
    a caller's :func:`torch.inference_mode` (or ``no_grad``) must not switch their autograd off.
    In inference mode the body runs with it disabled, on copies of any inference-tensor
    arguments (which autograd may not record); the body enables grad where it needs it."""

    def normal(x):
        return x.clone() if isinstance(x, torch.Tensor) and x.is_inference() else x

    @functools.wraps(fn)
    def run(*args, **kwargs):
        if not torch.is_inference_mode_enabled():
            return fn(*args, **kwargs)
        with torch.inference_mode(False):
            return fn(*[normal(a) for a in args], **{k: normal(v) for k, v in kwargs.items()})

    return run


def inference_when_no_grad(fn):
    """Decorator for functions returning one tensor: run ``fn`` in :func:`torch.inference_mode`
    (no autograd bookkeeping on its many small ops) when no gradient can flow from its arguments
    (grad mode off, or no tensor argument, nor one in a tuple or list argument, requires grad), and return a copy made outside it (an
    ordinary tensor). Inside inference mode already, ``fn`` just runs. Caches that ``fn`` fills
    must build their tensors with :func:`normal_tensors`."""

    def needs_grad(v):
        if isinstance(v, (tuple, list)):  # e.g. coefficients (a, b)
            return any(needs_grad(u) for u in v)
        return isinstance(v, torch.Tensor) and v.requires_grad

    @functools.wraps(fn)
    def run(*args, **kwargs):
        if torch.is_inference_mode_enabled() or (torch.is_grad_enabled() and any(
                needs_grad(v) for v in (*args, *kwargs.values()))):
            return fn(*args, **kwargs)
        with torch.inference_mode():
            out = fn(*args, **kwargs)
        return out.clone()

    return run


#: the most points (the product of the tensor arguments' sizes) that :func:`inference_when_small` runs
#: in inference mode: one-point and few-point calls, whose copy of the result costs one small op
SMALL_CALL = 128


def inference_when_small(fn):
    """Decorator for a function returning one tensor and filling no cache: a call of at most
    :data:`SMALL_CALL` points (the product of its tensor arguments' sizes; numbers, strings and
    None count one) that no gradient can flow through runs in :func:`torch.inference_mode` and
    returns a copy made outside it (an ordinary tensor). Its few hundred small ops then skip the
    autograd bookkeeping (~10 % of a one-point call); larger calls, calls with a gradient, inside
    inference mode already, under vmap or ``torch.compile`` (:func:`traceable`) just run."""

    @functools.wraps(fn)
    def run(*args, **kwargs):
        if traceable() or torch.is_inference_mode_enabled():  # (traceable first: torch.compile cannot trace the other)
            return fn(*args, **kwargs)
        grad = torch.is_grad_enabled()
        size = 1
        for v in (*args, *kwargs.values()):
            if isinstance(v, torch.Tensor):
                if grad and v.requires_grad:
                    return fn(*args, **kwargs)
                size *= v.numel()
            elif not (v is None or isinstance(v, (numbers.Number, str))):  # (sequences, arrays: not counted here)
                return fn(*args, **kwargs)
        if size > SMALL_CALL:
            return fn(*args, **kwargs)
        with torch.inference_mode():
            out = fn(*args, **kwargs)
        return out.clone()

    return run
