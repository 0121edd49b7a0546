"""The ``torchirid`` command.

``torchirid spectrum`` computes the reflectance R(θ, λ) of a Bragg mirror or a thin film on
a grid of incidence angles × wavelengths and writes ``<out>/<name>.npz`` (the arrays and a
JSON ``params`` string) and ``<out>/<name>.png`` (a reflectance map).

``torchirid gradients`` draws the atlas of angular colour gradients of Fourneau et al. 2024,
Fig. 4 (rows: period Λ; columns: d1/Λ, plus a first thin-film column) and writes
``<out>/<name>.png`` and ``<out>/<name>.npz`` (the sRGB strips and a JSON ``params`` string).

On the command line, wavelengths and thicknesses are in nm and incidence angles in degrees
(the library itself takes cos θ).

This module only parses and checks the arguments (a bad one is a usage error: a message and
exit status 2) and calls :mod:`torchirid.render`, which computes, draws and writes the
products. That import (torch, numpy, matplotlib) happens inside the command so that
``--help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import sys
from pathlib import Path

PROG = "torchirid"
POLARIZATIONS = ("s", "p", "unpolarized")
KINDS = ("bragg", "thin-film")
DTYPES = ("float64", "float32")


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Show defaults and keep the hand-made line breaks of descriptions and epilogs."""

    def _get_help_string(self, action):
        if action.default is None or action.default is argparse.SUPPRESS or not action.option_strings:
            return action.help
        if isinstance(action.default, (list, tuple)):
            return f"{action.help} (default: {' '.join(map(str, action.default))})"
        return super()._get_help_string(action)


