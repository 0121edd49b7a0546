#!/usr/bin/env python
r"""Fit the angular correction w̃(θ₁) of Fourneau et al. 2024 (appendix B) by autograd.

The reference w(θ₁) — the mean ratio of Yeh's spectrum to its envelope over one period of
the Bloch phase, with |C|² = 2R₁₂/(1 − R₁₂) and R₁₂ = R₁₂(θ₁) the Fresnel reflectance of the
n₁ | n₂ interface at the incidence angle (``angular_correction_reference``) — is tabulated
on a grid of angles and index pairs. Schlick's form

    w̃(θ₁) = w̃₀ + (1 − w̃₀)(1 − cos θ₁)⁵,   w̃₀ = a R₁₂(0) + b,

(``angular_correction``) is fitted to it in float64 with ``torch.optim.LBFGS`` on the
mean squared error over the grid (uniform weights in (pair, angle)). The model is linear
in (a, b), so the autograd optimum is cross-checked against the closed-form least-squares
solution. Written:

* ``src/torchirid/data/angular_correction.json`` — (a, b), the paper's (0.735, 0.532), the
  fit errors of both, the data grid and the reference table, N, the R₁₂ reading, the
  N-invariance study, the date and the torchirid version (atomic write);
* ``docs/figures/angular_correction.png`` — w (dots) against w̃ (fitted: solid, paper:
  dashed) for three n₂ in air, like the paper's Fig. 13, and w̃₀ against R₁₂.

Run from the repository root (a few seconds on 2 cores)::

    PYTHONPATH=src python training/fit_angular_correction.py
    PYTHONPATH=src python training/fit_angular_correction.py --cells 50 --json /tmp/w.json --no-figure
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import re
import sys
import time

import torch

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if os.path.join(ROOT, "src") not in sys.path:  # run from a checkout without installing
    sys.path.insert(0, os.path.join(ROOT, "src"))

import torchirid  # noqa: E402
from torchirid._io import atomic_write  # noqa: E402
from torchirid.spectral.correction import (  # noqa: E402
    FILE_FORMAT,
    FILE_FORMAT_VERSION,
    PAPER_COEFFICIENTS,
    angular_correction,
    angular_correction_limit,
    angular_correction_reference,
)

F64 = torch.float64
R12_READING = ("R12(theta1) = Fresnel reflectance of the n1|n2 interface at the incidence angle theta1 in n1 "
               "({pol}); |C|^2 = R1/(1-R1) = 2 R12/(1-R12) with R1 = R12 + R12 (1-R12)^2/(1-R12^2). "
               "w~0 uses R12 at normal incidence, as in the paper.")
MODEL = "w~(theta1) = w~0 + (1 - w~0) (1 - cos theta1)^5, w~0 = a R12(0) + b, R12(0) = ((n1 - n2)/(n1 + n2))^2"
DEFAULT_EXTRA_PAIRS = "1.33:1.56,1.33:2.0,1.56:1.8,1.5:2.4"
DEFAULT_EVAL_PAIRS = "1.56:1.0,1.5:1.33,2.0:1.5"
FIGURE_N2 = (1.25, 1.5, 2.0)


def parse_pairs(text: str) -> list[tuple[float, float]]:
    """'n1:n2,n1:n2' → [(n1, n2), ...] ('' → [])."""
    pairs = []
    for item in filter(None, (s.strip() for s in text.split(","))):
        try:
            n1, n2 = (float(v) for v in item.split(":"))
        except ValueError as exc:
            raise argparse.ArgumentTypeError(f"index pair {item!r} is not n1:n2") from exc
        if not (n1 > 0 and n2 > 0):
            raise argparse.ArgumentTypeError(f"index pair {item!r}: indices must be > 0")
        pairs.append((n1, n2))
    return pairs


def parse_cells(text: str) -> list[int]:
    out = [int(v) for v in text.split(",") if v.strip()]
    if any(v < 1 for v in out):
        raise argparse.ArgumentTypeError("cells must be integers >= 1")
    return out


def make_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cells", type=int, default=20, help="N of the reference integral (default 20)")
    p.add_argument("--samples", type=int, default=64, help="quadrature nodes per interval pi/N (default 64)")
    p.add_argument("--polarization", default="unpolarized", choices=("unpolarized", "s", "p"),
                   help="polarization of R12(theta1) in |C|^2 (default unpolarized)")
    p.add_argument("--angle-max", type=float, default=89.0, help="largest incidence angle in degrees (default 89)")
    p.add_argument("--angles", type=int, default=90,
                   help="angles, uniform in degrees from 0 to --angle-max (default 90: 0, 1, ..., 89)")
    p.add_argument("--n2-min", type=float, default=1.1, help="n2 range with n1 = 1 (default 1.1 .. 2.5)")
    p.add_argument("--n2-max", type=float, default=2.5)
    p.add_argument("--n2-count", type=int, default=15, help="n2 values with n1 = 1 (default 15)")
    p.add_argument("--extra-pairs", type=parse_pairs, default=parse_pairs(DEFAULT_EXTRA_PAIRS),
                   help=f"more fitted n1:n2 pairs (default {DEFAULT_EXTRA_PAIRS})")
    p.add_argument("--eval-pairs", type=parse_pairs, default=parse_pairs(DEFAULT_EVAL_PAIRS),
                   help=f"pairs evaluated but not fitted, e.g. n1 > n2 (default {DEFAULT_EVAL_PAIRS})")
    p.add_argument("--invariance-cells", type=parse_cells, default=parse_cells("10,20,50,100"),
                   help="N values of the N-invariance study (default 10,20,50,100)")
    p.add_argument("--paper-range", type=float, nargs=2, default=(1.25, 1.75), metavar=("N2_MIN", "N2_MAX"),
                   help="n2 range (n1 = 1) of the check that reproduces the paper's (a, b) (default 1.25 1.75)")
    p.add_argument("--json", default=os.path.join(ROOT, "src", "torchirid", "data", "angular_correction.json"),
                   help="output coefficients file")
    p.add_argument("--figure", default=os.path.join(ROOT, "docs", "figures", "angular_correction.png"),
                   help="output figure")
    p.add_argument("--no-figure", action="store_true", help="skip the figure")
    p.add_argument("--no-table", action="store_true", help="do not store the reference table in the JSON")
    p.add_argument("--threads", type=int, default=None, help="torch intra-op threads (default: torch's)")
    p.add_argument("--quiet", action="store_true", help="print only the summary")
    return p


# ---------------------------------------------------------------------------------------------


def reference_table(pairs, angles_deg, cells, samples, polarization) -> torch.Tensor:
    """w[pair, angle] of angular_correction_reference (float64)."""
    n1 = torch.tensor([p[0] for p in pairs], dtype=F64)[:, None]
    n2 = torch.tensor([p[1] for p in pairs], dtype=F64)[:, None]
    c = torch.cos(torch.deg2rad(angles_deg))[None, :].clamp(0, 1)
    return angular_correction_reference(c, n1, n2, cells=cells, samples=samples, polarization=polarization)


def schlick(pairs, angles_deg, coefficients) -> torch.Tensor:
    n1 = torch.tensor([p[0] for p in pairs], dtype=F64)[:, None]
    n2 = torch.tensor([p[1] for p in pairs], dtype=F64)[:, None]
    c = torch.cos(torch.deg2rad(angles_deg))[None, :].clamp(0, 1)
    return angular_correction(c, n1, n2, coefficients=coefficients)


def fit_autograd(pairs, angles_deg, w, init=(0.5, 0.5)) -> dict:
    """(a, b) minimising mean (w̃ − w)² by LBFGS (strong Wolfe line search), float64."""
    params = torch.tensor(init, dtype=F64, requires_grad=True)
    opt = torch.optim.LBFGS([params], lr=1.0, max_iter=100, tolerance_grad=1e-14, tolerance_change=1e-20,
                            history_size=10, line_search_fn="strong_wolfe")
    evaluations = 0

    def closure():
        nonlocal evaluations
        evaluations += 1
        opt.zero_grad()
        loss = (schlick(pairs, angles_deg, params) - w).square().mean()
        loss.backward()
        return loss

    for _ in range(5):  # LBFGS.step runs up to max_iter iterations; repeat until the gradient vanishes
        opt.step(closure)
        if params.grad is not None and float(params.grad.abs().max()) < 1e-14:
            break
    with torch.no_grad():
        mse = float((schlick(pairs, angles_deg, params) - w).square().mean())
    a, b = (float(v) for v in params.detach())
    return {"a": a, "b": b, "mse": mse, "loss_evaluations": evaluations,
            "final_gradient_max": float(params.grad.abs().max())}


def fit_lstsq(pairs, angles_deg, w) -> tuple[float, float]:
    """The same fit in closed form: w − F = (a R12 + b)(1 − F), F = (1 − cos θ)⁵."""
    r0 = torch.tensor([((n1 - n2) / (n1 + n2)) ** 2 for n1, n2 in pairs], dtype=F64)[:, None]
    F = ((1 - torch.cos(torch.deg2rad(angles_deg))) ** 5)[None, :]
    X = torch.stack(torch.broadcast_tensors(r0 * (1 - F), (1 - F).expand_as(w)), -1).reshape(-1, 2)
    sol = torch.linalg.lstsq(X, (w - F).reshape(-1, 1)).solution.reshape(-1)
    return float(sol[0]), float(sol[1])


def errors(pairs, angles_deg, w, coefficients, angle_max=None) -> dict:
    """RMS and max |w̃ − w| (and where) over the grid, optionally for θ ≤ angle_max only."""
    d = schlick(pairs, angles_deg, coefficients) - w
    if angle_max is not None:
        d = d[:, angles_deg <= angle_max + 1e-9]
    i = int(d.abs().argmax())
    pi, ai = divmod(i, d.shape[1])
    return {"rms": float(d.square().mean().sqrt()), "max_abs": float(d.abs().max()),
            "max_abs_at": {"n1": pairs[pi][0], "n2": pairs[pi][1], "angle_deg": float(angles_deg[ai])}}


def normal_regression(pairs, w0) -> tuple[float, float]:
    """The paper's description: a linear regression of w(0) against R12 over the pairs."""
    r0 = torch.tensor([((n1 - n2) / (n1 + n2)) ** 2 for n1, n2 in pairs], dtype=F64)
    X = torch.stack([r0, torch.ones_like(r0)], -1)
    sol = torch.linalg.lstsq(X, w0.reshape(-1, 1)).solution.reshape(-1)
    return float(sol[0]), float(sol[1])


