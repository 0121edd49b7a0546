r"""Local refinement by exact gradients, and the book-keeping every optimiser stage shares.

``refine`` runs SciPy's L-BFGS-B (box bounds = the thickness bounds) on ``k`` candidates at
once: their merits are summed, so that the gradient of the sum is each candidate's own gradient
(the candidates stay independent) and one batched forward and backward pass through the merit
serves them all. ``Run`` holds the clock, the budget (time, evaluations) and the history.
"""

from __future__ import annotations

import contextlib
import math
import time

import numpy as np
import torch

from .merit import Evaluator
from .problem import Layer

#: L-BFGS-B's memory (its cost per iteration grows with memory × variables: 16 candidates × 20
#: thicknesses refined together make that cost show)
MAXCOR = 10
#: L-BFGS-B's relative merit tolerance (its gradient tolerance is 1e-3 of it)
FTOL = 1e-12


class Run:
    """Book-keeping of one optimisation: clock, budget, history, progress."""

    def __init__(self, ev: Evaluator, time_limit, max_evaluations, progress):
        self.ev, self.progress = ev, progress
        self.start = time.perf_counter()
        self.time_limit = math.inf if time_limit is None else float(time_limit)
        self.max_evaluations = math.inf if max_evaluations is None else int(max_evaluations)
        self.best = math.inf
        self.history: list = []
        self.recording = True

    @contextlib.contextmanager
    def stage(self, fraction: float, *, recording: bool = True):
        """A stage that may spend at most ``fraction`` of what is left of the budget (time and
        evaluations), and whose merits enter the history and the progress only if ``recording``
        (a nominal stage before a robust one: its merits are not the problem's)."""
        saved = self.time_limit, self.max_evaluations, self.recording
        if self.time_limit < math.inf:
            self.time_limit = self.elapsed() + fraction * (self.time_limit - self.elapsed())
        if self.max_evaluations < math.inf:
            left = self.max_evaluations - self.ev.evaluations
            self.max_evaluations = self.ev.evaluations + int(fraction * left)
        self.recording = recording
        try:
            yield
        finally:
            self.time_limit, self.max_evaluations, self.recording = saved

    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def out_of_budget(self) -> bool:
        return self.elapsed() >= self.time_limit or self.ev.evaluations >= self.max_evaluations

    def record(self, merit: float) -> None:
        if self.recording and merit < self.best:
            self.best = merit
            self.history.append((self.elapsed(), self.ev.evaluations, merit))
            if self.progress is not None:
                self.progress(self.ev.evaluations, merit)


def refine(ev: Evaluator, x: np.ndarray, choice: np.ndarray | None, run: Run, *, maxiter: int = 500):
    """L-BFGS-B on the candidates ``x [k, F]`` together (materials fixed); returns (x, merits)."""
    from scipy.optimize import minimize

    k, F = x.shape
    if F == 0:
        with torch.inference_mode():
            m = ev.merit(torch.as_tensor(x, dtype=ev.dtype), _choice(ev, choice)).cpu().numpy()
        return x, m
    ch = _choice(ev, choice)
    lower = np.tile(ev.lower, k)
    upper = np.tile(ev.upper, k)
    last = {}

    def fg(flat):
        t = torch.tensor(flat.reshape(k, F), dtype=ev.dtype, device=ev.device, requires_grad=True)
        m = ev.merit(t, ch)
        m.sum().backward()
        last["m"] = m.detach().cpu().numpy()
        run.record(float(last["m"].min()))
        if run.out_of_budget():
            raise _Stop
        return float(m.detach().sum()), t.grad.cpu().numpy().ravel()

    x0 = np.clip(x, ev.lower, ev.upper).ravel()
    try:
        res = minimize(fg, x0, jac=True, method="L-BFGS-B", bounds=list(zip(lower, upper)),
                       options={"maxiter": maxiter, "ftol": FTOL, "gtol": FTOL * 1e-3, "maxcor": MAXCOR})
        x = res.x.reshape(k, F)
    except _Stop:
        pass
    with torch.inference_mode():
        m = ev.merit(torch.as_tensor(x, dtype=ev.dtype, device=ev.device), ch).cpu().numpy()
    return x, m


@contextlib.contextmanager
def one_blas_thread():
    """NumPy's BLAS on one thread while the optimisers run (threadpoolctl, when installed).

    Their NumPy work is many small vectors (SciPy's L-BFGS-B and differential evolution): a
    second BLAS thread buys nothing there and, on a machine busy with other work, waits for a
    core — a 20-layer mirror took 0.78 s with OpenBLAS's default threads against 0.34 s with one
    (median of 8 seeds, 2 loaded cores)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl is a dependency
        yield
        return
    with threadpool_limits(1, user_api="blas"):
        yield


class _Stop(Exception):
    """Raised inside an objective when the budget is spent."""


def _choice(ev: Evaluator, choice):
    if choice is None or not ev.choosing:
        return None
    return torch.as_tensor(np.rint(choice), dtype=torch.long, device=ev.device)


def stack_of(ev: Evaluator, x, ch):
    layers = ev.problem.layers
    d = ev.thicknesses(torch.as_tensor(np.asarray(x, dtype=float)[None], dtype=ev.dtype))[0].tolist()
    mats = [layer.candidates[0] for layer in layers]
    for i, j in enumerate(ev.choosing):
        mats[j] = layers[j].candidates[int(ch[i])]
    return mats, d


def clean(materials, thicknesses, min_thickness: float):
    """Drop layers thinner than ``min_thickness`` (when it is > 0; zero-thickness ones too) and
    merge equal neighbours; with ``min_thickness = 0`` the stack is kept as it is."""
    if min_thickness <= 0:
        return list(materials), [float(d) for d in thicknesses]
    out_m, out_d = [], []
    for m, d in zip(materials, thicknesses):
        if d <= 0 or d < min_thickness:
            continue
        if out_m and out_m[-1] == m:
            out_d[-1] += d
        else:
            out_m.append(m)
            out_d.append(float(d))
    return out_m, out_d


def refine_stack(problem, materials: list, thicknesses: list, run: Run, *, lower: float = 0.0):
    """Refine every thickness of a stack (its materials fixed), each in ``[lower, upper]`` with
    ``upper`` the largest bound of the problem; returns (materials, thicknesses)."""
    upper = max([layer.thickness[1] if layer.free else layer.thickness for layer in problem.layers] +
                [float(max(thicknesses))])
    ev = Evaluator(problem.with_layers([Layer(m, (lower, upper)) for m in materials]))
    xs, _ = refine(ev, np.clip(np.asarray(thicknesses, dtype=float), lower, upper)[None], None, run)
    run.ev.evaluations += ev.evaluations
    return list(materials), xs[0].tolist()


def stack_merit(problem, materials: list, thicknesses: list, dtype: torch.dtype = torch.float64, device=None) -> float:
    """The merit of a stack with every thickness fixed (under the problem's thickness errors when
    it has them); an empty stack is the bare exit medium."""
    if not materials:
        materials, thicknesses = [problem.n_substrate], [0.0]
    ev = Evaluator(problem.with_layers([Layer(m, float(d)) for m, d in zip(materials, thicknesses)]),
                   dtype=dtype, device=device)
    with torch.inference_mode():
        return float(ev.merit(torch.zeros(1, 0, dtype=dtype, device=ev.device))[0])