def _index(text: str):
    """A refractive index n or n + iκ from the command line: ``1.5``, ``1.5+0.02j``."""
    try:
        return float(text)
    except ValueError:
        pass
    try:
        z = complex(text.replace(" ", "").replace("i", "j"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a refractive index such as 1.5 or 1.5+0.02j (n + iκ), got {text!r}"
        ) from None
    return z.real if z.imag == 0 else z


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {value}")
    return value


def _float(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None



def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG,
        formatter_class=_HelpFormatter,
        description=(
            "torchirid: exact, differentiable reflectance of iridescent materials\n"
            "(thin films, multilayers, Bragg mirrors) in PyTorch.\n\n"
            "Units on the command line: wavelengths and thicknesses in nm, incidence\n"
            "angles in degrees (the Python API takes cos θ)."
        ),
        epilog=(
            "examples:\n"
            "  torchirid spectrum                       # Fourneau et al. 2024, Fig. 1 Bragg mirror\n"
            "  torchirid spectrum --kind thin-film --n-film 1.33 --thickness 400\n"
            "  torchirid gradients                      # Fourneau et al. 2024, Fig. 4 atlas\n"
            "  torchirid scatterogram                   # jewel-beetle scatterograms, Fig. 9\n"
            "  torchirid thin-film                      # Kneiphof et al. 2019 Fig. 7: thin films under IBL\n"
            "  torchirid render-sphere                  # Hirayama 2000 Fig. 8: coated rough spheres\n"
            "  torchirid film-table --stack teapot --check  # Hirayama 2000 §5: k_r/k_t table → LUT .npz\n"
            "  torchirid fit-film CUBE.npz --out fit/   # Kobayashi: film n and thickness map from a hyperspectral cube\n"
            "  torchirid spectrum --help                # all options"
        ),
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    sp = sub.add_parser(
        "spectrum",
        formatter_class=_HelpFormatter,
        help="reflectance map R(incidence angle, wavelength) of a Bragg mirror or thin film → .npz + .png",
        description=(
            "Compute the specular reflectance R of a Bragg mirror (N cells of two layers,\n"
            "Fourneau et al. 2024) or of a single thin film (Airy sum) on a grid of\n"
            "incidence angles θ from 0° to 90° (inclusive) × wavelengths, and write\n"
            "<out>/<name>.npz and <out>/<name>.png.\n\n"
            "The .npz holds wavelength_nm (W,), theta_deg (A,), cos_theta (A,),\n"
            "reflectance (A, W) and params (a JSON string of every parameter and the\n"
            "torchirid version). Refractive indices may be complex, n + iκ with κ >= 0\n"
            "meaning absorption, written like 1.5+0.02j.\n\n"
            "The defaults are the Bragg mirror of Fourneau et al. 2024, Fig. 1 (left):\n"
            "n1 = 1, n2 = 1.5, d1 = 125 nm, d2 = 375 nm, N = 20, in air."
        ),
    )
    sp.add_argument("--kind", choices=KINDS, default="bragg", help="structure to compute")

    g = sp.add_argument_group(
        "Bragg mirror (--kind bragg)", "the stack n_incident | (n2, d2), (n1, d1) × cells | n1, lit from n_incident"
    )
    g.add_argument(
        "--n1", type=_index, default=1.0, metavar="N", help="index of layer 1 (also the medium below the mirror)"
    )
    g.add_argument("--n2", type=_index, default=1.5, metavar="N", help="refractive index of layer 2")
    g.add_argument("--d1", type=_float, default=125.0, metavar="NM", help="thickness of layer 1 in nm")
    g.add_argument("--d2", type=_float, default=375.0, metavar="NM", help="thickness of layer 2 in nm")
    g.add_argument("--cells", type=int, default=20, metavar="COUNT", help="number N of cells (layer pairs)")

    g = sp.add_argument_group(
        "thin film (--kind thin-film)", "the stack n_incident | (n_film, thickness) | n_substrate, lit from n_incident"
    )
    g.add_argument("--n-film", type=_index, default=1.5, metavar="N", help="refractive index of the film")
    g.add_argument("--thickness", type=_float, default=375.0, metavar="NM", help="film thickness in nm")
    g.add_argument(
        "--n-substrate", type=_index, default=1.0, metavar="N", help="refractive index of the medium below the film"
    )
    g = sp.add_argument_group("both kinds")
    g.add_argument(
        "--n-incident", type=_index, default=None, metavar="N",
        help="real index of the incident medium above the structure; default: n1 (bragg), 1.0 (thin-film)",
    )

    g = sp.add_argument_group("grid and output")
    g.add_argument(
        "--polarization",
        choices=POLARIZATIONS,
        default="unpolarized",
        help="'unpolarized' is the mean of the s and p reflectances",
    )
    g.add_argument(
        "--wavelengths",
        nargs=3,
        metavar=("MIN", "MAX", "COUNT"),
        default=["380", "780", "401"],
        help="wavelength grid in nm: COUNT evenly spaced values from MIN to MAX inclusive",
    )
    g.add_argument(
        "--angles",
        type=_count,
        default=90,
        metavar="COUNT",
        help="number of incidence angles θ (degrees, in the incident medium), evenly spaced from 0 to 90 inclusive",
    )
    g.add_argument("--dtype", choices=DTYPES, default="float64", help="precision of the computation")
    g.add_argument("--out", default="out", metavar="DIR", help="output directory (created if missing)")
    g.add_argument("--name", default="spectrum", metavar="STEM", help="file stem: writes STEM.npz and STEM.png")
    sp.set_defaults(func=_cmd_spectrum, parser=sp)
    _add_gradients_parser(sub)
    _add_scatterogram_parser(sub)
    # by module path: the packages re-export functions of the same names as these modules
    importlib.import_module("torchirid.optics.film_tables").add_parser(sub)
    importlib.import_module("torchirid.render.sphere").add_parser(sub)
    importlib.import_module("torchirid.render.thin_film_ibl").add_parser(sub)
    importlib.import_module("torchirid.estimation.cli").add_parser(sub)
    return parser


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("torchirid")
    except Exception:  # not installed (e.g. run from a source tree via PYTHONPATH)
        return "unknown"


def _parse_wavelengths(parser: argparse.ArgumentParser, raw) -> tuple[float, float, int]:
    lo, hi, count = raw
    try:
        lo, hi = float(lo), float(hi)
    except ValueError:
        parser.error(f"--wavelengths: MIN and MAX must be numbers (nm); got {raw[0]!r} {raw[1]!r}")
    try:
        count = _count(count)
    except argparse.ArgumentTypeError as e:
        parser.error(f"--wavelengths COUNT: {e}")
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo <= 0 or hi < lo:
        parser.error(f"--wavelengths: need 0 < MIN <= MAX (nm); got MIN={lo:g} MAX={hi:g}")
    if count > 1 and hi == lo:
        parser.error("--wavelengths: MIN == MAX needs COUNT 1")
    return lo, hi, count


def _check_name(parser: argparse.ArgumentParser, name: str) -> None:
    if not name or os.sep in name or (os.altsep and os.altsep in name):
        parser.error(f"--name must be a plain file stem, got {name!r}")


def _cmd_spectrum(args: argparse.Namespace) -> int:
    parser: argparse.ArgumentParser = args.parser
    wl_min, wl_max, wl_count = _parse_wavelengths(parser, args.wavelengths)
    _check_name(parser, args.name)

    from torchirid import render

    grid = dict(
        wavelengths=(wl_min, wl_max, wl_count), angles=args.angles, polarization=args.polarization, dtype=args.dtype
    )
    try:
        if args.kind == "bragg":
            rmap = render.bragg_reflectance_map(
                args.n1, args.n2, args.d1, args.d2, args.cells, n_incident=args.n_incident, **grid
            )
        else:
            rmap = render.thin_film_reflectance_map(
                args.n_film, args.thickness, args.n_substrate,
                n_incident=1.0 if args.n_incident is None else args.n_incident, **grid
            )
    except ValueError as e:  # the library names the bad parameter; report it like a usage error
        parser.error(str(e))

    out = Path(args.out)
    npz_path = out / f"{args.name}.npz"
    png_path = out / f"{args.name}.png"
    try:
        out.mkdir(parents=True, exist_ok=True)
        render.save_reflectance_map_npz(rmap, npz_path)
        render.save_reflectance_map_png(rmap, png_path, dpi=120)
    except OSError as e:
        print(f"{PROG}: error: cannot write to {out}: {e}", file=sys.stderr)
        return 1

    print(npz_path)
    print(png_path)
    return 0


# ----------------------------------------------------------------------------------------
# torchirid gradients: the atlas of angular colour gradients (Fourneau et al. 2024, Fig. 4)
# ----------------------------------------------------------------------------------------


def _positive(text: str) -> float:
    value = _float(text)
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return value


def _ratio(text: str) -> float:
    value = _float(text)
    if not (0.0 < value < 1.0):
        raise argparse.ArgumentTypeError(f"expected a ratio d1/Λ strictly between 0 and 1, got {text!r}")
    return value


def _strip_count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 2, got {text!r}") from None
    if value < 2:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 2 (a gradient needs two angles), got {value}")
    return value


def _add_gradients_parser(sub) -> None:
    gp = sub.add_parser(
        "gradients",
        formatter_class=_HelpFormatter,
        help="atlas of angular colour gradients of Bragg mirrors (Fourneau et al. 2024, Fig. 4) → .png + .npz",
        description=(
            "Draw the atlas of Fourneau et al. 2024, Fig. 4: Bragg mirrors of N cells of\n"
            "indices n1 and n2, one row per period Λ = d1 + d2 and one column per d1/Λ, plus a\n"
            "first column with a thin film (a slab of index n2 and thickness Λ in n1; air by\n"
            "default). Each cell shows the reflectance against the incidence angle θ (0–90°)\n"
            "at the CMF peaks λ = 599, 556, 442 nm (red, green, blue; the paper's caption\n"
            "prints 559, a typo for 599), above colour strips of the mirror's colour against θ:\n"
            "  ref.             the exact spectrum integrated against the CMFs (method='spectral')\n"
            "  piecewise (s=8)  the library's piecewise approximation (fringe-averaged weights)\n"
            "  paper sub. s=3   the paper's subdivided piecewise approximation (its weights)\n"
            "The thin-film column has the reference strip only. Colours are sRGB under D65\n"
            "(CIE 1931 2°), clipped to [0, 1].\n\n"
            "Writes <out>/<name>.png and <out>/<name>.npz: theta_deg (A,), lambdas_nm (L,),\n"
            "ratios (R,), d1_nm and d2_nm (L, R), srgb_reference, srgb_piecewise and\n"
            "srgb_paper_sub (L, R, A, 3), srgb_thin_film (L, A, 3), the matching unclipped\n"
            "xyz_* arrays, the curves (curve_theta_deg, curve_wavelength_nm,\n"
            "reflectance_bragg (L, R, 721, 3), reflectance_thin_film (L, 721, 3)) and params\n"
            "(a JSON string of every parameter and the torchirid version)."
        ),
    )
    g = gp.add_argument_group("structures")
    g.add_argument("--n1", type=_positive, default=1.0, metavar="N",
                   help="real index of layer 1, also the medium around the mirror and the film")
    g.add_argument("--n2", type=_positive, default=1.5, metavar="N",
                   help="real index of layer 2 and of the thin film")
    g.add_argument("--cells", type=_count, default=20, metavar="COUNT", help="number N of cells of the mirrors")
    g.add_argument("--lambdas", type=_positive, nargs="+", default=[244.0, 500.0, 988.0], metavar="NM",
                   help="periods Λ = d1 + d2 in nm, one row each (the thin film's thickness too)")
    g.add_argument("--ratios", type=_ratio, nargs="+", default=[0.1, 0.3, 0.5, 0.7, 0.9], metavar="R",
                   help="ratios d1/Λ in (0, 1), one column each")
    g.add_argument("--polarization", choices=POLARIZATIONS, default="unpolarized",
                   help="'unpolarized' is the mean of the s and p reflectances")
    g = gp.add_argument_group("grid and output")
    g.add_argument("--angles", type=_strip_count, default=90, metavar="COUNT",
                   help="number of incidence angles θ of each colour strip, evenly spaced from 0 to 90° inclusive")
    g.add_argument("--out", default="out", metavar="DIR", help="output directory (created if missing)")
    g.add_argument("--name", default="gradients", metavar="STEM", help="file stem: writes STEM.png and STEM.npz")
    g.add_argument("--dpi", type=_count, default=150, metavar="DPI", help="resolution of the PNG")
    gp.set_defaults(func=_cmd_gradients, parser=gp)


def _cmd_gradients(args: argparse.Namespace) -> int:
    parser: argparse.ArgumentParser = args.parser
    _check_name(parser, args.name)
    if args.n1 > args.n2:
        # the piecewise strips model light propagating in layer 2 at every angle up to 90°
        parser.error(f"--n1 ({args.n1:g}) must not exceed --n2 ({args.n2:g}): the piecewise approximations "
                     "need light propagating in layer 2 (no total internal reflection) up to 90°")

    from tqdm.auto import tqdm

    from torchirid import render

    steps = [*render.GRADIENT_ATLAS_STEPS, "figure"]
    # one bragg_xyz call per method for the whole grid; the bar appears only past 2 s
    bar = tqdm(total=len(steps), desc="torchirid gradients", unit="step", delay=2.0, file=sys.stderr, leave=False)
    try:
        atlas = render.gradient_atlas(
            args.lambdas,
            args.ratios,
            n1=args.n1,
            n2=args.n2,
            cells=args.cells,
            polarization=args.polarization,
            angles=args.angles,
            progress=bar,
        )
    except ValueError as e:  # the library names the bad parameter; report it like a usage error
        bar.close()
        parser.error(str(e))

    out = Path(args.out)
    npz_path = out / f"{args.name}.npz"
    png_path = out / f"{args.name}.png"
    try:
        out.mkdir(parents=True, exist_ok=True)
        bar.set_postfix_str("figure", refresh=False)
        render.save_gradient_atlas_png(atlas, png_path, dpi=args.dpi)
        bar.update()
        render.save_gradient_atlas_npz(atlas, npz_path)
    except OSError as e:
        print(f"{PROG}: error: cannot write to {out}: {e}", file=sys.stderr)
        return 1
    finally:
        bar.close()

    print(png_path)
    print(npz_path)
    return 0


# ----------------------------------------------------------------------------------------
# torchirid scatterogram: imaging-scatterometer views of layered Bragg structures (Fig. 9)
# ----------------------------------------------------------------------------------------
SCATTEROGRAM_PRESETS = ("green", "red", "purple")  # torchirid.layered.presets.JEWEL_BEETLE_NAMES
SCATTEROGRAM_PROJECTIONS = ("equidistant", "orthographic", "equal-area")  # render.scatterogram.PROJECTIONS


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


def _add_scatterogram_parser(sub) -> None:
    sp = sub.add_parser(
        "scatterogram",
        formatter_class=_HelpFormatter,
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
    g.add_argument("--preset", nargs="+", choices=(*SCATTEROGRAM_PRESETS, "custom"), default=list(SCATTEROGRAM_PRESETS),
                   metavar="NAME", help=f"one column each: {', '.join(SCATTEROGRAM_PRESETS)} or custom")
    g.add_argument("--n1", type=_positive, default=1.59, metavar="N", help="custom: index n1 (low)")
    g.add_argument("--n2", type=_positive, default=1.67, metavar="N", help="custom: index n2 (high)")
    g.add_argument("--d1", type=_positive, default=78.4, metavar="NM", help="custom: thickness d1 in nm")
    g.add_argument("--d2", type=_positive, default=81.6, metavar="NM", help="custom: thickness d2 in nm")
    g.add_argument("--cells", type=_count, default=8, metavar="COUNT", help="custom: number N of cells")
    g.add_argument("--alpha", type=_positive, default=0.05, metavar="A", help="custom: GGX roughness α")
    g.add_argument("--n-incident", type=_positive, default=1.0, metavar="N",
                   help="custom: index of the medium around the mirrors (1: air, no coating; else a smooth coating)")
    g.add_argument("--base-albedo", type=_float, default=0.0, metavar="RHO", help="custom: Lambertian base albedo in [0, 1]")
    g = sp.add_argument_group("illumination")
    g.add_argument("--no-white", dest="white", action="store_false", help="leave out the white-environment row")
    g.add_argument("--beam", nargs=2, type=_float, action="append", metavar=("THETA", "PHI"),
                   help="add a narrow-beam row lit from (θ, φ) in degrees; repeatable (default: one beam at 0 0)")
    g = sp.add_argument_group("image and output")
    g.add_argument("--resolution", type=_count, default=160, metavar="PIXELS", help="pixels per side of each image")
    g.add_argument("--wavelengths", nargs=3, metavar=("MIN", "MAX", "COUNT"), default=["380", "780", "81"],
                   help="wavelength grid in nm: COUNT evenly spaced values from MIN to MAX inclusive")
    g.add_argument("--projection", choices=SCATTEROGRAM_PROJECTIONS, default="equidistant",
                   help="angular mapping: radius ∝ θ (equidistant), sin θ (orthographic) or sin(θ/2) (equal-area)")
    g.add_argument("--exposure", type=_exposure, default="auto", metavar="X",
                   help="display gain on XYZ, or 'auto' (each image's brightest pixel to Y = 1)")
    g.add_argument("--lut", action="store_true", help="tabulate the mirrors' reflectance over the angle (faster)")
    g.add_argument("--out", default="out", metavar="DIR", help="output directory (created if missing)")
    g.add_argument("--name", default="scatterogram", metavar="STEM", help="file stem: writes STEM.png and STEM.npz")
    g.add_argument("--dpi", type=_count, default=150, metavar="DPI", help="resolution of the PNG")
    sp.set_defaults(func=_cmd_scatterogram, parser=sp)


def _cmd_scatterogram(args: argparse.Namespace) -> int:
    parser: argparse.ArgumentParser = args.parser
    _check_name(parser, args.name)
    wl_min, wl_max, wl_count = _parse_wavelengths(parser, args.wavelengths)
    if wl_count < 2 or wl_max <= wl_min:
        parser.error("--wavelengths: a spectrum needs MIN < MAX and COUNT >= 2")
    beams = args.beam if args.beam is not None else [[0.0, 0.0]]
    if not args.white and not beams:
        parser.error("nothing to render: --no-white needs at least one --beam")
    for theta, _ in beams:
        if not 0.0 <= theta <= 90.0:
            parser.error(f"--beam THETA must lie in [0, 90] degrees; got {theta:g}")

    import torch

    from torchirid import render
    from torchirid.layered import LayeredBragg, RoughBraggLayer
    from torchirid.layered.presets import JEWEL_BEETLE, jewel_beetle

    try:
        structures = []
        for name in args.preset:
            if name == "custom":
                layer = RoughBraggLayer(args.n1, args.n2, args.d1, args.d2, args.cells, args.alpha, n_incident=args.n_incident)
                structures.append((f"custom Λ={args.d1 + args.d2:g} nm", LayeredBragg([layer], args.base_albedo)))
            else:
                row = JEWEL_BEETLE[name]
                structures.append((f"{row['label']}: Λ={row['period']:g} nm, N={row['cells']}", jewel_beetle(name)))
        lam = torch.linspace(wl_min, wl_max, wl_count, dtype=torch.float64)
        rows, labels = [], []
        kw = dict(resolution=args.resolution, wavelength=lam, projection=args.projection, lut=args.lut)
        if args.white:
            rows.append([render.scatterogram(s, title=t, **kw) for t, s in structures])
            labels.append("white environment")
        for theta, phi in beams:
            rows.append([render.scatterogram(s, incident=(theta, phi), title=t, **kw) for t, s in structures])
            labels.append(f"beam θi={theta:g}°, φi={phi:g}°")
    except ValueError as e:  # the library names the bad parameter; report it like a usage error
        parser.error(str(e))

    out = Path(args.out)
    png_path = out / f"{args.name}.png"
    npz_path = out / f"{args.name}.npz"
    try:
        out.mkdir(parents=True, exist_ok=True)
        render.save_scatterograms_png(rows, png_path, dpi=args.dpi, exposure=args.exposure, row_labels=labels)
        render.save_scatterograms_npz(rows, npz_path)
    except OSError as e:
        print(f"{PROG}: error: cannot write to {out}: {e}", file=sys.stderr)
        return 1
    print(png_path)
    print(npz_path)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``torchirid`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    raise SystemExit(main())