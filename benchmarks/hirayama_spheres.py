"""Hirayama et al. 2000, Fig. 8 and Table 1 (Fig. 9) as spectral sphere renders → docs/figures.

Writes ``docs/figures/hirayama_spheres.png`` (Fig. 8 style: rows = the three coated stacks,
columns = σ₀ ∈ {0, 25, 50} nm, τ = 300 nm; each panel = coated | uncoated sphere) and
``docs/figures/hirayama_table1.png`` (Table 1's teapot/cylinder/sphere stacks as spheres,
σ₀ ∈ {0, 50} nm), and prints the chroma tables (CIELAB C*ab over the lit sphere pixels,
coated vs uncoated × σ₀) as markdown, with the time taken.

    PYTHONPATH=src python benchmarks/hirayama_spheres.py [--size 128] [--out docs/figures]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch

from torchirid.app.figures import spheres as sp


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=128, help="sphere image side in pixels")
    ap.add_argument("--wavelength-step", type=float, default=5.0, help="nm, over 380-780 nm")
    ap.add_argument("--lamp", default="FL10")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent.parent / "docs" / "figures"))
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    common = dict(size=args.size, wavelength_step=args.wavelength_step, lamp=args.lamp)

    t0 = time.perf_counter()
    fig8 = sp.render_panels(sp.FIG8_ROWS, (0.0, 25.0, 50.0), 300.0, **common)
    t1 = time.perf_counter()
    sp.save_panels_png(fig8, out / "hirayama_spheres.png",
                       title=f"Hirayama 2000 Fig. 8: coated | uncoated, τ = 300 nm, lamp {args.lamp}")
    print(f"## Fig. 8 spheres ({args.size} px, {args.wavelength_step:g} nm, lamp {args.lamp}; {t1 - t0:.1f} s for 18 spheres)\n")
    print(sp.chroma_table_markdown(fig8))

    t0 = time.perf_counter()
    tab1 = sp.render_panels(sp.TABLE1_OBJECTS, (0.0, 50.0), 300.0, **common)
    t1 = time.perf_counter()
    sp.save_panels_png(tab1, out / "hirayama_table1.png",
                       title=f"Hirayama 2000 Table 1 stacks as spheres: coated | uncoated, τ = 300 nm, lamp {args.lamp}")
    print(f"\n## Table 1 objects as spheres ({t1 - t0:.1f} s for 12 spheres)\n")
    print(sp.chroma_table_markdown(tab1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