def write_json_atomic(path: str, data: dict) -> None:
    """Write ``data`` as JSON atomically (torchirid's one atomic-write helper)."""
    text = json.dumps(data, indent=1, ensure_ascii=False, allow_nan=False)
    # lists of numbers on one line each (innermost brackets without strings or objects)
    text = re.sub(r"\[([^\[\]{}\"]*)\]",
                  lambda m: "[" + ", ".join(v.strip() for v in m.group(1).split(",")) + "]", text)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    atomic_write(path, lambda f: f.write((text + "\n").encode("utf-8")))


def plot(path, fitted, args) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.3))
    dots = torch.arange(0, 91, 3, dtype=F64)
    fine = torch.linspace(0, 90, 361, dtype=F64)
    colors = ("tab:blue", "tab:orange", "tab:green")
    for n2, col in zip(FIGURE_N2, colors):
        pair = [(1.0, n2)]
        w = reference_table(pair, dots, args.cells, args.samples, args.polarization)[0]
        ax.plot(dots, w, "o", ms=4, color=col, label=f"w, n2 = {n2}")
        ax.plot(fine, schlick(pair, fine, fitted)[0].detach(), "-", color=col, lw=1.5)
        ax.plot(fine, schlick(pair, fine, PAPER_COEFFICIENTS)[0].detach(), "--", color=col, lw=1.0)
    ax.plot([], [], "k-", label=f"w̃ fitted (a, b) = ({fitted[0]:.3f}, {fitted[1]:.3f})")
    ax.plot([], [], "k--", label="w̃ paper (0.735, 0.532)")
    ax.set_xlabel("incidence angle θ1 (degrees), n1 = 1")
    ax.set_ylabel("angular correction")
    ax.set_title(f"Fourneau app. B, Fig. 13: w (N = {args.cells}, R12(θ1) {args.polarization}) vs Schlick w̃",
                 fontsize=9)
    ax.set_xlim(0, 90)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")

    n2s = torch.linspace(1.01, 3.0, 200, dtype=F64)
    r0 = ((1 - n2s) / (1 + n2s)) ** 2
    w0 = angular_correction_reference(torch.ones((), dtype=F64), 1.0, n2s, cells=args.cells, samples=args.samples)
    bx.plot(r0, w0, "k-", lw=1.5, label=f"w(0°), N = {args.cells}")
    bx.plot(r0, angular_correction_limit(torch.ones((), dtype=F64), 1.0, n2s), "k:", lw=1.0,
            label="w(0°), N → ∞ (closed form)")
    bx.plot(r0, fitted[0] * r0 + fitted[1], "r-", lw=1.0, label="w̃0 fitted")
    bx.plot(r0, PAPER_COEFFICIENTS[0] * r0 + PAPER_COEFFICIENTS[1], "r--", lw=1.0, label="w̃0 paper")
    lo, hi = args.paper_range
    for i, edge in enumerate((lo, hi)):
        bx.axvline(((1 - edge) / (1 + edge)) ** 2, color="0.6", lw=0.8, ls="-.",
                   label=f"n2 = {lo} … {hi}: a fit there gives ≈ the paper's (a, b)" if i == 0 else None)
    bx.set_xlabel("R12 at normal incidence (n1 = 1, n2 = 1.01 … 3)")
    bx.set_ylabel("w at normal incidence")
    bx.set_title("w̃0 = a R12 + b: the slope depends on the R12 range fitted", fontsize=9)
    bx.grid(alpha=0.3)
    bx.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    try:  # atomic: the old figure stays if saving fails
        atomic_write(path, lambda f: fig.savefig(f, dpi=130, format="png"))
    finally:
        plt.close(fig)


