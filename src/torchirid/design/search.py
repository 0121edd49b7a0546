r"""Optimisers over the batched merit: a global stage, exact-gradient refinement, needles.

:func:`optimise` runs, by default (``method="auto"``):

1. **Global stage** — SciPy's :func:`~scipy.optimize.differential_evolution` (``best1bin``,
   Latin-hypercube start, ``vectorized=True``: each generation is one tensor call of
   ``Evaluator`` on the whole population; discrete material choices are
   its integer variables), run in rounds of ``generations`` generations. After each round the
   best ``refine`` members are refined by exact gradients and put back into the population (a
   Lamarckian step), and the next round starts from that population.
2. **Gradient refinement** — L-BFGS-B (SciPy, box bounds = the thickness bounds) with the
   gradient from autograd through the recursion; the ``refine`` candidates are refined together
   (one batched call per iteration; their merits are summed, which keeps them independent).
3. **Needles** (``method="needle"``, or ``"auto"`` when ``max_layers`` exceeds the starting
   layer count) — ``torchirid.design.needle``.

The global stage ends when two successive rounds return the same refined best (to ``rtol``), or at
``max_evaluations`` / ``time_limit``. Seeded: the same seed gives the same design (on the same
machine and torch version). ``seconds`` in the result is the optimiser's wall time, from after the
problem is compiled (materials read, tables built) to the end.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from .. import _threads
from .local import (
    Run,
    clean,
    one_blas_thread,
    refine,
    refine_stack,
    stack_merit,
    stack_of,
)
from .merit import Evaluator
from .needle import needle_search
from .problem import Layer, Problem, material_label

__all__ = ["Design", "optimise"]

METHODS = ("auto", "global", "gradient", "needle")
#: generations of differential evolution between two refinements: at least this, and 2 per
#: variable (a 40-layer chirped mirror gains from longer rounds, a 20-layer mirror from shorter)
GENERATIONS = 40
#: population members refined by gradients after each round (together: one batched call per
#: L-BFGS-B iteration; 16 found the 40-layer chirped mirror's and the colour targets' basins
#: more often than 4 or 8, at the same time for the 20-layer mirror)
REFINE = 16
#: L-BFGS-B iterations of each round's refinement (the final one runs to convergence)
ROUND_ITERATIONS = 30
#: an improvement of the merit smaller than this (absolute) does not count as one
ATOL = 1e-9
#: rounds without improvement (relative 1e-9) that end the global stage (2: no early stop in 8
#: seeds of the 10-, 20- and 40-layer mirrors, 23 % less time than 3 on the 20-layer one)
PATIENCE = 2



@dataclass
class Design:
    """An optimised stack and how it was found.

    Attributes:
        problem: the problem (its ``layers`` are the starting stack).
        materials: the chosen material of every layer, incident side first.
        thicknesses: nm, incident side first (layers thinner than ``min_thickness`` removed).
        merit: the merit of this stack (the robust merit when the problem has ``robust``).
        seconds: the optimiser's wall time (problem compilation excluded).
        evaluations: candidate stacks evaluated (each error draw of a robust merit not counted).
        history: ``(seconds, evaluations, best merit)`` as the search went.
        method: the stages run.
    """

    problem: Problem
    materials: list
    thicknesses: list
    merit: float
    seconds: float
    evaluations: int
    history: list = field(default_factory=list)
    method: str = "auto"

    @property
    def layers(self) -> list[dict]:
        """``[{"material": <number or name>, "thickness_nm": d}, ...]``, incident side first."""
        return [{"material": material_label(m), "thickness_nm": float(d)}
                for m, d in zip(self.materials, self.thicknesses)]

    def as_problem(self) -> Problem:
        """The design as a problem with every thickness fixed (for analysis)."""
        return self.problem.with_layers([Layer(m, float(d)) for m, d in zip(self.materials, self.thicknesses)])

    def to_dict(self) -> dict:
        """What ``design.json`` holds."""
        return {"layers": self.layers, "incident": material_label(self.problem.n_incident),
                "exit": material_label(self.problem.n_substrate), "merit": float(self.merit),
                "seconds": float(self.seconds), "evaluations": int(self.evaluations),
                "total_thickness_nm": float(sum(self.thicknesses)), "method": self.method,
                "history": [[float(s), int(e), float(m)] for s, e, m in self.history]}

    def to_json(self, path=None) -> str:
        text = json.dumps(self.to_dict(), indent=2)
        if path is not None:
            with open(path, "w") as f:
                f.write(text + "\n")
        return text


def _merit_numpy(ev: Evaluator, F: int):
    """``f(X (F+C, S)) → (S,)`` for SciPy's vectorised DE (also accepts one ``(F+C,)`` vector)."""

    def f(X):
        X = np.asarray(X)
        one = X.ndim == 1
        X = X.reshape(-1, 1) if one else X
        x = torch.as_tensor(np.ascontiguousarray(X[:F].T), dtype=ev.dtype, device=ev.device)
        choice = torch.as_tensor(np.rint(X[F:].T), dtype=torch.long, device=ev.device) if X.shape[0] > F else None
        with torch.inference_mode():
            m = ev.merit(x, choice).cpu().numpy()
        return m[0] if one else m

    return f


