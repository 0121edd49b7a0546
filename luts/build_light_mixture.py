"""Build the shipped light-mixture tables of torchirid.ibl.fitted (K = 5, 48 θo × 48 √α nodes).

    PYTHONPATH=src python luts/build_light_mixture.py                                   # both tables
    PYTHONPATH=src python luts/build_light_mixture.py --masking height_correlated [--out PATH]
    PYTHONPATH=src python luts/build_light_mixture.py --masking separable --theta-nodes 4 --alpha-nodes 4 --out t.npz

Writes src/torchirid/data/thin_film_ibl/light_mixture.npz (separable Smith G) and
light_mixture_height_correlated.npz (height-correlated Smith G, Kneiphof's Smith-joint term),
float32, ~140 KB each; ~10 s each. A table of another size needs ``--out`` (the shipped files
are loaded with the shipped parameters).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from torchirid.ibl.fitted import _DATA, _SHIPPED, light_mixture_lut
from torchirid.ibl.uniform import MASKING_MODES

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--masking", choices=MASKING_MODES, action="append",
                    help="build only this table (repeatable; default: all)")
    ap.add_argument("--out", type=Path, default=None, help="output path (only with one --masking)")
    for name in ("theta_nodes", "alpha_nodes", "nodes", "bins"):
        ap.add_argument("--" + name.replace("_", "-"), type=int, default=_SHIPPED[name],
                        help=f"default {_SHIPPED[name]} (the shipped tables)")
    args = ap.parse_args(argv)
    maskings = args.masking or list(MASKING_MODES)
    if args.out is not None and len(maskings) != 1:
        ap.error("--out needs exactly one --masking")
    params = dict(_SHIPPED, theta_nodes=args.theta_nodes, alpha_nodes=args.alpha_nodes, nodes=args.nodes,
                  bins=args.bins)
    if params != _SHIPPED and args.out is None:
        ap.error("a table of another size needs --out (the shipped files keep the shipped parameters)")
    for masking in maskings:
        out = args.out or ROOT.joinpath("src", "torchirid", *_DATA[masking])
        t = time.perf_counter()
        lut = light_mixture_lut(**params, masking=masking)  # (validates the sizes: ValueError naming them)
        out.parent.mkdir(parents=True, exist_ok=True)
        lut.write(out)
        print(f"wrote {out} ({out.stat().st_size / 1024:.0f} KiB, {time.perf_counter() - t:.1f} s): {lut}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