def main(argv=None) -> dict:
    args = make_parser().parse_args(argv)
    if args.threads:
        torch.set_num_threads(args.threads)
    t_start = time.perf_counter()
    say = (lambda *a: None) if args.quiet else (lambda *a: print(*a, flush=True))
    try:
        from tqdm import tqdm
    except ImportError:  # progress bars are optional
        def tqdm(it, **_):
            return it

    angles = torch.linspace(0.0, args.angle_max, args.angles, dtype=F64)
    pairs = [(1.0, round(float(v), 12)) for v in torch.linspace(args.n2_min, args.n2_max, args.n2_count, dtype=F64)]
    pairs += list(args.extra_pairs)
    if any(n2 <= n1 for n1, n2 in pairs):
        say("note: fitted pairs with n1 >= n2 reach total internal reflection (w = 1) past the critical angle")
    steps = ["reference", "fit", "evaluation", *[f"N={n}" for n in args.invariance_cells], "paper range", "figure"]
    bar = tqdm(total=len(steps), desc="angular correction", disable=None, leave=False)

    def step(name):
        bar.set_postfix_str(name)
        bar.update(1)

    W = reference_table(pairs, angles, args.cells, args.samples, args.polarization)
    step("reference")
    fit = fit_autograd(pairs, angles, W)
    a_ls, b_ls = fit_lstsq(pairs, angles, W)
    fit["lstsq_check"] = {"a": a_ls, "b": b_ls, "max_diff": max(abs(fit["a"] - a_ls), abs(fit["b"] - b_ls))}
    fitted = (fit["a"], fit["b"])
    fit_err = errors(pairs, angles, W, fitted)
    paper_err = errors(pairs, angles, W, PAPER_COEFFICIENTS)
    fit_err80 = errors(pairs, angles, W, fitted, angle_max=80.0)
    paper_err80 = errors(pairs, angles, W, PAPER_COEFFICIENTS, angle_max=80.0)
    step("fit")

    evaluation = None
    if args.eval_pairs:
        We = reference_table(args.eval_pairs, angles, args.cells, args.samples, args.polarization)
        crit = []
        for n1, n2 in args.eval_pairs:
            crit.append(math.degrees(math.asin(n2 / n1)) if n2 < n1 else 90.0)
        below = torch.stack([angles < cr for cr in crit])  # before the critical angle
        d_fit = schlick(args.eval_pairs, angles, fitted) - We
        d_pap = schlick(args.eval_pairs, angles, PAPER_COEFFICIENTS) - We
        evaluation = {
            "pairs_n1_n2": [list(p) for p in args.eval_pairs],
            "critical_angle_deg": crit,
            "fitted": {"rms": float(d_fit.square().mean().sqrt()), "max_abs": float(d_fit.abs().max()),
                       "max_abs_below_critical": float(d_fit[below].abs().max())},
            "paper": {"rms": float(d_pap.square().mean().sqrt()), "max_abs": float(d_pap.abs().max()),
                      "max_abs_below_critical": float(d_pap[below].abs().max())},
            "note": "not fitted: with n1 > n2, w = 1 past the critical angle (total internal reflection), "
                    "which the Schlick form in cos(theta1) does not model",
        }
    step("evaluation")

    invariance = {"cells": [], "max_abs_diff_vs_default": [], "max_abs_diff_vs_default_up_to_80deg": [],
                  "fitted_a": [], "fitted_b": []}
    for n in args.invariance_cells:
        Wn = W if n == args.cells else reference_table(pairs, angles, n, args.samples, args.polarization)
        fn = fit_lstsq(pairs, angles, Wn)
        invariance["cells"].append(n)
        invariance["max_abs_diff_vs_default"].append(float((Wn - W).abs().max()))
        invariance["max_abs_diff_vs_default_up_to_80deg"].append(float((Wn - W)[:, angles <= 80].abs().max()))
        invariance["fitted_a"].append(fn[0])
        invariance["fitted_b"].append(fn[1])
        step(f"N={n}")
    Winf = angular_correction_limit(torch.cos(torch.deg2rad(angles))[None, :].clamp(0, 1),
                                    torch.tensor([p[0] for p in pairs], dtype=F64)[:, None],
                                    torch.tensor([p[1] for p in pairs], dtype=F64)[:, None],
                                    polarization=args.polarization)
    fn = fit_lstsq(pairs, angles, Winf)
    invariance["large_n_limit"] = {"max_abs_diff_vs_default": float((Winf - W).abs().max()),
                                   "fitted_a": fn[0], "fitted_b": fn[1]}

    lo, hi = args.paper_range
    pr_pairs = [(1.0, round(float(v), 12)) for v in torch.linspace(lo, hi, 11, dtype=F64)]
    Wp = reference_table(pr_pairs, angles, args.cells, args.samples, args.polarization)
    pr_fit = fit_lstsq(pr_pairs, angles, Wp)
    paper_range = {
        "n1": 1.0, "n2_range": [lo, hi], "n2_count": 11,
        "fitted_a": pr_fit[0], "fitted_b": pr_fit[1],
        "normal_incidence_regression": dict(zip(("a", "b"), normal_regression(pr_pairs, Wp[:, 0]))),
        "errors_fitted": errors(pr_pairs, angles, Wp, pr_fit),
        "errors_paper": errors(pr_pairs, angles, Wp, PAPER_COEFFICIENTS),
    }
    step("paper range")

    reg = normal_regression(pairs, W[:, 0])
    provenance = {
        "builder": "training/fit_angular_correction.py",
        "command": " ".join(["training/fit_angular_correction.py", *(argv if argv is not None else sys.argv[1:])]),
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "torchirid_version": torchirid.__version__,
        "torch_version": torch.__version__,
        "reference": {
            "integral": "w(theta1) = (1/2pi) int_0^2pi R/R^e dx, R = |C|^2/(|C|^2 + sin^2 x/sin^2 Nx), "
                        "R^e = |C|^2/(|C|^2 + sin^2 x) (Fourneau et al. 2024, appendix B)",
            "function": "torchirid.spectral.correction.angular_correction_reference",
            "cells": args.cells,
            "samples_per_dip_interval": args.samples,
            "quadrature": "midpoint rule after the periodic map x = X(v), X'(v) = (8/3) sin^4(Nv)",
            "polarization": args.polarization,
            "r12_reading": R12_READING.format(pol=args.polarization),
        },
        "data": {
            "angles_deg": {"min": 0.0, "max": args.angle_max, "count": args.angles},
            "pairs_n1_n2": [list(p) for p in pairs],
            "n2_grid_n1_1": {"min": args.n2_min, "max": args.n2_max, "count": args.n2_count},
            "weighting": "uniform over the (pair, angle) grid",
        },
        "fit": {
            "method": "torch.optim.LBFGS (strong Wolfe), float64, mean squared error of w~ - w",
            **fit,
            "errors": fit_err,
            "errors_up_to_80deg": fit_err80,
        },
        "paper_coefficient_errors": {"errors": paper_err, "errors_up_to_80deg": paper_err80},
        "normal_incidence_regression": {"a": reg[0], "b": reg[1],
                                        "note": "w(0) against R12 only, the paper's stated method"},
        "paper_range_check": paper_range,
        "n_invariance": invariance,
        "evaluation_pairs": evaluation,
    }
    data = {
        "format": FILE_FORMAT,
        "format_version": FILE_FORMAT_VERSION,
        "model": MODEL,
        "coefficients": {"a": fit["a"], "b": fit["b"]},
        "paper_coefficients": {"a": PAPER_COEFFICIENTS[0], "b": PAPER_COEFFICIENTS[1]},
        "provenance": provenance,
    }
    if not args.no_table:
        data["reference_table"] = {
            "angles_deg": [round(float(v), 12) for v in angles],
            "pairs_n1_n2": [list(p) for p in pairs],
            "w": [[round(float(v), 13) for v in row] for row in W],
        }
    # the figure first: a failure there leaves the shipped JSON untouched (both writes are atomic)
    if not args.no_figure:
        plot(args.figure, fitted, args)
    write_json_atomic(args.json, data)
    step("figure")
    bar.close()
    elapsed = time.perf_counter() - t_start

    say(f"reference: N = {args.cells}, {args.samples} nodes per pi/N, R12(theta1) {args.polarization}; "
        f"{len(pairs)} pairs x {args.angles} angles (0..{args.angle_max:g} deg)")
    say(f"fitted (a, b) = ({fit['a']:.4f}, {fit['b']:.4f})   paper (0.735, 0.532)   "
        f"[lstsq ({a_ls:.4f}, {b_ls:.4f}), |diff| {fit['lstsq_check']['max_diff']:.1e}]")
    say(f"errors, fitted: RMS {fit_err['rms']:.4f}  max {fit_err['max_abs']:.4f} at {fit_err['max_abs_at']}")
    say(f"errors, paper:  RMS {paper_err['rms']:.4f}  max {paper_err['max_abs']:.4f} at {paper_err['max_abs_at']}")
    say(f"theta <= 80 deg: fitted RMS {fit_err80['rms']:.4f} max {fit_err80['max_abs']:.4f}; "
        f"paper RMS {paper_err80['rms']:.4f} max {paper_err80['max_abs']:.4f}")
    say(f"normal-incidence regression w(0) ~ a R12 + b: ({reg[0]:.4f}, {reg[1]:.4f})")
    pr_reg = paper_range["normal_incidence_regression"]
    say(f"paper range n2 in [{lo}, {hi}]: fitted ({pr_fit[0]:.4f}, {pr_fit[1]:.4f}), normal-incidence regression "
        f"({pr_reg['a']:.4f}, {pr_reg['b']:.4f})")
    say("N invariance (max |w_N - w_%d| over the grid; up to 80 deg; fitted a, b):" % args.cells)
    for i, n in enumerate(invariance["cells"]):
        say(f"  N = {n:4d}: {invariance['max_abs_diff_vs_default'][i]:.2e}  "
            f"{invariance['max_abs_diff_vs_default_up_to_80deg'][i]:.2e}  "
            f"({invariance['fitted_a'][i]:.4f}, {invariance['fitted_b'][i]:.4f})")
    lim = invariance["large_n_limit"]
    say(f"  N =  inf: {lim['max_abs_diff_vs_default']:.2e}  ({lim['fitted_a']:.4f}, {lim['fitted_b']:.4f})")
    if evaluation:
        say(f"n1 > n2 pairs (not fitted) {evaluation['pairs_n1_n2']}: fitted max {evaluation['fitted']['max_abs']:.3f} "
            f"(below critical {evaluation['fitted']['max_abs_below_critical']:.3f}), paper max "
            f"{evaluation['paper']['max_abs']:.3f}")
    say(f"wrote {os.path.relpath(args.json, os.getcwd())}" + ("" if args.no_figure else
                                                           f" and {os.path.relpath(args.figure, os.getcwd())}")
        + f" in {elapsed:.1f} s")
    return data


if __name__ == "__main__":
    main()
