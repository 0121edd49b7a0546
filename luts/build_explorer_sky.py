"""Build the prefiltered sky of the explorer page (``torchirid explore``), shipped so that writing
the page costs no prefiltering (~2 s of CPU).

    PYTHONPATH=src python luts/build_explorer_sky.py [--out PATH]

Writes src/torchirid/data/explorer/sky.npz (float32, ~150 KiB): the synthetic sky of
``torchirid.ibl.synthetic_environment(64, 128)`` prefiltered by ``torchirid.ibl.prefilter_environment``
to 32 × 64 texels at the six roughness levels of the page's α slider
(``torchirid.app.explorer.SKY_ALPHAS``). tests/realtime/test_explorer_page.py checks that it is current.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from torchirid.app.explorer import sky_lut

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "src/torchirid/data/explorer/sky.npz")
    args = ap.parse_args(argv)
    t = time.perf_counter()
    lut = sky_lut()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    lut.write(args.out)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1024:.0f} KiB, {time.perf_counter() - t:.1f} s): {lut}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
