"""Build time and accuracy of the transmission-filter table F_α (Fourneau et al. 2024 §4.2.2).

Compares, in the same run and on the same machine:

* **numpy recipe** — the paper's recipe done straightforwardly: uniform 0.25° grids in θi and
  θd (361 × 361), the ψ integral of eq. 29 by the trapezoidal rule on 1000 uniform samples of
  [0, ψ_dmax] (eq. 24–26), vectorised with numpy over θd and ψ (one θi row at a time, as a
  user would to keep memory bounded); looked up by bilinear interpolation in (θi, θd);
* **torchirid** — :func:`torchirid.layered.filter.transmission_filter_lut` (closed form of the
  ψ integral, peak-following warped θd axis, θi/u bisection checked against the closed form).

Both are timed as the median of ``--repeats`` builds (after one warm-up build), on one core
by default (``--threads``): the gain is meant to come from the method, not from more cores. Accuracy: the
maximum over ~0.7 M points (uniform, around the peak, around the kink θd = π/2 − θi, near
normal incidence, and a 180 × 360 grid; θi ≤ 89.5°) of |table − F| against the closed form
:func:`~torchirid.layered.filter.transmission_filter`, relative to the filter's peak; for the
numpy recipe also its error *at its own nodes* (the ψ sampling is inexact near narrow peaks).

Run::

    PYTHONPATH=src python benchmarks/filter_build.py            # prints a markdown table
"""

from __future__ import annotations

import argparse
import math
import platform
import statistics
import sys
import time

import numpy as np
import torch

from torchirid.layered.filter import transmission_filter
from torchirid.layered.filter_lut import transmission_filter_lut

HALF_PI = math.pi / 2
ALPHAS = (0.025, 0.1, 0.4)


# ------------------------------------------------------------------------ the numpy recipe
def numpy_recipe(alpha: float, step_deg: float = 0.25, psi_samples: int = 1000) -> tuple[np.ndarray, np.ndarray]:
    """F_α on uniform (θi, θd) grids by eq. 29 with a 1000-sample trapezoid in ψ."""
    n = int(round(90.0 / step_deg)) + 1
    theta = np.linspace(0.0, HALF_PI, n)
    ti_all, td = theta, theta
    s = np.linspace(0.0, 1.0, psi_samples)  # ψ = s·ψ_max
    table = np.empty((n, n))
    cd, sd = np.cos(td), np.sin(td)
    for i, ti in enumerate(ti_all):
        ci, si = math.cos(ti), math.sin(ti)
        g1 = 2.0 / (1.0 + math.sqrt(1.0 + alpha**2 * math.tan(ti) ** 2)) if ci > 1e-12 else 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            arg = -1.0 / (math.tan(ti) * np.tan(td))
        psi_max = np.where(ti + td >= HALF_PI, np.arccos(np.clip(np.nan_to_num(arg, nan=-1.0), -1, 1)), math.pi)
        psi = psi_max[:, None] * s[None, :]
        cos_m = ci * cd[:, None] + si * sd[:, None] * np.cos(psi)
        d = alpha**2 / (math.pi * (1.0 - (1.0 - alpha**2) * cos_m**2) ** 2)  # D̃ of eq. 18
        integral = np.trapezoid(d, dx=1.0, axis=1) * psi_max / (psi_samples - 1)
        table[i] = 2.0 * g1**2 * cd / max(ci, 1e-300) * sd * integral if ci > 1e-12 else 0.0
    return theta, table


def bilinear(theta: np.ndarray, table: np.ndarray, ti: np.ndarray, td: np.ndarray) -> np.ndarray:
    h = theta[1] - theta[0]
    fi = np.clip(ti / h, 0, len(theta) - 1 - 1e-9)
    fd = np.clip(td / h, 0, len(theta) - 1 - 1e-9)
    i, j = fi.astype(int), fd.astype(int)
    a, b = fi - i, fd - j
    return ((1 - a) * (1 - b) * table[i, j] + a * (1 - b) * table[i + 1, j]
            + (1 - a) * b * table[i, j + 1] + a * b * table[i + 1, j + 1])


