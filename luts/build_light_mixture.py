"""Build the shipped light-mixture tables of torchirid.ibl.fitted (K = 5, 48 θo × 48 √α nodes).

    PYTHONPATH=src python luts/build_light_mixture.py                                   # both tables
    PYTHONPATH=src python luts/build_light_mixture.py --masking height-correlated [--out PATH]

Writes src/torchirid/data/thin_film_ibl/light_mixture.npz (separable Smith G) and
light_mixture_height_correlated.npz (height-correlated Smith G, Kneiphof's Smith-joint term),
float32, ~140 KB each; ~10 s each.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch  # noqa: F401  (the LUT holds torch tensors)

from torchirid.ibl.fitted import _DATA, _SHIPPED, light_mixture_lut
from torchirid.ibl.uniform import MASKING_MODES

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--masking", choices=MASKING_MODES, action="append",
                    help="build only this table (repeatable; default: all)")
    ap.add_argument("--out", type=Path, default=None, help="output path (only with one --masking)")
    args = ap.parse_args(argv)
    maskings = args.masking or list(MASKING_MODES)
    if args.out is not None and len(maskings) != 1:
        ap.error("--out needs exactly one --masking")
    for masking in maskings:
        out = args.out or ROOT.joinpath("src", "torchirid", *_DATA[masking])
        t = time.perf_counter()
        lut = light_mixture_lut(**_SHIPPED, masking=masking)
        out.parent.mkdir(parents=True, exist_ok=True)
        lut.save(out)
        print(f"wrote {out} ({out.stat().st_size / 1024:.0f} KiB, {time.perf_counter() - t:.1f} s): {lut}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
