"""Save a gallery example's picture for the README (the README's picture comes from the gallery).

    .venv/bin/python docs/readme_figure.py docs/examples/plot_angular_gradients.py
    → docs/figures/gallery_angular_gradients.png

Runs the script as sphinx-gallery does (full size, Agg backend) and writes the figure of its
``plt.show()`` instead of showing it.
"""

from __future__ import annotations

import argparse
import os
import runpy
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("script", type=Path, help="a docs/examples/plot_*.py script")
    parser.add_argument("--dpi", type=int, default=110)
    args = parser.parse_args(argv)
    if not args.script.is_file() or not args.script.name.startswith("plot_"):
        parser.error(f"script: not a gallery script (docs/examples/plot_*.py): {args.script}")
    os.environ["MPLBACKEND"] = "Agg"
    os.environ.pop("TORCHIRID_GALLERY_TINY", None)
    import matplotlib.pyplot as plt

    out = DOCS / "figures" / f"gallery_{args.script.stem.removeprefix('plot_')}.png"

    def save(*_, **__):
        plt.gcf().savefig(out, dpi=args.dpi, bbox_inches="tight")
        print(f"wrote {out.relative_to(DOCS.parent)}")

    plt.show = save
    sys.argv = [str(args.script)]
    runpy.run_path(str(args.script), run_name="__main__")
    return 0


if __name__ == "__main__":
    sys.exit(main())
