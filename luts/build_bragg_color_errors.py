#!/usr/bin/env python
r"""(Re)build ``src/torchirid/data/bragg_color_errors.json``: the measured error and cost of every
Bragg-colour method configuration, from which ``bragg_xyz(method="auto")`` chooses
(:mod:`torchirid.spectral.auto`).

Runs the measurement of ``benchmarks/bragg_color_speed_vs_error.py`` (its docstring gives the
grids — Fourneau et al. 2024's Fig. 4 and a denser one, 810 colours per period — the error
reference and the timing protocol): the p95 / median / max ΔE2000 of each configuration
against the converged spectral colour, and its µs per colour in interleaved rounds, plus the
batch-size check. Writes the table atomically, its provenance naming this script, the command
and the machine. The errors are deterministic; the times are this machine's (rebuild on the
machine whose costs ``method="auto"`` should reflect, with idle cores). ``--report`` also writes
the benchmark's figure and its section of ``benchmarks/results/bragg_color.md`` from the same
run; the benchmark on its own prints and writes those but not the table.

    python luts/build_bragg_color_errors.py --max-wait 240 --rounds 15   # the shipped table (~9 min, 2 idle cores)
    python luts/build_bragg_color_errors.py --rounds 15 --report         # and the benchmark's report

``--grids``, ``--periods``, ``--angles`` and ``--batch-angles`` shrink the measurement (for a
smoke test: such a table is not one to ship).

JSON schema (``format`` "torchirid.bragg_color_errors", ``format_version`` 1)::

    {
      "format": "torchirid.bragg_color_errors", "format_version": 1,
      "description": str,
      "provenance": {"builder": "luts/build_bragg_color_errors.py", "command": str,   # how to rebuild
                     "measured_with": str,                         # (optional) another command that ran it
                     "created": ISO date-time, "torchirid_version": str,
                     "torch_version": str, "python": str, "cpu": str, "threads": int, "cpus": [int],
                     "dtype": "float64", "allocator": str, "timing": str, "rounds": int,
                     "contended_rounds": int},
      "grids": {                       # grid name -> its definition
        "fig4" | "dense": {"n1": float, "n2": float, "cells": int, "periods_nm": [float],
                 "d1_over_period": [float], "angles_deg": [float], "polarization": str,
                 "illuminant": str, "observer": str, "wavelength_range_nm": [lo, hi],
                 "colours_per_period": 810,        # d1/Λ values × angles
                 "spectral_samples": {"244": int, ...},      # ω samples of default "spectral"
                 "error_reference": {"method": "spectral", "samples_per_fringe": 192.0,
                                     "samples": {"244": int, ...},
                                     "max_delta_e_vs_refinement": {"244": float, ...},
                                     "refinement_samples_per_fringe": 384.0}}
      },
      "entries": [                     # one per method configuration
        {"config": {...},              # keyword arguments of torchirid.bragg_xyz, exactly:
                                       #   {"method": "spectral"}
                                       #   {"method": "sampled", "samples": K}
                                       #   {"method": "piecewise", "subdivisions": s,
                                       #    "weights": "paper"|"averaged", "correction": "paper"|"fitted"}
                                       #   ("correction" is ignored by weights="averaged")
         "label": str,                 # e.g. "sampled K=64", "piecewise s=3 paper/paper"
         "grids": {
           "fig4" | "dense": {
             "median": float, "p95": float, "max": float,   # ΔE2000 over all colours of the grid
             "us_per_colour": float,                        # µs, this machine (see provenance)
             "speedup_vs_spectral": float,                  # machine-independent-ish ratio
             "per_period": {"244": {same five keys}, "500": {...}, "988": {...}}}}}
      ],
      "batch_size_check": {"grid": "fig4", "periods_nm": [244.0, 500.0, 988.0],
                           "entries": [{"config": {...},
                                        "us_per_colour": {"244": {"810": float, "2430": float, "8100": float},
                                                          "500": {...}, "988": {...}}}]}
    }

Per-period keys are Λ in nm as integer strings. ``speedup_vs_spectral`` is relative to default
``spectral`` on the same batch (its own entry has 1.0); times depend on the batch size.
"""

from __future__ import annotations

import datetime
import importlib.util
import json
import os
import platform
import sys
from pathlib import Path

import numpy as np
import torch

import torchirid as ti

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = ROOT / "src" / "torchirid" / "data" / "bragg_color_errors.json"
BUILDER = "luts/build_bragg_color_errors.py"


