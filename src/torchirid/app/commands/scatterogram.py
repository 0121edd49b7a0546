"""``torchirid scatterogram``: imaging-scatterometer views of rough Bragg layers (Fourneau et al. 2024, Fig. 9) → PNG + ``.npz``."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from .. import _args

NAME = "scatterogram"

__all__ = ["NAME", "add_parser", "run"]

#: the beam row drawn when no --beam is given: normal incidence, as match_scatterogram's default incident_deg
DEFAULT_BEAM = (0.0, 0.0)


def _exposure(text: str):
    if text == "auto":
        return text
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected 'auto' or a number > 0, got {text!r}")
    return value


def add_parser(subparsers):
    """Register ``scatterogram`` on an argparse subparsers object (``func=run``); returns its parser."""
    from ...layered.scatterograms import PROJECTIONS
    from ...presets import JEWEL_BEETLE_NAMES

    sp = _args.add_command_parser(
        subparsers,
        NAME,
        help="scatterograms of rough Bragg layers, e.g. the jewel beetle (Fourneau et al. 2024, Fig. 9) → .png + .npz",
        description=(
            "Render scatterograms — the hemisphere of reflected directions as an imaging\n"
            "scatterometer sees it, the normal at the centre and the horizon on the rim — of\n"
            "layered Bragg structures with the single-reflection BRDF (Fourneau et al. 2024,\n"
            "eq. 34), spectrally (D65, CIE 1931 2°) → sRGB, with the 5°, 30°, 60° and 90°\n"
            "circles in red as in Fig. 9. One column per structure, one row per illumination:\n"
            "  white          a uniform white (D65) environment, as in Fig. 9: each pixel is\n"
            "                 the directional albedo ∫ f_r cos θi dωi\n"
            "  beam θ φ       a narrow beam from polar angle θ, azimuth φ (degrees): each\n"
            "                 pixel is f_r cos θi; the specular spot sits at φ + 180°\n\n"
            "Structures: the jewel-beetle presets of Table 3 (green/blue, red, purple: one\n"
            "rough Bragg layer, α = 0.05, in air over an absorbing base; δ read as the fraction\n"
            "of Λ in the n2 layer), or 'custom' built from the --n1 ... --base-albedo options.\n\n"
            "Writes <out>/<name>.png and <out>/<name>.npz: xyz (rows, cols, H, W, 3), mask\n"
            "(H, W), wavelength_nm, titles and params (a JSON string)."
        ),
        epilog=(
            "examples:\n"
            "  torchirid scatterogram                                 # the three presets, white + beam at 0°\n"
            "  torchirid scatterogram --beam 0 0 --beam 45 0 --resolution 128\n"
            "  torchirid scatterogram --preset custom --n1 1.0 --n2 1.5 --d1 250 --d2 250 --cells 10 --alpha 0.1"
        ),
    )
    g = sp.add_argument_group("structures")
    g.add_argument("--preset", nargs="+", choices=(*JEWEL_BEETLE_NAMES, "custom"),
                   default=list(JEWEL_BEETLE_NAMES),
                   metavar="NAME", help=f"one column each: {', '.join(JEWEL_BEETLE_NAMES)} or custom")
    g.add_argument("--n1", type=_args.positive, default=1.59, metavar="N", help="custom: index n1 (low)")
    g.add_argument("--n2", type=_args.positive, default=1.67, metavar="N", help="custom: index n2 (high)")
    g.add_argument("--d1", type=_args.positive_length, default=78.4, metavar="NM", help="custom: thickness d1 in nm")
    g.add_argument("--d2", type=_args.positive_length, default=81.6, metavar="NM", help="custom: thickness d2 in nm")
    g.add_argument("--cells", type=_args.count, default=8, metavar="COUNT", help="custom: number N of cells")
    g.add_argument("--alpha", type=_args.positive, default=0.05, metavar="A", help="custom: GGX roughness α")
    g.add_argument("--n-incident", type=_args.positive, default=1.0, metavar="N",
                   help="custom: index of the medium around the mirrors (1: air, no coating; else a smooth coating)")
    g.add_argument("--base-albedo", type=_args.number, default=0.0, metavar="RHO",
                   help="custom: Lambertian base albedo in [0, 1]")
    g = sp.add_argument_group("illumination")
    g.add_argument("--no-white", dest="white", action="store_false", help="leave out the white-environment row (drawn first unless this is given)")
    g.add_argument("--beam", nargs=2, type=_args.number, action="append", metavar=("THETA", "PHI"),
                   help=f"add a narrow-beam row lit from (θ, φ) in degrees; repeatable (default: one beam at "
                        f"{DEFAULT_BEAM[0]:g} {DEFAULT_BEAM[1]:g})")
    g = sp.add_argument_group("image and output")
    g.add_argument("--resolution", type=_args.count, default=160, metavar="PIXELS", help="pixels per side of each image")
    g.add_argument("--wavelengths", nargs=3, metavar=("MIN", "MAX", "COUNT"), default=["380", "780", "81"],
                   help="wavelength grid in nm: COUNT evenly spaced values from MIN to MAX inclusive")
    g.add_argument("--projection", choices=PROJECTIONS, default="equidistant",
                   help="angular mapping: radius ∝ θ (equidistant), sin θ (orthographic) or sin(θ/2) (equal_area)")
    g.add_argument("--exposure", type=_exposure, default="auto", metavar="X",
                   help="display gain on XYZ, or 'auto' (each image's brightest pixel to Y = 1)")
    g.add_argument("--lut", action="store_true", help="tabulate the mirrors' reflectance over the angle (faster)")
    g.add_argument("--out", default="out", metavar="DIR", help="output directory (created if missing)")
    g.add_argument("--name", default="scatterogram", metavar="STEM", help="file stem: writes STEM.png and STEM.npz")
    g.add_argument("--dpi", type=_args.count, default=150, metavar="DPI", help="resolution of the PNG")
    _args.add_output_options(g)
    sp.set_defaults(func=run, parser=sp)
    return sp


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Render, draw and write the scatterograms; prints the two paths. Exit status: 0, 1 (write), 2 (bad argument)."""
    import torch

    from ...layered import LayeredBragg, RoughBraggLayer, scatterogram
    from ...presets import JEWEL_BEETLE, jewel_beetle
    from ..figures import scatterograms

    _args.check_name(args.name)
    wl_min, wl_max, wl_count = _args.parse_wavelengths(args.wavelengths)
    if wl_count < 2 or wl_max <= wl_min:
        raise ValueError("--wavelengths: a spectrum needs MIN < MAX and COUNT >= 2")
    beams = args.beam if args.beam is not None else [list(DEFAULT_BEAM)]
    if not args.white and not beams:
        raise ValueError("nothing to render: --no-white needs at least one --beam")
    for theta, _ in beams:
        if not 0.0 <= theta <= 90.0:
            raise ValueError(f"--beam THETA must lie in [0, 90] degrees; got {theta:g}")

    structures = []
    for name in args.preset:
        if name == "custom":
            layer = RoughBraggLayer(args.n1, args.n2, args.d1, args.d2, args.cells, args.alpha,
                                    n_incident=args.n_incident)
            structures.append((f"custom Λ={args.d1 + args.d2:g} nm", LayeredBragg([layer], args.base_albedo)))
        else:
            row = JEWEL_BEETLE[name]
            structures.append((f"{row['label']}: Λ={row['period']:g} nm, N={row['cells']}", jewel_beetle(name)))
    lam = torch.linspace(wl_min, wl_max, wl_count, dtype=torch.float64)
    rows, labels = [], []
    kw = dict(resolution=args.resolution, wavelength=lam, projection=args.projection, reflectance="lut" if args.lut else "exact")
    lights = ([None] if args.white else []) + [(theta, phi) for theta, phi in beams]
    bar = _args.progress_bar(f"torchirid {NAME}", total=len(lights) * len(structures), unit="image", quiet=args.quiet)
    try:
        for light in lights:
            row = []
            for t, s in structures:
                row.append(scatterogram(s, title=t, **kw) if light is None
                           else scatterogram(s, incident_deg=light, title=t, **kw))
                bar.update()
            rows.append(row)
            labels.append("white environment" if light is None else f"beam θi={light[0]:g}°, φi={light[1]:g}°")
    finally:
        bar.close()

    out = Path(args.out)
    figures = _args.figure_paths(out, args.name, args.format)
    npz_path = out / f"{args.name}.npz"
    try:
        out.mkdir(parents=True, exist_ok=True)
        for path in figures:
            scatterograms.save_scatterograms_png(rows, path, dpi=args.dpi, exposure=args.exposure, row_labels=labels)
        scatterograms.save_scatterograms_npz(rows, npz_path)
    except OSError as e:
        return _args.cannot_write(NAME, out, e)
    for path in [*figures, npz_path]:
        print(path)
    return 0