# ------------------------------------------------------------------------ evaluation
def dense_points(alpha: float, n: int = 120_000, seed: int = 0):
    g = torch.Generator().manual_seed(seed)
    top = math.radians(89.5)

    def rand(m):
        return torch.rand(m, generator=g, dtype=torch.float64)

    ti = [rand(n) * top, rand(n) * top, rand(n) * top, rand(n) * min(top, 8 * alpha)]
    td = [rand(n) * HALF_PI,
          ti[1] + alpha * torch.randn(n, generator=g, dtype=torch.float64),
          HALF_PI - ti[2] + 0.05 * alpha * torch.randn(n, generator=g, dtype=torch.float64),
          ti[3] + alpha * torch.randn(n, generator=g, dtype=torch.float64)]
    gi, gd = torch.meshgrid(torch.linspace(0, top, 180, dtype=torch.float64),
                            torch.linspace(0, HALF_PI, 360, dtype=torch.float64), indexing="ij")
    ti.append(gi.flatten())
    td.append(gd.flatten())
    return torch.cat(ti), torch.cat(td).clamp(0, HALF_PI)


def timed(fn, repeats: int):
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3, help="timed builds per method and α (median)")
    ap.add_argument("--threads", type=int, default=1,
                    help="torch intra-op threads (default 1: the numpy recipe runs on one core too)")
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)

    rows = []
    for alpha in ALPHAS:
        t_np, (theta, table) = timed(lambda: numpy_recipe(alpha), args.repeats)
        t_ti, lut = timed(lambda: transmission_filter_lut(alpha), args.repeats)
        ti, td = dense_points(alpha)
        exact = transmission_filter(ti, td, alpha)
        peak = float(transmission_filter(torch.tensor(0.0, dtype=torch.float64),
                                         torch.linspace(0, 0.6, 60001, dtype=torch.float64), alpha).max())
        err_np = float(np.abs(bilinear(theta, table, ti.numpy(), td.numpy()) - exact.numpy()).max()) / peak
        gi, gd = np.meshgrid(theta, theta, indexing="ij")
        keep = gi <= math.radians(89.5)
        at_nodes = transmission_filter(torch.from_numpy(gi[keep]), torch.from_numpy(gd[keep]), alpha).numpy()
        err_np_nodes = float(np.abs(table[keep] - at_nodes).max()) / peak
        err_ti = float((lut(ti, td) - exact).abs().max()) / peak
        n_i, n_u = lut.lut.values.shape
        rows.append((alpha, t_np, err_np, err_np_nodes, table.size, t_ti, err_ti, n_i, n_u))

    cmd = f"PYTHONPATH=src python benchmarks/filter_build.py --repeats {args.repeats} --threads {args.threads}"
    print(f"Transmission filter table F_α: build time (median of {args.repeats}) and max interpolation "
          f"error / peak over {ti.numel():,} points (θi ≤ 89.5°)\n")
    print(f"Machine: {platform.processor() or platform.machine()}, torch {torch.__version__}, "
          f"numpy {np.__version__}, {args.threads} torch thread(s), Python {sys.version.split()[0]}\n")
    print("| α | numpy recipe: build | its error (interp.) | its error (at nodes) | size | "
          "torchirid LUT: build | its error | size (θi × u) | speed-up |")
    print("|---|---|---|---|---|---|---|---|---|")
    for alpha, t_np, e_np, e_nodes, size_np, t_ti, e_ti, n_i, n_u in rows:
        print(f"| {alpha} | {t_np:.2f} s | {e_np:.1e} | {e_nodes:.1e} | {size_np:,} | {t_ti * 1e3:.0f} ms | "
              f"{e_ti:.1e} | {n_i} × {n_u} = {n_i * n_u:,} | ×{t_np / t_ti:.0f} |")
    print(f"\nCommand: `{cmd}`")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