def _benchmark():
    path = ROOT / "benchmarks" / "bragg_color_speed_vs_error.py"
    spec = importlib.util.spec_from_file_location("bragg_color_speed_vs_error", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


bench = _benchmark()


def table(cfgs, keys, entries, refinfo, args, elapsed) -> dict:
    """The JSON document (schema: the module docstring)."""
    return {
        "format": "torchirid.bragg_color_errors",
        "format_version": 1,
        "description": ("ΔE2000 (CIE Lab, D65) of torchirid.bragg_xyz methods against the converged "
                        "method='spectral', and their time per colour, for method selection. Schema: docstring of "
                        f"{BUILDER}."),
        "provenance": {
            "builder": BUILDER,
            "command": args.command,
            "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "torchirid_version": ti.__version__, "torch_version": torch.__version__,
            "python": platform.python_version(), "cpu": f"{bench.cpu_name()}, {os.cpu_count()} cores",
            "threads": args.threads, "cpus": args.cpus_used, "dtype": "float64", "allocator": bench.allocator(args),
            "timing": (f"one call per (method, Λ) on the {len(bench.FRACTIONS)} × {len(bench.ANGLES)} batch; median of "
                       f"{args.rounds} interleaved rounds; whole run {elapsed:.0f} s"),
            "contended_rounds": refinfo["quiet"]["contended"], "rounds": refinfo["quiet"]["rounds"],
        },
        "grids": {
            grid: {"n1": g["n1"], "n2": g["n2"], "cells": g["cells"], "periods_nm": list(g["periods"]),
                   "d1_over_period": bench.FRACTIONS, "angles_deg": [float(a) for a in bench.ANGLES],
                   "polarization": "unpolarized", "illuminant": "D65", "observer": "CIE 1931 2",
                   "wavelength_range_nm": [380.0, 780.0], "colours_per_period": bench.colours(),
                   "spectral_samples": refinfo[grid]["samples"],
                   "error_reference": {"method": "spectral", "samples_per_fringe": bench.REF_SPF,
                                       "samples": refinfo[grid]["ref_samples"],
                                       "max_delta_e_vs_refinement": refinfo[grid]["check"],
                                       "refinement_samples_per_fringe": bench.CHECK_SPF}}
            for grid, g in bench.GRIDS.items()},
        "entries": [{"config": c, "label": bench.label(c), "grids": entries[k]} for c, k in zip(cfgs, keys)],
        "batch_size_check": {
            "grid": bench.BATCH_CHECK["grid"], "periods_nm": list(bench.BATCH_CHECK["periods"]),
            "entries": [{"config": c, "us_per_colour": {pk: per[json.dumps(c, sort_keys=True)]
                                                        for pk, per in bench.batch_medians(refinfo).items()}}
                        for c in bench.BATCH_CONFIGS]},
    }


def write(data: dict, path: Path) -> None:
    """Atomic write: a temporary file in the target's folder, then os.replace."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    try:
        with open(tmp, "w") as f:
            json.dump(data, f, indent=1, ensure_ascii=False)
            f.write("\n")
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def shrink(args) -> None:
    """Apply --grids / --periods / --angles / --batch-angles to the benchmark's grids."""
    if args.grids:
        bench.GRIDS = {g: bench.GRIDS[g] for g in args.grids}
    if args.periods:
        for g in bench.GRIDS.values():
            g["periods"] = tuple(args.periods)
        bench.BATCH_CHECK["periods"] = tuple(args.periods)
    if args.angles:
        bench.ANGLES = [int(a) for a in np.linspace(0, 89, args.angles).round()]
    if args.batch_angles:
        bench.BATCH_CHECK["angles"] = tuple(args.batch_angles)


def main(argv=None) -> int:
    ap = bench.parser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"the table (default {DEFAULT_OUT.relative_to(ROOT)})")
    ap.add_argument("--report", action="store_true",
                    help="also write the benchmark's figure and section of benchmarks/results/bragg_color.md")
    ap.add_argument("--grids", nargs="+", choices=tuple(bench.GRIDS), default=None,
                    help="measure these grids only (fig4 is needed for the batch-size check)")
    ap.add_argument("--periods", nargs="+", type=float, default=None, help="Λ in nm (default 244 500 988)")
    ap.add_argument("--angles", type=int, default=None, help="angles per Λ, 0–89° (default 90)")
    ap.add_argument("--batch-angles", nargs="+", type=int, default=None,
                    help="angles per call of the batch-size check (default 90 270 900)")
    args = ap.parse_args(argv)
    raw = list(sys.argv[1:] if argv is None else argv)
    if args.grids and "fig4" not in args.grids:
        ap.error("--grids must include fig4 (the batch-size check runs on it)")
    if args.angles is not None and args.angles < 2:
        ap.error("--angles must be >= 2")
    if args.periods and min(args.periods) <= 0:
        ap.error("--periods must be > 0 nm")
    shrunk = bool(args.grids or args.periods or args.angles or args.batch_angles)
    if args.report and shrunk:
        ap.error("--report writes the benchmark's report: measure the whole grids")
    bench.setup(ap, args, raw, __file__, min_rounds=1 if shrunk else 5)
    args.command = " ".join(["python", BUILDER, *(a for a in raw if a != "--report")])
    shrink(args)
    cfgs, keys, results, refinfo, entries, elapsed = bench.run(args)
    write(table(cfgs, keys, entries, refinfo, args, elapsed), args.out)
    print(f"wrote {args.out} ({len(entries)} configurations, {elapsed:.0f} s)")
    if args.report:
        args.json_written = args.out == DEFAULT_OUT
        bench.report(cfgs, keys, results, refinfo, entries, elapsed, args, write=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