def global_search(ev: Evaluator, run: Run, rng: np.random.Generator, *, population: int | None = None,
                  generations: int | None = None, refine_count: int = REFINE, rtol: float = 1e-9,
                  patience: int = PATIENCE, goal: float | None = None, round_iterations: int = ROUND_ITERATIONS,
                  start: np.ndarray | None = None):
    """Rounds of SciPy DE + batched gradient refinement; returns (x [F], choice [C] or None, merit)."""
    from scipy.optimize import differential_evolution

    F, C = len(ev.free), len(ev.choosing)
    D = F + C
    bounds = list(zip(ev.lower, ev.upper)) + [(0, k - 1) for k in ev.counts]
    integrality = np.array([False] * F + [True] * C)
    size = population or max(32, 2 * D)
    generations = generations or max(GENERATIONS, 2 * D)
    f = _merit_numpy(ev, F)
    lo, hi = np.array([b[0] for b in bounds]), np.array([b[1] for b in bounds])
    # Latin hypercube start in the box (integer columns rounded)
    init = (rng.permuted(np.tile(np.arange(size), (D, 1)), axis=1).T + rng.random((size, D))) / size
    init = lo + init * (hi - lo)
    init[:, F:] = np.rint(init[:, F:])
    if start is not None:  # a known candidate joins the population: the result is no worse
        init[0] = start
    best = (None, math.inf)
    previous = math.inf
    stalls = 0
    while True:
        left = run.max_evaluations - ev.evaluations
        gens = generations if left == math.inf else int(max(1, min(generations, left // size - 1)))

        def stop(intermediate_result):  # SciPy passes the result by this name
            run.record(float(intermediate_result.fun))
            return run.out_of_budget()

        res = differential_evolution(f, bounds, strategy="best1bin", maxiter=gens, popsize=1, init=init,
                                     tol=0, atol=0, mutation=(0.5, 1.0), recombination=0.7, polish=False,
                                     vectorized=True, updating="deferred", seed=int(rng.integers(2**31)),
                                     integrality=integrality if C else None, callback=stop)
        pop, energies = res.population, res.population_energies
        run.record(float(energies.min()))
        if run.out_of_budget():
            i = int(np.argmin(energies))
            cand = (pop[i], float(energies[i]))
            best = cand if cand[1] < best[1] else best
            break
        top = np.argsort(energies)[:refine_count]
        xs, ms = refine(ev, pop[top, :F], pop[top, F:] if C else None, run, maxiter=round_iterations)
        pop[top, :F], energies[top] = xs, ms
        i = int(np.argmin(energies))
        if energies[i] < best[1]:
            best = (pop[i].copy(), float(energies[i]))
        run.record(best[1])
        # an improvement counts above rtol of the merit and above ATOL (a merit polished from 1e-12
        # to 1e-14 has met its target)
        stalls = stalls + 1 if previous - best[1] <= rtol * abs(best[1]) + ATOL else 0
        if run.out_of_budget() or stalls >= patience or (goal is not None and best[1] <= goal):
            break
        previous = best[1]
        init = pop
    x = best[0]
    if not run.out_of_budget():  # the best, refined to convergence
        xs, ms = refine(ev, x[None, :F], x[None, F:] if C else None, run)
        if ms[0] < best[1]:
            x, best = np.concatenate([xs[0], x[F:]]), (None, float(ms[0]))
    return x[:F], (np.rint(x[F:]).astype(int) if C else None), best[1]


def multistart(ev: Evaluator, run: Run, rng: np.random.Generator, *, starts: int = 32):
    """Gradient refinement from ``starts`` random stacks at once; materials drawn at random."""
    F = len(ev.free)
    x = ev.lower + rng.random((starts, F)) * (ev.upper - ev.lower)
    choice = np.stack([rng.integers(k, size=starts) for k in ev.counts], 1) if ev.choosing else None
    xs, ms = refine(ev, x, choice, run)
    i = int(np.argmin(ms))
    return xs[i], (None if choice is None else choice[i]), float(ms[i])


def optimise(problem: Problem, *, method: str = "auto", seed: int = 0, time_limit: float | None = None,
             max_evaluations: int | None = None, progress: Callable[[int, float], Any] | None = None,
             population: int | None = None, goal: float | None = None, dtype: torch.dtype = torch.float64,
             device=None) -> Design:
    """Find the stack that minimises the problem's merit.

    Args:
        problem: a :class:`~torchirid.design.Problem`.
        method: ``"auto"`` (global stage with gradient refinement, then needles when
            ``max_layers`` allows more layers), ``"global"``, ``"gradient"`` (multi-start
            L-BFGS-B from random stacks) or ``"needle"`` (needles from the problem's stack, each
            free thickness starting at the middle of its bounds).
        seed: the random seed (the same seed, the same design).
        time_limit: seconds for the whole optimisation (problem compilation excluded); the best
            stack found so far is returned when it runs out.
        max_evaluations: a budget of candidate stacks.
        progress: ``progress(evaluations, best_merit)``, called at every improvement.
        population: the global stage's population (default ``max(32, 2 × variables)``).
        goal: stop as soon as the merit is at most this. With a ``time_limit`` or
            ``max_evaluations``, the global stage starts again from a new population whenever
            it stalls above the goal (or, without a goal, until the budget is spent), keeping
            the best design.
        dtype, device: of the evaluation (float64 on the CPU by default).

    Returns:
        a :class:`Design`.

    Example (a 4-layer mirror at 600 nm):
        >>> from torchirid import design
        >>> p = design.Problem([design.Layer(m, (0, 214)) for m in (1.8, 1.4, 1.8, 1.4)],
        ...                    [design.SpectralTarget("R", [600.0], p=1)], n_incident=1.0, n_substrate=1.8)
        >>> d = design.optimise(p, seed=0)
        >>> [round(t, 1) for t in d.thicknesses]  # quarter waves: 600 / (4 n)
        [83.3, 107.1, 83.3, 107.1]
    """
    if not isinstance(problem, Problem):
        raise TypeError(f"problem must be a torchirid.design.Problem; got {type(problem).__name__}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
    if time_limit is not None and not time_limit > 0:
        raise ValueError(f"time_limit must be > 0 seconds; got {time_limit!r}")
    if max_evaluations is not None and (not isinstance(max_evaluations, int) or max_evaluations < 1):
        raise ValueError(f"max_evaluations must be a whole number ≥ 1; got {max_evaluations!r}")
    if progress is not None and not callable(progress):
        raise TypeError("progress must be callable as progress(evaluations, best_merit)")
    ev = Evaluator(problem, dtype=dtype, device=device)
    rng = np.random.default_rng(seed)
    run = Run(ev, time_limit, max_evaluations, progress)
    if not ev.free and not ev.choosing and method != "needle":  # nothing to vary
        materials, thicknesses = clean(*stack_of(ev, np.zeros(0), None), problem.min_thickness)
        merit = stack_merit(problem, materials, thicknesses, dtype, device)
        run.record(merit)
        return Design(problem, materials, thicknesses, merit, run.elapsed(), 1, run.history, method)
    # a long run of small ops (populations, a few candidates): torch's small-work thread count
    # (torchirid._threads) and one BLAS thread for SciPy's NumPy side
    with torch.random.fork_rng(devices=[]), one_blas_thread(), _threads.limited(0):
        torch.manual_seed(seed)
        grow = problem.max_layers is not None and problem.max_layers > len(problem.layers)
        if method == "needle":
            x0 = (ev.lower + ev.upper) / 2
            ch0 = np.zeros(len(ev.choosing), dtype=int) if ev.choosing else None
            materials, thicknesses, merit = needle_search(problem, ev, run, x0, ch0)
        else:
            if method == "gradient":
                x, ch, merit = multistart(ev, run, rng)
            else:
                start = None
                if problem.robust is not None:
                    # the nominal optimum first (a robust merit costs `samples` evaluations; at most
                    # a quarter of a budget, not in the history), then the robust search from a
                    # population that contains it
                    with run.stage(0.25, recording=False):
                        x, ch, _ = global_search(ev.nominal(), run, rng, population=population)
                    start = np.concatenate([x, ch]) if ch is not None else x
                x, ch, merit = global_search(ev, run, rng, population=population, goal=goal, start=start)
                # with a budget and a goal not met, search again from a new population
                # (not when needles follow: they get what is left)
                budget = (time_limit is not None or max_evaluations is not None) and not (method == "auto" and grow)
                while budget and not run.out_of_budget() and (goal is None or merit > goal):
                    x2, ch2, merit2 = global_search(ev, run, rng, population=population, goal=goal)
                    if merit2 < merit:
                        x, ch, merit = x2, ch2, merit2
            materials, thicknesses = stack_of(ev, x, ch)
            if method == "auto" and grow and not run.out_of_budget():
                materials, thicknesses, merit = needle_search(problem, ev, run, x, ch)
        cleaned = clean(materials, thicknesses, problem.min_thickness)
        if cleaned != (list(materials), [float(d) for d in thicknesses]) and cleaned[0]:
            # layers under min_thickness went: the rest refined again, each at least that thick
            cleaned = refine_stack(problem, *cleaned, run, lower=problem.min_thickness)
        materials, thicknesses = cleaned
        merit = stack_merit(problem, materials, thicknesses, dtype, device)
        run.record(merit)
    return Design(problem, materials, thicknesses, merit, run.elapsed(), ev.evaluations, run.history, method)
