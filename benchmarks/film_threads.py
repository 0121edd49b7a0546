"""Film estimation with the default thread policy against one and two threads, quiet and loaded.

The bar (issue 35): ``estimate_film`` on a 256 × 256, 5-angle synthetic cube with default
settings within 1.3× of the best thread count's time, both on a quiet machine and beside a busy
process. Three configurations alternate in paired rounds in one process (the cube is rendered
once, not timed):

* ``default``: torch's thread count (all cores) and torchirid's policy
  (``large_work_threads="auto"``: the cores other processes leave free; torchirid._threads);
* ``1 thread``: ``torch.set_num_threads(1)``, the policy off;
* ``N threads``: ``torch.set_num_threads(N)`` (N = the cores), the policy off;

then the same while ``--load`` busy processes (pure-Python loops, one core each) run beside it.
Figure: per condition, the median over rounds of default / min(1 thread, N threads) of the same
round, with [min–max].

``--workload match`` times ``match_scatterogram`` (the jewel beetle's green scatterograms at two
incidences, ``--size`` pixels a side, a local refinement from a nearby start) and ``--workload
texture`` ``realtime.fit_texture`` (a thin-film texture of 16 × 32 texels from 20 000 samples)
the same way.

Run: ``.venv/bin/python benchmarks/film_threads.py`` (~15 min at 256 × 256;
``--size 128`` for a quicker look); ``--workload match --size 24``, ``--workload texture``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

import torch

import torchirid as ti
from torchirid.estimation import estimate_film, synthetic_cube

BUSY = "while True: pass"


def configurations(cores):
    def default():
        torch.set_num_threads(cores)
        return ti.options(large_work_threads="auto")

    def fixed(n):
        def setup():
            torch.set_num_threads(n)
            return ti.options(large_work_threads=None)
        return setup

    return {"default": default, "1 thread": fixed(1), f"{cores} threads": fixed(cores)}


def workload(name, size):
    """The call to time, built once (its inputs are not timed)."""
    if name == "film":
        cube = synthetic_cube("mgf2_400", height=size, width=size)
        label = f"estimate_film on a {size} × {size} × {cube.cube.shape[2]}-angle cube"
        return label, lambda: estimate_film(cube.cube, cube.wavelength, cube.cos_theta, cube.sample.n_substrate)
    if name == "match":
        from torchirid.fitting import match_scatterogram, render_targets
        from torchirid.presets import jewel_beetle

        lam = torch.linspace(380.0, 780.0, 41, dtype=torch.float64)
        incs = [(0.0, 0.0), (40.0, 0.0)]
        target = render_targets(jewel_beetle("green"), incs, resolution=size, wavelength=lam)
        label = f"match_scatterogram on two {size} × {size} scatterograms (local refinement)"
        return label, lambda: match_scatterogram(target, incident_deg=incs, n1=1.59, cells=(8,), period_range=None,
                                                 wavelength=lam, init={"period": 166.0, "delta": 0.51, "dn": 0.08,
                                                                       "alpha": 0.07}, short_iter=8, max_iter=25)
    from torchirid.realtime import fit_texture

    label = "fit_texture('thin_film', (16, 32)) from 20 000 samples"
    return label, lambda: fit_texture("thin_film", (16, 32), ((0.2, 1.0), (100.0, 400.0)),
                                      {"n_film": 1.33, "n_substrate": 1.5}, samples=20_000, iterations=60)


def run(call, setup):
    with setup():
        t = time.perf_counter()
        out = call()
        return time.perf_counter() - t, out


def measure(call, rounds, cores):
    configs = configurations(cores)
    times = {k: [] for k in configs}
    for r in range(rounds):
        order = list(configs) if r % 2 == 0 else list(reversed(configs))
        for name in order:
            dt, _ = run(call, configs[name])
            times[name].append(dt)
        print(f"  round {r + 1}: " + ", ".join(f"{k} {v[-1]:.1f} s" for k, v in times.items()), flush=True)
    others = [k for k in configs if k != "default"]
    ratios = [times["default"][i] / min(times[k][i] for k in others) for i in range(rounds)]
    return times, ratios


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workload", choices=("film", "match", "texture"), default="film")
    ap.add_argument("--size", type=int, default=256, help="cube (or scatterogram) height and width, pixels")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--load", type=int, default=1, help="busy processes in the loaded condition")
    ap.add_argument("--only", choices=("quiet", "loaded"), help="one condition only")
    args = ap.parse_args(argv)
    cores = len(os.sched_getaffinity(0))
    label, call = workload(args.workload, args.size)
    if args.workload != "film":
        call()  # (a warm-up, untimed: caches and tables filled on first use)
    print(f"{label}, {cores} cores, {args.rounds} paired rounds; torch {torch.__version__}")
    for condition in ("quiet", "loaded"):
        if args.only and condition != args.only:
            continue
        busy = []
        if condition == "loaded":
            busy = [subprocess.Popen([sys.executable, "-c", BUSY]) for _ in range(args.load)]
            time.sleep(1.0)
        try:
            print(f"{condition}:" + (f" {args.load} busy process(es) beside it" if busy else ""))
            times, ratios = measure(call, args.rounds, cores)
        finally:
            for p in busy:
                p.kill()
        med = {k: statistics.median(v) for k, v in times.items()}
        print(f"  medians: " + ", ".join(f"{k} {v:.1f} s" for k, v in med.items()))
        print(f"  default / best: {statistics.median(ratios):.2f}× [{min(ratios):.2f}–{max(ratios):.2f}]")


if __name__ == "__main__":
    main()
