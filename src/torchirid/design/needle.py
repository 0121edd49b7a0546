r"""Needle optimisation (Tikhonravov, Trubetskov & DeBell, *Appl. Opt.* 35, 5493 (1996)).

A needle is a layer of zero thickness of material :math:`m` inserted at depth :math:`z` of the
stack. Its thickness derivative

.. math:: P(m, z) = \left.\frac{∂M}{∂δ}\right|_{δ = 0}

says whether growing it lowers the merit :math:`M`. Here it is not derived by hand: every
candidate insertion — each material of the problem at ``positions`` depths inside every layer and
at every interface — is one row of a batch of stacks whose needle has thickness 0, and one
backward pass through the batched merit gives all the :math:`P(m, z)` at once. The stage then

1. inserts the needle where :math:`P` is most negative,
2. refines every thickness by L-BFGS-B (``refine``), each layer but the new needle bounded below by
   ``min_thickness``,
3. removes the needle if it stayed below ``min_thickness`` (and any zero-thickness layer), merges
   equal neighbours, and refines again what is left,

and repeats until no needle lowers the merit (:math:`P ≥ 0` everywhere, to ``1e-9`` of the
merit per nm), the problem's ``max_layers`` is reached, or the budget is spent.
"""

from __future__ import annotations

import numpy as np
import torch

from .local import clean, refine, refine_stack, stack_merit, stack_of
from .merit import Evaluator
from .problem import Layer, Problem

#: depths probed inside each layer (evenly spread, besides its two interfaces)
POSITIONS = 8


def _materials(problem: Problem) -> list:
    out = []
    for layer in problem.layers:
        for m in layer.candidates:
            if m not in out:
                out.append(m)
    return out


def needle_derivatives(problem: Problem, materials: list, thicknesses: list, palette: list,
                       positions: int = POSITIONS):
    """``(P, where)``: the merit's derivative for every candidate needle (per nm) and, per row,
    ``(layer, depth in nm, palette index)``."""
    rows, stacks, mats = [], [], []
    mi = [palette.index(m) for m in materials]
    L = len(materials)
    for j in range(L):
        depths = np.linspace(0.0, thicknesses[j], positions + 2)
        for z in depths:
            for k in range(len(palette)):
                # a needle of the layer's own material, or at an interface of its neighbour's,
                # only moves that interface: the refinement already did that
                if k == mi[j] or (z == 0 and j > 0 and k == mi[j - 1]) or (
                        z == thicknesses[j] and j + 1 < L and k == mi[j + 1]):
                    continue
                d = thicknesses[:j] + [float(z), 0.0, thicknesses[j] - float(z)] + thicknesses[j + 1:]
                m = mi[:j] + [mi[j], k, mi[j]] + mi[j + 1:]
                rows.append((j, float(z), k))
                stacks.append(d)
                mats.append(m)
    layers = [Layer(list(palette) if len(palette) > 1 else palette[0], (0.0, 1e6)) for _ in range(L + 2)]
    ev = Evaluator(problem.with_layers(layers))
    x = torch.tensor(stacks, dtype=ev.dtype, requires_grad=True)
    choice = torch.tensor(mats, dtype=torch.long) if len(palette) > 1 else None
    ev.merit(x, choice).sum().backward()
    needle = torch.tensor([j + 1 for j, _, _ in rows])
    P = x.grad[torch.arange(len(rows)), needle].numpy()
    return P, rows, ev.evaluations


def needle_search(problem: Problem, ev: Evaluator, run, x, ch):
    """The needle stage from the stack ``x`` (free thicknesses) / ``ch`` (choices) of ``ev``;
    returns (materials, thicknesses, merit)."""
    materials, thicknesses = stack_of(ev, x, ch)
    materials, thicknesses = clean(materials, thicknesses, 0.0)
    palette = _materials(problem)
    upper = max([float(ev.upper.max())] if len(ev.upper) else [max(thicknesses)])
    max_layers = problem.max_layers or len(problem.layers)
    best = (materials, thicknesses, np.inf)
    seen = set()
    tmin = problem.min_thickness
    needle = None  # the index of the needle just inserted: the one layer that may start below tmin
    while True:
        lower = [0.0 if (i == needle or tmin <= 0) else tmin for i in range(len(materials))]
        sub = Evaluator(problem.with_layers([Layer(m, (lo, upper)) for m, lo in zip(materials, lower)]))
        with run.stage(1.0, recording=False):  # the history holds the stacks as returned (below)
            xs, _ = refine(sub, np.maximum(np.asarray(thicknesses, dtype=float), lower)[None], None, run)
            ev.evaluations += sub.evaluations
            refined = (list(materials), xs[0].tolist())
            materials, thicknesses = clean(*refined, tmin)
            if (materials, thicknesses) != refined and materials:
                # the needle stayed under min_thickness and went: the rest refined again
                materials, thicknesses = refine_stack(problem, materials, thicknesses, run, lower=tmin)
        if not materials:
            break
        merit = stack_merit(problem, materials, thicknesses)  # of the stack as returned (cleaned)
        run.record(merit)
        if merit < best[2]:
            best = (materials, thicknesses, merit)
        key = (tuple(map(repr, materials)), round(merit, 12))
        if run.out_of_budget() or len(materials) + 2 > max_layers or key in seen:
            break  # budget, layer count, or a needle that the refinement removed again
        seen.add(key)
        P, rows, count = needle_derivatives(problem, materials, thicknesses, palette)
        ev.evaluations += count
        i = int(np.argmin(P))
        if not P[i] < -1e-9 * max(abs(merit), 1e-12):
            break
        j, z, k = rows[i]
        materials, thicknesses = _insert(materials, thicknesses, j, z, palette[k])
        needle = j + 1 if 0 < z else j  # where _insert put it (a split at z = 0 puts it first)
    return best


def _insert(materials, thicknesses, j: int, z: float, material):
    """The stack with a zero-thickness ``material`` at depth ``z`` of layer ``j`` (an empty piece of
    the split layer, at an interface, is left out)."""
    d = thicknesses[j]
    pieces = [(materials[j], z), (material, 0.0), (materials[j], d - z)]
    pieces = [p for i, p in enumerate(pieces) if i == 1 or p[1] > 0]
    return (materials[:j] + [m for m, _ in pieces] + materials[j + 1:],
            thicknesses[:j] + [t for _, t in pieces] + thicknesses[j + 1:])
