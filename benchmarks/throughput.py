"""Throughput at the sizes users compute: ns per point and peak memory against grid size.

Kernels: ``bragg_reflectance`` (Fourneau Fig. 1's mirror, N = 20), ``thin_film_reflectance``
(1.33 / 300 nm on 1.5) and ``multilayer`` (L = 10 films, R and T), float64, no gradient,
unpolarized, ``--threads`` torch threads. Grid: W wavelengths (380–780 nm) × A angles (0–86°)
with W·A ≈ the size, W = min(2001, size // 10). Sizes 10⁴, 3.6·10⁴, 10⁶, 10⁷ (and 10⁸ with
``--huge``, chunked only).

One fresh process per (kernel, size, mode) measures the best of ``--repeats`` calls and its peak
RSS above the process's baseline (inputs and outputs included), reported over the size of the
outputs (multilayer returns two). Cost per point against the 36k grid's (sizes ≥ 10⁶): in one
process, paired rounds of the 36k grid (best of 5 calls) and the large grid (one call), the
ratio of their ns/point per round, the median over ``--rounds`` — robust to the load of other
processes, which single timings on this shared machine are not. Modes: ``chunked`` (the default evaluation), ``one piece``
(``torchirid.options(chunk_size=None)``, with ``--unchunked``), ``compiled`` (``torchirid.options(compile=True)``,
chunked; Bragg only — the other kernels have no compiled path; with ``--compiled``), whose first
call (the compile) is reported separately.

tmm_fast (``--peer``, up to 10⁶ points; beyond, its transfer matrices of every point and film
do not fit in memory): in one process, paired rounds — ours (chunked) and ``tmm_fast.coh_tmm``
(s and p) back to back on the same grid, the ratio per round, the median over ``--rounds``.

Output: a markdown table (stdout; ``--write`` also puts it between ``<!-- throughput:start -->``
and ``<!-- throughput:end -->`` of ``benchmarks/results/throughput.md``), and with ``--plot
FILE`` a log-log plot of ns/point against grid size.

Run: ``.venv/bin/python benchmarks/throughput.py --unchunked --compiled --peer --huge --write
--plot docs/figures/throughput.png`` (~15 min on 2 cores, quiet machine).
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results" / "throughput.md"

SETUP = r'''
import json, resource, statistics, sys, time
import torch, torchirid as ti
F = torch.float64

def grid(size):
    W = min(2001, max(2, size // 10)); A = max(1, size // W)
    lam = torch.linspace(380.0, 780.0, W, dtype=F)
    theta = torch.linspace(0.0, 1.5, A, dtype=F)
    return lam, torch.cos(theta)[:, None], theta

L = 10
IDX = torch.tensor([1.0] + [1.38, 2.3] * (L // 2) + [1.52], dtype=torch.complex128)
THK = torch.tensor([100.0, 60.0] * (L // 2), dtype=F)
BRAGG_IDX = torch.tensor([1.0] + [1.0, 1.5] * 20 + [1.0], dtype=torch.complex128)
BRAGG_THK = torch.tensor([125.0, 375.0] * 20, dtype=F)

def ours(kernel, lam, c):
    return {
        "bragg": lambda: ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20),
        "thin_film": lambda: ti.thin_film_reflectance(lam, c, 1.33, 300.0, 1.5),
        "multilayer": lambda: ti.multilayer(lam, c, IDX, THK),
    }[kernel]

OUTPUTS = {"bragg": 1, "thin_film": 1, "multilayer": 2}

def peer(kernel, lam, theta):
    import tmm_fast
    idx, thk = {"bragg": (BRAGG_IDX, BRAGG_THK), "multilayer": (IDX, THK),
                "thin_film": (torch.tensor([1.0, 1.33, 1.5], dtype=torch.complex128),
                              torch.tensor([300.0], dtype=F))}[kernel]
    M = idx[None, :, None].expand(1, idx.numel(), lam.numel()).contiguous()
    T = torch.cat([torch.tensor([float("inf")], dtype=F), thk * 1e-9, torch.tensor([float("inf")], dtype=F)])[None]
    lm = lam * 1e-9
    return lambda: [tmm_fast.coh_tmm(p, M, T, theta, lm, device="cpu")["R"] for p in ("s", "p")]
'''

CHILD = SETUP + r'''
kernel, size, mode, threads, repeats = sys.argv[1], int(sys.argv[2]), sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
torch.set_num_threads(threads)
lam, c, _ = grid(size)
points = lam.numel() * c.numel()
if mode == "compiled":
    ti.options(compile=True)
f = ours(kernel, lam, c)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
ctx = ti.options(chunk_size=None) if mode == "one piece" else ti.options(chunk_size=ti.get_chunk_size())
first = None
best = float("inf")
with ctx, torch.no_grad():
    if mode == "compiled":
        t = time.perf_counter(); out = f(); first = time.perf_counter() - t; del out
    for _ in range(repeats):
        t = time.perf_counter(); out = f(); best = min(best, time.perf_counter() - t)
        del out
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"points": points, "ns": best / points * 1e9, "peak_mb": (peak - base) / 1024,
                  "out_mb": OUTPUTS[kernel] * points * 8 / 2**20, "first_s": first}))
'''

PAIRED = SETUP + r'''
kernel, size, threads, rounds = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
torch.set_num_threads(threads)
lam, c, theta = grid(size)
f, g = ours(kernel, lam, c), peer(kernel, lam, theta)
ratios = []
with torch.no_grad():
    f(); g()
    for _ in range(rounds):
        t = time.perf_counter(); f(); a = time.perf_counter() - t
        t = time.perf_counter(); g(); b = time.perf_counter() - t
        ratios.append(b / a)
print(json.dumps({"ratio": statistics.median(ratios), "lo": min(ratios), "hi": max(ratios)}))
'''


SCALING = SETUP + r'''
kernel, size, threads, rounds = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
torch.set_num_threads(threads)
small, big = grid(36_090), grid(size)
f, g = ours(kernel, *small[:2]), ours(kernel, *big[:2])
ns, nb = small[0].numel() * small[1].numel(), big[0].numel() * big[1].numel()

def best(fn, reps):
    t_best = float("inf")
    for _ in range(reps):
        t = time.perf_counter(); fn(); t_best = min(t_best, time.perf_counter() - t)
    return t_best

ratios = []
with torch.no_grad():
    f(); g()
    for _ in range(rounds):
        a = best(f, 5) / ns
        b = best(g, 1) / nb
        ratios.append(b / a)
print(json.dumps({"ratio": statistics.median(ratios), "lo": min(ratios), "hi": max(ratios)}))
'''


def _child(code, *args, timeout=3600):
    proc = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True,
                          timeout=timeout)
    if proc.returncode != 0:
        lines = proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"]
        return {"error": lines[-1][:120]}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def plot(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.6), layout="constrained")
    colours = {"bragg": "C0", "thin_film": "C1", "multilayer": "C2"}
    styles = {"chunked": "-o", "one piece": "--s", "compiled": ":^"}
    for (kernel, mode), rows in sorted(results.items()):
        rows = [r for r in rows if "ns" in r]
        if rows:
            ax.plot([r["points"] for r in rows], [r["ns"] for r in rows], styles[mode], color=colours[kernel],
                    label=f"{kernel.replace('_', ' ')}, {mode}", ms=4)
    ax.set(xscale="log", yscale="log", xlabel="points per call", ylabel="ns per point (best of calls)",
           title="Throughput against grid size (float64, 2 threads, no gradient)")
    ax.grid(True, which="both", alpha=0.3)
    fig.legend(loc="outside lower center", ncol=3, fontsize=7)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    print(f"wrote {path}")


def _results_from_table(text):
    """{(kernel, mode): [row]} from the markdown table written by ``--write`` (for ``--replot``)."""
    lines = [ln for ln in text.splitlines() if ln.startswith("| ") and not ln.startswith("| kernel")]
    header = next(ln for ln in text.splitlines() if ln.startswith("| kernel"))
    cols = [c.strip() for c in header.strip("|").split("|")]
    results = {}
    for ln in lines:
        cells = [c.strip() for c in ln.strip("|").split("|")]
        row = dict(zip(cols, cells))
        for mode in ("chunked", "one piece", "compiled"):
            value = row.get(f"{mode} ns/point", "–")
            try:
                ns = float(value)
            except ValueError:
                continue
            results.setdefault((row["kernel"], mode), []).append(
                {"points": int(row["points"].replace(",", "")), "ns": ns})
    return results


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--rounds", type=int, default=5,
                    help="paired rounds: cost per point against the 36k grid's (≥ 10⁶ points), tmm_fast (--peer)")
    ap.add_argument("--unchunked", action="store_true", help="also one-piece evaluation (not at 10⁸)")
    ap.add_argument("--compiled", action="store_true", help="also torchirid.options(compile=True) (Bragg)")
    ap.add_argument("--peer", action="store_true", help="tmm_fast speed ratio in paired rounds (≤ 10⁶ points)")
    ap.add_argument("--huge", action="store_true", help="also 10⁸ points (chunked only; ~1–2 min per kernel)")
    ap.add_argument("--kernels", default="bragg,thin_film,multilayer")
    ap.add_argument("--sizes", default=None, help="comma-separated sizes (default 1e4,36090,1e6,1e7[,1e8])")
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--plot", default=None, metavar="FILE")
    ap.add_argument("--replot", default=None, metavar="FILE",
                    help="only redraw the plot into FILE from benchmarks/results/throughput.md")
    args = ap.parse_args(argv)
    if args.replot:
        plot(_results_from_table(RESULTS.read_text()), args.replot)
        return
    if args.sizes:
        sizes = [int(float(s)) for s in args.sizes.split(",")]
    else:
        sizes = [10_000, 36_090, 1_000_000, 10_000_000] + ([100_000_000] if args.huge else [])
    header = ["kernel", "points", "chunked ns/point", "chunked peak / output"]
    if args.unchunked:
        header += ["one piece ns/point", "one piece peak / output"]
    if args.compiled:
        header += ["compiled ns/point", "compiled peak / output", "first call (compile) s"]
    header += ["cost/point ÷ 36k grid's (paired) [range]"]
    if args.peer:
        header += ["speed-up vs tmm_fast [range]"]
    rows = ["| " + " | ".join(header) + " |", "|---|" + "---:|" * (len(header) - 1)]
    print(rows[0], flush=True)
    results = {}

    def cell(r):
        if r is None:
            return ["–", "–"]
        if "error" in r:
            return [r["error"], ""]
        return [f"{r['ns']:.1f}", f"{r['peak_mb'] / r['out_mb']:.1f}×"]

    for kernel in args.kernels.split(","):
        for size in sizes:
            huge = size >= 10**8
            reps = 1 if huge else args.repeats
            a = _child(CHILD, kernel, size, "chunked", args.threads, reps)
            results.setdefault((kernel, "chunked"), []).append(a)
            cells = [kernel, f"{a.get('points', size):,}", *cell(a)]
            if args.unchunked:
                b = None if huge else _child(CHILD, kernel, size, "one piece", args.threads, reps)
                if b is not None:
                    results.setdefault((kernel, "one piece"), []).append(b)
                cells += cell(b)
            if args.compiled:
                cc = _child(CHILD, kernel, size, "compiled", args.threads, reps) if kernel == "bragg" else None
                if cc is not None:
                    results.setdefault((kernel, "compiled"), []).append(cc)
                cells += cell(cc) + ([f"{cc['first_s']:.1f}"] if cc and "first_s" in cc else ["–"])
            sc = _child(SCALING, kernel, size, args.threads, args.rounds) if size >= 1_000_000 else None
            cells.append("–" if sc is None else sc.get("error") or f"{sc['ratio']:.2f} [{sc['lo']:.2f}–{sc['hi']:.2f}]")
            if args.peer:
                p = _child(PAIRED, kernel, size, args.threads, args.rounds) if size <= 1_000_000 else None
                cells.append("–" if p is None else p.get("error") or f"{p['ratio']:.0f}× [{p['lo']:.0f}–{p['hi']:.0f}]")
            rows.append("| " + " | ".join(cells) + " |")
            print(rows[-1], flush=True)
    table = "\n".join(rows)
    print()
    print(table)
    if args.plot:
        plot(results, args.plot)
    if args.write:
        block = (f"<!-- throughput:start -->\nCommand: `.venv/bin/python benchmarks/throughput.py "
                 f"{' '.join(argv if argv is not None else sys.argv[1:])}`\n\n{table}\n<!-- throughput:end -->")
        text = RESULTS.read_text() if RESULTS.exists() else "# Throughput against grid size\n"
        pat = re.compile(r"<!-- throughput:start -->.*?<!-- throughput:end -->", re.S)
        text = pat.sub(lambda _: block, text) if pat.search(text) else text.rstrip("\n") + "\n\n" + block + "\n"
        RESULTS.write_text(text)


if __name__ == "__main__":
    main()
