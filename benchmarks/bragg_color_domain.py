"""Where the fast Bragg-colour methods are valid: ΔE2000 of ``piecewise`` and ``envelope`` against
the converged ``spectral`` colour, binned by the number of fringes in the visible.

Both fast methods replace the fringes of the Yeh spectrum by their average (Fourneau et al.
2024, §3.2). That holds when the visible range holds many fringes, so the CMFs average them:
the governing quantity is the fringe count of each colour,

.. math:: F = N\\,(n_1 d_1 \\cos θ_1 + n_2 d_2 \\cos θ_2)\\,(ω_{max} − ω_{min})/π ,

(:func:`torchirid.spectral.sampling.fringe_count`), not Λ or N alone: short periods (Λ = 10–80 nm, whose
first Bragg band lies in the UV) and few cells (N = 5) both give few fringes.

Grid (float64, unpolarized, D65 / CIE 1931 2°, 380–780 nm, mirrors embedded in n1 = 1):
n2 ∈ {1.5, 2.0, 2.4}, N ∈ {5, 10, 20, 50, 100}, Λ ∈ {10, 20, 40, 60, 80, 100, 140, 180, 244,
350, 500, 700, 988} nm, d1/Λ ∈ {0.1, 0.3, 0.5, 0.7, 0.9}, θ = 0, 6, …, 84°: 14 625 colours per
method. Output: a table of p50 / p95 / max ΔE2000 per F bin for each method, written between
``<!-- bragg-domain:start -->`` and ``<!-- bragg-domain:end -->`` of
``benchmarks/results/bragg_color.md`` (``--no-write`` prints it only). ~3 min on 2 cores.

Run: ``.venv/bin/python benchmarks/bragg_color_domain.py``
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import time
from pathlib import Path

import numpy as np
import torch

import torchirid as ti
from torchirid.color import delta_e_2000, xyz_to_lab
from torchirid.spectral.sampling import fringe_count

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "bragg_color.md"
BINS = [0, 4, 8, 10, 12, 14, 16, 20, 30, 50, 100, math.inf]
F64 = torch.float64


def measure(quick: bool = False):
    n2s = [1.5, 2.0, 2.4]
    cells = [5, 10, 20, 50, 100] if not quick else [5, 20]
    periods = [10, 20, 40, 60, 80, 100, 140, 180, 244, 350, 500, 700, 988] if not quick else [20, 80, 244]
    theta = torch.tensor(np.deg2rad(np.arange(0.0, 85.0, 6.0)), dtype=F64)
    cos = torch.cos(theta)[:, None]
    frac = torch.tensor([0.1, 0.3, 0.5, 0.7, 0.9], dtype=F64)
    rows = {"F": [], "piecewise": [], "envelope": []}
    t0 = time.perf_counter()
    for n2 in n2s:
        for N in cells:
            for L in periods:
                d1 = L * frac
                d2 = L - d1
                ref = xyz_to_lab(ti.bragg_xyz(cos, 1.0, n2, d1, d2, N, method="spectral"))
                rows["F"].append(fringe_count(cos, 1.0, n2, d1, d2, N).expand(ref.shape[:-1]).reshape(-1))
                for m in ("piecewise", "envelope"):
                    with np.errstate(all="ignore"), torch.no_grad():
                        import warnings
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore")
                            lab = xyz_to_lab(ti.bragg_xyz(cos, 1.0, n2, d1, d2, N, method=m))
                    rows[m].append(delta_e_2000(lab, ref).reshape(-1))
            print(f"n2 = {n2}: done ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
    return {k: torch.cat(v).numpy() for k, v in rows.items()}


def table(res) -> str:
    lines = ["| fringes F in 380–780 nm | colours | piecewise p50 / p95 / max | envelope p50 / p95 / max |",
             "|---|---|---|---|"]
    F = res["F"]
    for lo, hi in zip(BINS[:-1], BINS[1:]):
        sel = (F >= lo) & (F < hi)
        if not sel.any():
            continue
        cells = []
        for m in ("piecewise", "envelope"):
            e = res[m][sel]
            cells.append(f"{np.percentile(e, 50):.2f} / {np.percentile(e, 95):.2f} / {e.max():.2f}")
        name = f"{lo:g}–{hi:g}" if math.isfinite(hi) else f"≥ {lo:g}"
        lines.append(f"| {name} | {int(sel.sum())} | {cells[0]} | {cells[1]} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-write", action="store_true", help="print the table only")
    ap.add_argument("--quick", action="store_true", help="a small grid (a smoke test)")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)
    res = measure(args.quick)
    md = table(res)
    print(md)
    if not args.no_write and not args.quick:
        text = RESULTS.read_text() if RESULTS.exists() else ""
        block = ("<!-- bragg-domain:start -->\n## Domain of the fast methods (fringes in the visible)\n\n"
                 f"Command: `.venv/bin/python benchmarks/bragg_color_domain.py`; {res['F'].size} colours "
                 "(n2 1.5/2.0/2.4, N 5–100, Λ 10–988 nm, d1/Λ 0.1–0.9, θ 0–84°), ΔE2000 against "
                 "`method=\"spectral\"`.\n\n" + md + "\n<!-- bragg-domain:end -->")
        pat = re.compile(r"<!-- bragg-domain:start -->.*?<!-- bragg-domain:end -->", re.S)
        text = pat.sub(block, text) if pat.search(text) else text.rstrip("\n") + "\n\n" + block + "\n"
        RESULTS.write_text(text)
        print(f"wrote {RESULTS.relative_to(ROOT)}", file=sys.stderr)


if __name__ == "__main__":
    main()
