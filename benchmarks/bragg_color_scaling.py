"""How the landmark and sampled Bragg colour methods scale with batch size and torch threads.

Fourneau Fig. 4's mirrors (n1 = 1, n2 = 1.5, N = 20, d1/Λ = 0.1 … 0.9) at one period Λ, with
``angles`` incidence angles 0–89° per call (9 × angles colours), unpolarized, float64. For each
thread count and batch size the methods run in interleaved rounds (random order per round);
printed: median ms per call and µs per colour, and the paired per-round ratio of
sampled K = 128 to each landmark configuration with the number of rounds it held.

It answers where the time of a landmark call goes that the speed-against-error benchmark
(``bragg_color_speed_vs_error.py``) only shows in total: the fixed cost (a 9-colour call), and
whether a second thread helps (torch runs an elementwise op on one thread below 32768 entries).

    python benchmarks/bragg_color_scaling.py                       # Λ = 244 nm, 1 and 2 threads
    python benchmarks/bragg_color_scaling.py --period 500 --rounds 25

Run it on idle cores with glibc's thresholds raised, as the main benchmark does
(``MALLOC_MMAP_THRESHOLD_=MALLOC_TRIM_THRESHOLD_=1073741824``; the script re-executes itself
with them unless ``--malloc default``).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys

import torch

import torchirid as ti
from bragg_color_speed_vs_error import MALLOC, time_rounds  # (this script's folder is on sys.path)

METHODS = {
    "piecewise s=5": dict(method="piecewise", subdivisions=5),
    "piecewise s=8": dict(method="piecewise", subdivisions=8),
    "sampled K=64": dict(method="sampled", samples=64),
    "sampled K=128": dict(method="sampled", samples=128),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--period", type=float, default=244.0, help="Λ in nm (default 244)")
    ap.add_argument("--angles", default="1,90,270,900", help="angles per call, comma-separated (× 9 colours)")
    ap.add_argument("--threads", default="1,2", help="torch thread counts, comma-separated")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--malloc", choices=("tuned", "default"), default="tuned")
    args = ap.parse_args(argv)
    tuned = os.environ.get("MALLOC_MMAP_THRESHOLD_") == MALLOC and os.environ.get("MALLOC_TRIM_THRESHOLD_") == MALLOC
    if args.malloc == "tuned" and not tuned:  # glibc reads these at start-up
        env = dict(os.environ, MALLOC_MMAP_THRESHOLD_=MALLOC, MALLOC_TRIM_THRESHOLD_=MALLOC)
        sys.stdout.flush()
        os.execve(sys.executable, [sys.executable, os.path.abspath(__file__), *(sys.argv[1:] if argv is None else argv)],
                  env)
    L = args.period
    d1 = (torch.tensor([0.1 * i for i in range(1, 10)], dtype=torch.float64) * L)[:, None]
    d2 = L - d1
    print(f"Λ = {L:g} nm, torch {torch.__version__}, {os.cpu_count()} cores, {args.rounds} rounds")
    print("| threads | colours per call | " + " | ".join(f"{m} (ms / µs per colour)" for m in METHODS)
          + " | K=128 / s=5 | K=128 / s=8 |")
    print("|---:|---:|" + "---:|" * (len(METHODS) + 2))
    for threads in (int(t) for t in args.threads.split(",")):
        torch.set_num_threads(threads)
        for nang in (int(a) for a in args.angles.split(",")):
            cos = torch.cos(torch.deg2rad(torch.linspace(0, 89, nang, dtype=torch.float64)))
            fns = {name: (lambda kw=kw: ti.bragg_xyz(cos, 1.0, 1.5, d1, d2, 20, **kw)) for name, kw in METHODS.items()}
            times = time_rounds(fns, args.rounds, seed=threads * 1000 + nang)
            n = 9 * nang
            cells = [f"{statistics.median(times[m]) * 1e3:.2f} / {statistics.median(times[m]) / n * 1e6:.1f}"
                     for m in METHODS]
            for m in ("piecewise s=5", "piecewise s=8"):
                r = [k / s for k, s in zip(times["sampled K=128"], times[m])]
                cells.append(f"{statistics.median(r):.2f}× ({sum(x > 1 for x in r)} of {len(r)})")
            print(f"| {threads} | {n} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
