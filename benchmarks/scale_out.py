"""Scale-out of table builds on Dask (issue 24): speed-up from 1 to 2 workers, per-chunk overhead,
and a projection to 10 and 100 nodes.

Workload: ``torchirid.scale.build_table`` of ``bragg_xyz`` (spectral, N = 200 cells) over
cos θ (48) × d1 (32) = 1 536 colours in chunks of 8 × 8 (24 chunks), float64, each worker one
process with one torch thread (``threads_per_worker=1``, ``torch.set_num_threads(1)`` on it), in
this process (no Dask) and on ``torchirid.scale.local_cluster`` of 1 and 2 workers (Dask's
``LocalCluster`` with ``WORKER_ENVIRON``: the allocator settings that keep chunks as fast as in
process); wall time of the build
(cluster start excluded), median of ``--repeats`` builds into fresh stores.

Monte Carlo: ``montecarlo_brdf_blocks`` (2 layers over a Lambertian base, 16 direction pairs ×
8 wavelengths, 4 096 paths per pair in 8 seeded blocks), wall time in the same three places.

Batch fitting: ``fit_batch("film", …)`` of 8 synthetic hyperspectral cubes (MgF2 films, 6 × 6
pixels, 5 angles, written as .npz), one ``estimate_film`` each, wall time in the same three places.

Per-chunk overhead: the same with a trivial function (``thin_film_reflectance`` of one point
per chunk, 200 chunks): (time per chunk on the cluster) − (time per chunk in process).

Projection: with chunks of compute time ``t`` and a serial per-chunk cost ``o`` at the scheduler
and client (measured above as an upper bound), ``n`` workers finish ``C`` chunks in about
``max(C t / n, C o)``: efficiency ``min(1, t / (n o))``. Printed for n = 10 and 100 (one worker
per node) at this workload's ``t``.

Run: ``.venv/bin/python benchmarks/scale_out.py`` (~2 min on 2 cores).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

import torchirid as ti
from torchirid.layered import LayeredBragg, RoughBraggLayer
from torchirid.scale import build_table, fit_batch, local_cluster, montecarlo_brdf_blocks


def _timed_builds(fn, axes, chunks, kwargs, channels, repeats, client=None):
    times = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as d:
            t = time.perf_counter()
            build_table(fn, axes, Path(d) / "t.zarr", chunks=chunks, kwargs=kwargs, channels=channels, client=client)
            times.append(time.perf_counter() - t)
    return statistics.median(times)


def _timed_montecarlo(repeats, client=None):
    """``montecarlo_brdf_blocks``: 2 layers over a Lambertian base, 16 direction pairs × 8
    wavelengths, 4 096 paths per pair in 8 blocks (``transmission="microfacet"``)."""
    s = LayeredBragg([RoughBraggLayer(1.0, 1.5, 100.0, 100.0, 5, 0.2), RoughBraggLayer(1.0, 1.6, 90.0, 120.0, 8, 0.1)],
                     base_albedo=0.5)
    t = torch.linspace(0.0, 1.2, 16, dtype=torch.float64)
    wi = torch.stack([torch.sin(t), 0 * t, torch.cos(t)], -1)
    wo = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
    lam = torch.linspace(400.0, 700.0, 8, dtype=torch.float64)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        montecarlo_brdf_blocks(lam, wi, wo, s, samples=4096, blocks=8, client=client, transmission="microfacet")
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def _cubes(folder: Path, count: int = 8) -> list[Path]:
    import torchirid.estimation as E

    paths = []
    for i in range(count):
        c = E.synthetic_cube("mgf2_400" if i % 2 else "mgf2_600", height=6, width=6, seed=i)
        E.write_npz(folder / f"cube{i}.npz", c.cube, c.wavelength, c.angles_deg)
        paths.append(folder / f"cube{i}.npz")
    return paths


def _timed_fits(paths, repeats, client=None):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        # a constant index: the ~1.6 s items of docs/performance.md (the default "auto" tries three models)
        recs = fit_batch("film", paths, fit={"index_model_name": "constant"}, client=client)
        times.append(time.perf_counter() - start)
        assert all(r["status"] == "ok" for r in recs), [r["error"] for r in recs]
    return statistics.median(times)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    from distributed import Client

    torch.set_num_threads(1)
    axes = {"cos_theta": np.linspace(0.2, 1.0, 48), "d1": np.linspace(80.0, 160.0, 32)}
    kwargs = {"n1": 1.0, "n2": 1.5, "d2": 375.0, "cells": 200}
    trivial_axes = {"wavelength": np.linspace(400.0, 700.0, 200)}
    trivial_kwargs = {"cos_theta": 1.0, "n_film": 1.33, "thickness": 300.0, "n_substrate": 1.5}
    rows = {}
    cube_dir = tempfile.TemporaryDirectory()
    cubes = _cubes(Path(cube_dir.name))
    rows["in process"] = (_timed_builds(ti.bragg_xyz, axes, 8, kwargs, (3,), args.repeats),
                          _timed_builds(ti.thin_film_reflectance, trivial_axes, 1, trivial_kwargs, (), args.repeats),
                          _timed_montecarlo(args.repeats), _timed_fits(cubes, args.repeats))
    for workers in (1, 2):
        with local_cluster(workers) as cluster, Client(cluster) as client:
            client.run(torch.set_num_threads, 1)
            rows[f"LocalCluster, {workers} worker{'s' if workers > 1 else ''}"] = (
                _timed_builds(ti.bragg_xyz, axes, 8, kwargs, (3,), args.repeats, client),
                _timed_builds(ti.thin_film_reflectance, trivial_axes, 1, trivial_kwargs, (), args.repeats, client),
                _timed_montecarlo(args.repeats, client), _timed_fits(cubes, args.repeats, client))
    base = rows["in process"][0]
    one = rows["LocalCluster, 1 worker"][0]
    mc_base, mc_one = rows["in process"][2], rows["LocalCluster, 1 worker"][2]
    fit_base, fit_one = rows["in process"][3], rows["LocalCluster, 1 worker"][3]
    print("| where | table build (s) | speed-up vs in process | vs 1 worker | trivial chunks: ms per chunk "
          "| Monte Carlo (s) | speed-up vs in process | vs 1 worker | 8 film fits (s) | speed-up vs in process "
          "| vs 1 worker |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, (t, triv, mc, fits) in rows.items():
        print(f"| {name} | {t:.2f} | {base / t:.2f}× | {one / t:.2f}× | {triv / 200 * 1e3:.2f} | {mc:.2f} | "
              f"{mc_base / mc:.2f}× | {mc_one / mc:.2f}× | {fits:.2f} | {fit_base / fits:.2f}× | {fit_one / fits:.2f}× |")
    cube_dir.cleanup()
    chunks = 24
    t_chunk = base / chunks
    overhead = max(rows["LocalCluster, 2 workers"][1], rows["LocalCluster, 1 worker"][1]) / 200 - \
        rows["in process"][1] / 200
    print(f"\nchunk compute time t = {t_chunk * 1e3:.1f} ms; per-chunk overhead on the cluster o ≤ "
          f"{overhead * 1e3:.2f} ms")
    for n in (10, 100):
        eff = min(1.0, t_chunk / (n * overhead)) if overhead > 0 else 1.0
        print(f"projection, {n} workers: efficiency ≈ {eff:.2f} at this chunk size (chunks of ≥ "
              f"{n * overhead * 1e3:.0f} ms keep it near 1)")


if __name__ == "__main__":
    main()
