"""Independent reference integrators for the layered tests (no torchirid code inside).

``tanh_sinh(f, edges)``: double-exponential (tanh-sinh) quadrature on every interval
``[edges[i], edges[i+1]]`` at once, vectorised: ``f`` receives an array of abscissae and
returns values of the same shape (plus trailing dims). It converges exponentially for
integrands analytic inside each interval, whatever they do at the interval's ends (square
roots included), which is what the kink of F_α needs. Returns the integral and the difference
with the rule of half the level (an error estimate).
"""

from __future__ import annotations

import math

import numpy as np


def _ts_rule(level: int, t_max: float = 3.2):
    h = 2.0 ** -level
    k = np.arange(-int(t_max / h), int(t_max / h) + 1)
    t = k * h
    u = 0.5 * math.pi * np.sinh(t)
    x = np.tanh(u)  # in (-1, 1)
    w = h * 0.5 * math.pi * np.cosh(t) / np.cosh(u) ** 2
    keep = np.abs(x) < 1.0  # drop the nodes rounded onto the ends
    return x[keep], w[keep]


def tanh_sinh(f, edges, level: int = 6):
    """∫ f over [edges[0], edges[-1]] split at every edge; returns (value, error estimate).

    ``edges`` may be an array of shape (n_edges,) or (n_edges, *B) for a batch of integrals
    (then f receives abscissae of shape (n_nodes, n_edges - 1, *B)).
    """
    edges = np.asarray(edges, dtype=np.float64)
    results = []
    for lev in (level - 1, level):
        x, w = _ts_rule(lev)
        a, b = edges[:-1], edges[1:]
        half = 0.5 * (b - a)
        mid = 0.5 * (b + a)
        shape = (-1,) + (1,) * a.ndim
        xs = mid[None] + half[None] * x.reshape(shape)
        vals = np.asarray(f(xs))
        ws = (half[None] * w.reshape(shape))
        ws = ws.reshape(ws.shape + (1,) * (vals.ndim - ws.ndim))
        results.append((vals * ws).sum(axis=(0, 1)))
    return results[1], np.abs(results[1] - results[0])
