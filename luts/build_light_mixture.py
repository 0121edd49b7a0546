"""Build the shipped light-mixture table of torchirid.ibl.fitted (K = 5, 48 θo × 48 √α nodes).

    PYTHONPATH=src python luts/build_light_mixture.py [--out PATH]

Writes src/torchirid/data/thin_film_ibl/light_mixture.npz (float32, ~110 KB); ~10 s.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch

from torchirid.ibl.fitted import _SHIPPED, light_mixture_lut

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "src/torchirid/data/thin_film_ibl/light_mixture.npz")
    args = ap.parse_args(argv)
    t = time.perf_counter()
    lut = light_mixture_lut(**_SHIPPED)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    lut.save(args.out)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1024:.0f} KiB, {time.perf_counter() - t:.1f} s): {lut}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
