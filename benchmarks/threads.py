"""Threads on a shared machine: one against two torch threads, quiet and loaded.

Workloads, from many small ops to few large ones (float64):

* ``colour``: ``bragg_xyz`` of one mirror (``method="spectral"``: ~1 000 wavelengths, ~100 ops
  of ~1 000 elements), the unit of a fitting loop;
* ``fit step``: one forward + backward of ``thin_film_reflectance`` over 81 wavelengths × 64
  pixels with a gradient (estimation-sized);
* ``grid 36k``: ``bragg_reflectance`` on 401 × 90 (ops of 36 090 elements, above torch's
  parallel grain of 32 768);
* ``grid 10⁶``: the same on 10⁶ points (chunked: blocks of 32 768 points);

each timed with one torch thread, two, and two with torchirid's policy (the default: one thread for
calls below ``torchirid._threads.SMALL_WORK`` elements, the cores other processes leave free for
larger ones) in alternation (paired
rounds, median of the per-round ratio to one thread), on a quiet machine and while ``--load``
busy processes (pure-Python loops, one core each) run beside it. A ratio > 1 means slower than
one thread.

Run: ``.venv/bin/python benchmarks/threads.py`` (~2 min).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

import torch

import torchirid as ti

F = torch.float64


def workloads():
    lam = torch.linspace(380.0, 780.0, 401, dtype=F)
    c = torch.cos(torch.linspace(0.0, 1.5, 90, dtype=F))[:, None]
    big_c = torch.cos(torch.linspace(0.0, 1.5, 2494, dtype=F))[:, None]
    lam81 = torch.linspace(400.0, 720.0, 81, dtype=F)
    d = torch.linspace(200.0, 400.0, 64, dtype=F)[:, None].requires_grad_()
    one = torch.tensor(0.8, dtype=F)

    def fit_step():
        R = ti.thin_film_reflectance(lam81, 0.9, 1.38, d, 1.5)
        R.square().sum().backward()
        d.grad = None

    return {
        "colour": (lambda: ti.bragg_xyz(one, 1.0, 1.5, 125.0, 375.0, 20), 40),
        "fit step": (fit_step, 40),
        "grid 36k": (lambda: ti.bragg_reflectance(lam, c, 1.0, 1.5, 125.0, 375.0, 20), 10),
        "grid 10⁶": (lambda: ti.bragg_reflectance(lam, big_c, 1.0, 1.5, 125.0, 375.0, 20), 1),
    }


def timed(fn, calls):
    t = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - t) / calls


VARIANTS = {  # name: (torch threads, torchirid small-work threads, large-work threads)
    "1 thread": (1, None, None),
    "2 threads": (2, None, None),
    "2 threads + policy": (2, 1, "auto"),
}


def measure(rounds):
    """{workload: {variant: (median time, median ratio to 1 thread, min, max)}}"""
    out = {}
    for name, (fn, calls) in workloads().items():
        fn()
        times = {v: [] for v in VARIANTS}
        for _ in range(rounds):
            for v, (threads, small, large) in VARIANTS.items():
                torch.set_num_threads(threads)
                ti.options(small_work_threads=small, large_work_threads=large)
                times[v].append(timed(fn, calls))
        ti.options(small_work_threads=1, large_work_threads="auto")
        base = times["1 thread"]
        out[name] = {}
        for v, ts in times.items():
            ratios = [t / b for t, b in zip(ts, base)]
            out[name][v] = (statistics.median(ts), statistics.median(ratios), min(ratios), max(ratios))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--load", type=int, default=1, help="busy processes in the loaded condition")
    args = ap.parse_args(argv)
    quiet = measure(args.rounds)
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(args.load)]
    try:
        time.sleep(0.5)
        loaded = measure(args.rounds)
    finally:
        for p in busy:
            p.kill()
    for label, res in (("quiet", quiet), (f"loaded ({args.load} busy process)", loaded)):
        print(f"\n{label}: time (ms) and ratio to one thread, median [range] over {args.rounds} paired rounds\n")
        print("| workload | " + " | ".join(VARIANTS) + " |")
        print("|---|" + "---:|" * len(VARIANTS))
        for name, row in res.items():
            cells = [f"{row[v][0] * 1e3:.2f} ms" + ("" if v == "1 thread" else
                     f", {row[v][1]:.2f}× [{row[v][2]:.2f}–{row[v][3]:.2f}]") for v in VARIANTS]
            print(f"| {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
