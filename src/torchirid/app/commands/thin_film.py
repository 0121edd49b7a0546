"""``torchirid thin-film``: a thin film on a rough surface under uniform light, Kneiphof et al. 2019 Fig. 7 → PNG + ``.npz`` + JSON."""

from __future__ import annotations

import json
from pathlib import Path

from .. import _args

NAME = "thin-film"
#: ``--preview``: (full, preview) value of each size option
SIZES = {"resolution": (32, 8)}

__all__ = ["NAME", "add_parser", "run"]


def add_parser(subparsers):
    """Register ``thin-film`` on an argparse subparsers object (``func=run``); returns its parser."""
    sp = _args.add_command_parser(
        subparsers,
        NAME,
        help="thin film on a rough surface under uniform light: Kneiphof et al. 2019 Fig. 7 comparison → .png + .npz + .json",
        description=(
            "Compare real-time approximations of a thin film on a rough GGX surface under\n"
            "uniform illumination against the converged ground truth (Kneiphof et al. 2019,\n"
            "Fig. 7): Belcour–Barla at the ideal reflection direction (the 'original'),\n"
            "Kneiphof's filtered eq. 20–29 with the exact light moments, eq. 29 with the exact\n"
            "path-difference moments, and torchirid's fitted light-mixture table.\n"
            "Two panels: θo × √α at --thickness, and θo × d ∈ [0, --max-thickness] at --alpha.\n\n"
            "Writes <out>/<name>.png (the image grid with ΔE2000 mean / p95 per method),\n"
            "<out>/<name>_roughness.npz and <out>/<name>_thickness.npz (XYZ of every method,\n"
            "ΔE2000 maps, albedo, axes, params) and <out>/<name>.json (the ΔE2000 table).\n\n"
            "The default run (32 × 32 per panel) takes about 10 s on a quiet 2-core machine and\n"
            "can take a minute beside other work; --preview (8 × 8) takes a few seconds."
        ),
        epilog=(
            "examples:\n"
            "  torchirid thin-film                                   # Fig. 7's material, 32 × 32 per panel\n"
            "  torchirid thin-film --resolution 64 --n-film 1.5 --base 0.2+3j"
        ),
    )
    sp.add_argument("--n-film", type=_args.positive, default=1.3, metavar="N", help="film index η2 (real, >= 1)")
    sp.add_argument("--base", type=_args.index, default=complex(2.0, 0.5), metavar="N",
                    help="base index η3 + iκ3, e.g. 2+0.5j (non-dispersive)")
    sp.add_argument("--thickness", type=_args.positive_length, default=600.0, metavar="NM",
                    help="film thickness of the roughness panel")
    sp.add_argument("--alpha", type=_args.positive, default=0.25, metavar="A", help="GGX roughness of the thickness panel")
    sp.add_argument("--max-thickness", type=_args.positive_length, default=1000.0, metavar="NM", help="end of the thickness axis")
    sp.add_argument("--resolution", type=_args.count, default=None, metavar="CELLS",
                    help="cells per axis of each panel (default: 32; 8 with --preview)")
    sp.add_argument("--out", default="out", metavar="DIR", help="output directory (created if missing)")
    sp.add_argument("--name", default="thin_film", metavar="STEM", help="file stem")
    sp.add_argument("--dpi", type=_args.count, default=150, metavar="DPI", help="resolution of the PNG")
    _args.add_preview_option(sp, SIZES, full="about 10 s on a quiet 2-core machine, up to a minute beside other "
                                               "work", quick="a few seconds")
    _args.add_output_options(sp)
    sp.set_defaults(func=run, parser=sp)
    return sp


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Both Fig. 7 panels → PNG, two .npz and a JSON ΔE2000 table. Exit status: 0, 1 (write), 2 (bad argument)."""
    from ..._io import atomic_write, json_ready
    from ..figures import thin_film_ibl

    _args.resolve_preview(args)
    _args.check_name(args.name)
    if args.resolution < 2:
        raise ValueError("--resolution must be >= 2")
    if args.n_film < 1.0:
        raise ValueError("--n-film must be >= 1 (the outer medium is air)")
    panels = []
    bar = _args.progress_bar(f"torchirid {NAME}", total=len(thin_film_ibl.THIN_FILM_IBL_PANELS), unit="panel",
                             quiet=args.quiet)
    try:
        for panel in thin_film_ibl.THIN_FILM_IBL_PANELS:
            panels.append(thin_film_ibl.thin_film_ibl_comparison(
                panel, resolution=args.resolution, n_film=args.n_film, thickness=args.thickness, alpha=args.alpha,
                n_substrate=args.base, max_thickness=args.max_thickness))
            bar.update()
    finally:
        bar.close()
    out = Path(args.out)
    report = {p.panel: {"stats": p.stats(), "seconds": p.seconds, "params": p.params} for p in panels}
    figures = _args.figure_paths(out, args.name, args.format)
    paths = [out / f"{args.name}_roughness.npz", out / f"{args.name}_thickness.npz", out / f"{args.name}.json"]
    try:
        out.mkdir(parents=True, exist_ok=True)
        for path in figures:
            thin_film_ibl.save_thin_film_ibl_png(panels, path, dpi=args.dpi)
        thin_film_ibl.save_thin_film_ibl_npz(panels[0], paths[0])
        thin_film_ibl.save_thin_film_ibl_npz(panels[1], paths[1])
        text = json.dumps(json_ready(report), indent=2, sort_keys=True, allow_nan=False) + "\n"  # strict: NaN → null
        atomic_write(paths[2], lambda f: f.write(text.encode()))
    except OSError as e:
        return _args.cannot_write(NAME, out, e)
    for p in panels:
        for k, st in p.stats().items():
            print(f"{p.panel:9s} {k:10s} ΔE2000 mean {st['mean']:6.2f}  p95 {st['p95']:6.2f}  max {st['max']:6.2f}")
    for path in [*figures, *paths]:
        print(path)
    return 0
