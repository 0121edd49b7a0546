"""Build the shipped split-sum DFG table of torchirid.ibl.dfg (64 × 64 nodes, 4096 samples).

    PYTHONPATH=src python luts/build_dfg.py [--out PATH] [--resolution 64 --samples 4096]

Writes src/torchirid/data/dfg/dfg_64.npz (float32). Export it for a shader with
``torchirid.export.export_lut(shipped_dfg_lut(), "dfg", format="exr")``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch

from torchirid.ibl.dfg import DFG_SHIPPED, dfg_lut

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "src/torchirid/data/dfg/dfg_64.npz")
    ap.add_argument("--resolution", type=int, default=DFG_SHIPPED["resolution"],
                    help=f"nodes per axis (default {DFG_SHIPPED['resolution']}, the shipped table)")
    ap.add_argument("--samples", type=int, default=DFG_SHIPPED["samples"],
                    help=f"quadrature samples per node (default {DFG_SHIPPED['samples']})")
    args = ap.parse_args(argv)
    if args.resolution < 2 or args.samples < 1:
        ap.error("--resolution must be >= 2 and --samples >= 1")
    t = time.perf_counter()
    lut = dfg_lut(args.resolution, samples=args.samples).to(torch.float32)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    lut.write(args.out)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1024:.0f} KiB, {time.perf_counter() - t:.1f} s): {lut}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
