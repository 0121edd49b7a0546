"""Throughput at the sizes users compute: ns per point and peak memory against grid size.

For each kernel (``bragg_reflectance`` N = 20, ``thin_film_reflectance``, ``multilayer`` with
L = 10 layers) and grid size (10⁴, 3.6·10⁴, 10⁶, 10⁷ points; 10⁸ with ``--huge``), one fresh
process per (kernel, size, mode) measures the best of ``--repeats`` calls (float64, no
gradient, ``--threads`` torch threads) and its peak RSS above the process's baseline (the
inputs and the output included), for the default chunked evaluation and, with ``--unchunked``,
one-piece evaluation (``torchirid.chunk_size(None)``). The grid is W wavelengths (380–780 nm)
× A angles with W·A the size, W = min(2001, size // 10).

Output: a markdown table (stdout; ``--write`` also puts it between ``<!-- throughput:start -->``
and ``<!-- throughput:end -->`` of ``benchmarks/results/throughput.md``).

Run: ``.venv/bin/python benchmarks/throughput.py --unchunked`` (~3 min on 2 cores).
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

CHILD = r'''
import json, resource, sys, time
import torch, torchirid as ti
kernel, size, chunked, threads, repeats = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "1", int(sys.argv[4]), int(sys.argv[5])
torch.set_num_threads(threads)
F = torch.float64
W = min(2001, max(2, size // 10)); A = max(1, size // W)
lam = torch.linspace(380.0, 780.0, W, dtype=F)
c = torch.cos(torch.linspace(0.0, 1.5, A, dtype=F))[:, None]
L = 10
idx = torch.tensor([1.0] + [1.38, 2.3] * (L // 2) + [1.52], dtype=torch.complex128)
thk = torch.tensor([100.0, 60.0] * (L // 2), dtype=F)
calls = {
    "bragg": lambda: ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20),
    "thin_film": lambda: ti.thin_film_reflectance(lam, c, 1.33, 300.0, 1.5),
    "multilayer": lambda: ti.multilayer(lam, c, idx, thk)[0],
}
f = calls[kernel]
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
ctx = ti.chunk_size(ti.get_chunk_size() if chunked else None)
best = float("inf")
with ctx, torch.no_grad():
    for _ in range(repeats):
        t = time.perf_counter(); out = f(); best = min(best, time.perf_counter() - t)
        del out
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"points": W * A, "ns": best / (W * A) * 1e9, "peak_mb": (peak - base) / 1024,
                  "out_mb": W * A * 8 / 2**20}))
'''


def measure(kernel, size, chunked, threads, repeats):
    proc = subprocess.run([sys.executable, "-c", CHILD, kernel, str(size), "1" if chunked else "0", str(threads),
                           str(repeats)], capture_output=True, text=True, timeout=3600)
    if proc.returncode != 0:
        return {"error": proc.stderr.strip().splitlines()[-1][:120]}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--unchunked", action="store_true", help="also measure one-piece evaluation (not at 10⁸)")
    ap.add_argument("--huge", action="store_true", help="also 10⁸ points (chunked only; ~1 min per kernel)")
    ap.add_argument("--kernels", default="bragg,thin_film,multilayer")
    ap.add_argument("--write", action="store_true")
    args = ap.parse_args(argv)
    sizes = [10_000, 36_090, 1_000_000, 10_000_000] + ([100_000_000] if args.huge else [])
    rows = ["| kernel | points | chunked ns/point | chunked peak / output | one piece ns/point | one piece peak / output |",
            "|---|---:|---:|---:|---:|---:|"]
    for kernel in args.kernels.split(","):
        for size in sizes:
            a = measure(kernel, size, True, args.threads, args.repeats if size < 10**8 else 1)
            b = measure(kernel, size, False, args.threads, args.repeats) if args.unchunked and size < 10**8 else None

            def cell(r):
                if r is None:
                    return "–", "–"
                if "error" in r:
                    return r["error"], ""
                return f"{r['ns']:.1f}", f"{r['peak_mb'] / r['out_mb']:.1f}×"

            ca, cb = cell(a), cell(b)
            rows.append(f"| {kernel} | {a.get('points', size):,} | {ca[0]} | {ca[1]} | {cb[0]} | {cb[1]} |")
            print(rows[-1], flush=True)
    table = "\n".join(rows)
    print(table)
    if args.write:
        block = (f"<!-- throughput:start -->\nCommand: `.venv/bin/python benchmarks/throughput.py "
                 f"{' '.join(argv if argv is not None else sys.argv[1:])}`\n\n{table}\n<!-- throughput:end -->")
        text = RESULTS.read_text() if RESULTS.exists() else "# Throughput against grid size\n"
        pat = re.compile(r"<!-- throughput:start -->.*?<!-- throughput:end -->", re.S)
        text = pat.sub(block, text) if pat.search(text) else text.rstrip("\n") + "\n\n" + block + "\n"
        RESULTS.write_text(text)


if __name__ == "__main__":
    main()
