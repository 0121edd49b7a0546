"""The ``torchirid`` command.

``torchirid spectrum`` computes the reflectance R(θ, λ) of a Bragg mirror or a thin film on
a grid of incidence angles × wavelengths and writes ``<out>/<name>.npz`` (the arrays and a
JSON ``params`` string) and ``<out>/<name>.png`` (a reflectance map).

``torchirid gradients`` draws the atlas of angular colour gradients of Fourneau et al. 2024,
Fig. 4 (rows: period Λ; columns: d1/Λ, plus a first thin-film column) and writes
``<out>/<name>.png`` and ``<out>/<name>.npz`` (the sRGB strips and a JSON ``params`` string).

On the command line, wavelengths and thicknesses are in nm and incidence angles in degrees
(the library itself takes cos θ). Heavy imports (torch, numpy, matplotlib) happen inside
the command so that ``--help`` stays fast.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
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


def _json_index(n):
    """Refractive indices in the JSON params: a number, or [re, im] when complex."""
    return [n.real, n.imag] if isinstance(n, complex) else n


def _fmt_index(n) -> str:
    if isinstance(n, complex):
        return f"{n.real:g}{n.imag:+g}i"
    return f"{n:g}"


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
        "Bragg mirror (--kind bragg)", "the stack n_host | (n2, d2), (n1, d1) × cells | n1, lit from n_host"
    )
    g.add_argument(
        "--n1", type=_index, default=1.0, metavar="N", help="index of layer 1 (also the medium below the mirror)"
    )
    g.add_argument("--n2", type=_index, default=1.5, metavar="N", help="refractive index of layer 2")
    g.add_argument("--d1", type=_float, default=125.0, metavar="NM", help="thickness of layer 1 in nm")
    g.add_argument("--d2", type=_float, default=375.0, metavar="NM", help="thickness of layer 2 in nm")
    g.add_argument("--cells", type=int, default=20, metavar="COUNT", help="number N of cells (layer pairs)")
    g.add_argument(
        "--n-host",
        type=_index,
        default=None,
        metavar="N",
        help="real index of the host (incident) medium above the mirror; default: n1",
    )

    g = sp.add_argument_group(
        "thin film (--kind thin-film)", "the stack n_outer | (n_film, thickness) | n_substrate, lit from n_outer"
    )
    g.add_argument("--n-film", type=_index, default=1.5, metavar="N", help="refractive index of the film")
    g.add_argument("--thickness", type=_float, default=375.0, metavar="NM", help="film thickness in nm")
    g.add_argument(
        "--n-substrate", type=_index, default=1.0, metavar="N", help="refractive index of the medium below the film"
    )
    g.add_argument(
        "--n-outer", type=_index, default=1.0, metavar="N", help="index of the incident medium above the film (real)"
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


def _cmd_spectrum(args: argparse.Namespace) -> int:
    parser: argparse.ArgumentParser = args.parser
    wl_min, wl_max, wl_count = _parse_wavelengths(parser, args.wavelengths)
    if not args.name or os.sep in args.name or (os.altsep and os.altsep in args.name):
        parser.error(f"--name must be a plain file stem, got {args.name!r}")

    import numpy as np
    import torch

    import torchirid

    dtype = getattr(torch, args.dtype)
    cdtype = torch.complex128 if dtype == torch.float64 else torch.complex64

    def real(x):
        return torch.tensor(x, dtype=dtype)

    def index(n):
        # build complex constants directly in the target precision (never float32 cast up)
        return torch.tensor(n, dtype=cdtype if isinstance(n, complex) else dtype)

    wavelength_nm = np.linspace(wl_min, wl_max, wl_count)
    theta_deg = np.linspace(0.0, 90.0, args.angles)
    # cos 90° is 6e-17, not 0; clip guards against any rounding outside [0, 1]
    cos_theta = np.clip(np.cos(np.radians(theta_deg)), 0.0, 1.0)

    wavelength = torch.as_tensor(wavelength_nm, dtype=dtype)[None, :]  # (1, W)
    cos_t = torch.as_tensor(cos_theta, dtype=dtype)[:, None]  # (A, 1)

    params: dict = {"kind": args.kind}
    if args.kind == "bragg":
        n_host = args.n1 if args.n_host is None else args.n_host
        params.update(
            n1=_json_index(args.n1),
            n2=_json_index(args.n2),
            d1_nm=args.d1,
            d2_nm=args.d2,
            cells=args.cells,
            n_host=_json_index(n_host),
        )
        title = (
            f"Bragg mirror: n1={_fmt_index(args.n1)}, n2={_fmt_index(args.n2)}, "
            f"d1={args.d1:g} nm, d2={args.d2:g} nm, N={args.cells}, host n={_fmt_index(n_host)}"
        )
    else:
        params.update(
            n_film=_json_index(args.n_film),
            thickness_nm=args.thickness,
            n_substrate=_json_index(args.n_substrate),
            n_outer=_json_index(args.n_outer),
        )
        title = (
            f"Thin film: n={_fmt_index(args.n_film)}, d={args.thickness:g} nm, "
            f"substrate n={_fmt_index(args.n_substrate)}, outer n={_fmt_index(args.n_outer)}"
        )
    params.update(
        polarization=args.polarization,
        wavelength_min_nm=wl_min,
        wavelength_max_nm=wl_max,
        wavelength_count=wl_count,
        angle_count=args.angles,
        angle_min_deg=0.0,
        angle_max_deg=90.0,
        dtype=args.dtype,
        torchirid_version=getattr(torchirid, "__version__", None) or _version(),
    )

    try:
        with torch.no_grad():
            if args.kind == "bragg":
                R = torchirid.bragg_reflectance(
                    wavelength,
                    cos_t,
                    index(args.n1),
                    index(args.n2),
                    real(args.d1),
                    real(args.d2),
                    args.cells,
                    n_host=index(n_host),
                    polarization=args.polarization,
                )
            else:
                R = torchirid.thin_film_reflectance(
                    wavelength,
                    cos_t,
                    index(args.n_film),
                    real(args.thickness),
                    index(args.n_substrate),
                    n_outer=index(args.n_outer),
                    polarization=args.polarization,
                )
    except ValueError as e:  # the library names the bad parameter; report it like a usage error
        parser.error(str(e))

    shape = (args.angles, wl_count)
    R = torch.broadcast_to(R, shape).detach().cpu().numpy()

    out = Path(args.out)
    npz_path = out / f"{args.name}.npz"
    png_path = out / f"{args.name}.png"
    try:
        out.mkdir(parents=True, exist_ok=True)
        _atomic_write(
            npz_path,
            lambda f: np.savez(
                f,
                wavelength_nm=wavelength_nm,
                theta_deg=theta_deg,
                cos_theta=np.asarray(cos_t.squeeze(-1).cpu().numpy()),
                reflectance=R,
                params=np.array(json.dumps(params, sort_keys=True)),
            ),
        )
        fig = _plot(wavelength_nm, theta_deg, R, title, args.polarization)
        try:
            _atomic_write(png_path, lambda f: fig.savefig(f, format="png", dpi=120))
        finally:
            import matplotlib.pyplot as plt

            plt.close(fig)
    except OSError as e:
        print(f"{PROG}: error: cannot write to {out}: {e}", file=sys.stderr)
        return 1

    print(npz_path)
    print(png_path)
    return 0


def _atomic_write(path: Path, write) -> None:
    """Write via a temporary file in the same directory, then rename over ``path``."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600 files; give the usual permissions
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _plot(wavelength_nm, theta_deg, R, title: str, polarization: str):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, (ax_map, ax_lines) = plt.subplots(
        1, 2, figsize=(12, 5), gridspec_kw={"width_ratios": [1.35, 1]}, layout="constrained"
    )
    finite = R[np.isfinite(R)]
    vmax = float(finite.max()) if finite.size and finite.max() > 0 else 1.0
    mesh = ax_map.pcolormesh(wavelength_nm, theta_deg, R, shading="nearest", cmap="magma", vmin=0.0, vmax=vmax)
    fig.colorbar(mesh, ax=ax_map, label="reflectance R")
    ax_map.set_xlabel("wavelength λ (nm)")
    ax_map.set_ylabel("incidence angle θ (degrees)")
    ax_map.set_title(f"R(θ, λ), {polarization}")

    # a few spectra at fixed angles (the grid angles nearest to these)
    picks = sorted({int(np.abs(theta_deg - t).argmin()) for t in (0.0, 30.0, 60.0, 80.0)})
    for i in picks:
        ax_lines.plot(wavelength_nm, R[i], label=f"θ = {theta_deg[i]:.1f}°")
    ax_lines.set_xlabel("wavelength λ (nm)")
    ax_lines.set_ylabel("reflectance R")
    ax_lines.set_ylim(0.0, max(1.0, vmax) * 1.02)
    if len(wavelength_nm) > 1:
        ax_lines.set_xlim(wavelength_nm[0], wavelength_nm[-1])
    ax_lines.grid(alpha=0.3)
    ax_lines.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=len(picks), fontsize="small", frameon=False)
    fig.suptitle(title)
    return fig


# ----------------------------------------------------------------------------------------
# torchirid gradients: the atlas of angular colour gradients (Fourneau et al. 2024, Fig. 4)
# ----------------------------------------------------------------------------------------

#: wavelengths (nm) of the reflectance curves: the peaks of the CIE 1931 x̄, ȳ, z̄ CMFs for
#: red, green and blue. Fourneau et al.'s Fig. 4 caption prints {559, 556, 442} nm; 559 is a
#: typo for 599 nm (the x̄ peak; 559 would sit on top of the green 556 nm curve).
CURVE_WAVELENGTHS_NM = (599.0, 556.0, 442.0)
CURVE_COLORS = ("tab:red", "tab:green", "tab:blue")
#: angles of the reflectance curves (0.125° steps: Λ ≈ 1 µm, N = 20 mirrors oscillate ~20
#: times over 0–90°, so this resolves every fringe independently of --angles)
CURVE_ANGLES = 721
#: the three strips under each Bragg plot: (npz key, label, bragg_xyz keyword arguments)
GRADIENT_METHODS = (
    ("reference", "ref.", {"method": "spectral"}),
    ("piecewise", "piecewise (s=8)", {"method": "piecewise", "subdivisions": 8, "weights": "averaged"}),
    ("paper_sub", "paper sub. s=3", {"method": "piecewise", "subdivisions": 3, "weights": "paper"}),
)
#: samples of the thin-film spectrum (0.2 nm over 380–780 nm: a ~1 µm film has ~6 fringes there)
THIN_FILM_SAMPLES = 2001


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
    if not args.name or os.sep in args.name or (os.altsep and os.altsep in args.name):
        parser.error(f"--name must be a plain file stem, got {args.name!r}")
    if args.n1 > args.n2:
        # the piecewise strips model light propagating in layer 2 at every angle up to 90°
        parser.error(f"--n1 ({args.n1:g}) must not exceed --n2 ({args.n2:g}): the piecewise approximations "
                     "need light propagating in layer 2 (no total internal reflection) up to 90°")

    import numpy as np
    import torch
    from tqdm.auto import tqdm

    import torchirid

    dtype = torch.float64
    lambdas = np.asarray(args.lambdas, dtype=np.float64)
    ratios = np.asarray(args.ratios, dtype=np.float64)
    theta_deg = np.linspace(0.0, 90.0, args.angles)
    curve_theta_deg = np.linspace(0.0, 90.0, CURVE_ANGLES)

    def cosines(deg):  # cos 90° is 6e-17, not 0; clip guards against rounding outside [0, 1]
        return torch.as_tensor(np.clip(np.cos(np.radians(deg)), 0.0, 1.0), dtype=dtype)

    # the grid as broadcasting tensors: Λ (L, 1, 1) × d1/Λ (1, R, 1) × angle (1, 1, A)
    period = torch.as_tensor(lambdas, dtype=dtype)[:, None, None]
    ratio = torch.as_tensor(ratios, dtype=dtype)[None, :, None]
    d1 = ratio * period
    d2 = period - d1
    cos_t = cosines(theta_deg)
    n1, n2 = float(args.n1), float(args.n2)
    common = dict(polarization=args.polarization)

    xyz: dict[str, np.ndarray] = {}
    steps = [label for _, label, _ in GRADIENT_METHODS] + ["thin film", "curves", "figure"]
    # one bragg_xyz call per method for the whole grid; the bar appears only past 2 s
    bar = tqdm(total=len(steps), desc="torchirid gradients", unit="step", delay=2.0, file=sys.stderr, leave=False)
    try:
        with torch.no_grad():
            for (key, label, kwargs) in GRADIENT_METHODS:
                bar.set_postfix_str(label, refresh=False)
                xyz[key] = torchirid.bragg_xyz(cos_t, n1, n2, d1, d2, args.cells, **kwargs, **common).numpy()
                bar.update()

            # thin film: a slab of index n2, thickness Λ, in n1 (air by default) — (L, A, 3)
            bar.set_postfix_str("thin film", refresh=False)
            wl = torch.linspace(380.0, 780.0, THIN_FILM_SAMPLES, dtype=dtype)
            R_film = torchirid.thin_film_reflectance(wl, cos_t[:, None], n2, period, n1, n_outer=n1, **common)
            xyz["thin_film"] = torchirid.spectrum_to_xyz(R_film, wl).numpy()
            bar.update()

            # reflectance curves at the CMF peaks: (L, R, C, 3) and (L, C, 3)
            bar.set_postfix_str("curves", refresh=False)
            wl_c = torch.as_tensor(CURVE_WAVELENGTHS_NM, dtype=dtype)
            cos_c = cosines(curve_theta_deg)[:, None]
            R_bragg = torchirid.bragg_reflectance(wl_c, cos_c, n1, n2, d1[..., None], d2[..., None], args.cells,
                                                  **common).numpy()
            R_thin = torchirid.thin_film_reflectance(wl_c, cos_c, n2, period, n1, n_outer=n1, **common).numpy()
            bar.update()
    except ValueError as e:  # the library names the bad parameter; report it like a usage error
        bar.close()
        parser.error(str(e))

    def srgb(x):
        return np.clip(torchirid.xyz_to_srgb(torch.as_tensor(x)).numpy(), 0.0, 1.0)

    strips = {key: srgb(value) for key, value in xyz.items()}
    params = dict(
        figure="Fourneau et al. 2024, Fig. 4",
        n1=n1,
        n2=n2,
        cells=args.cells,
        lambdas_nm=lambdas.tolist(),
        ratios=ratios.tolist(),
        polarization=args.polarization,
        angle_count=args.angles,
        angle_min_deg=0.0,
        angle_max_deg=90.0,
        strips={key: dict(label=label, **kwargs) for key, label, kwargs in GRADIENT_METHODS},
        thin_film=dict(n_film=n2, thickness="Λ", n_outer=n1, n_substrate=n1, method="spectrum_to_xyz",
                       wavelength_samples=THIN_FILM_SAMPLES, wavelength_range_nm=[380.0, 780.0]),
        curve_wavelengths_nm=list(CURVE_WAVELENGTHS_NM),
        curve_wavelengths_note="CMF peaks; the paper's caption prints 559 nm for red, a typo for 599 nm",
        observer="CIE 1931 2",
        illuminant="D65",
        srgb="clipped to [0, 1]",
        torchirid_version=getattr(torchirid, "__version__", None) or _version(),
    )

    out = Path(args.out)
    npz_path = out / f"{args.name}.npz"
    png_path = out / f"{args.name}.png"
    try:
        out.mkdir(parents=True, exist_ok=True)
        bar.set_postfix_str("figure", refresh=False)
        fig = _plot_gradients(theta_deg, curve_theta_deg, lambdas, ratios, d1.squeeze(-1).numpy(),
                              d2.squeeze(-1).numpy(), strips, R_bragg, R_thin, args)
        try:
            _atomic_write(png_path, lambda f: fig.savefig(f, format="png", dpi=args.dpi))
        finally:
            import matplotlib.pyplot as plt

            plt.close(fig)
        bar.update()
        arrays = dict(
            theta_deg=theta_deg,
            cos_theta=cos_t.numpy(),
            lambdas_nm=lambdas,
            ratios=ratios,
            d1_nm=d1.squeeze(-1).numpy(),
            d2_nm=d2.squeeze(-1).numpy(),
            curve_theta_deg=curve_theta_deg,
            curve_wavelength_nm=np.asarray(CURVE_WAVELENGTHS_NM),
            reflectance_bragg=R_bragg.astype(np.float32),
            reflectance_thin_film=R_thin.astype(np.float32),
            params=np.array(json.dumps(params, sort_keys=True)),
        )
        arrays.update({f"srgb_{key}": value for key, value in strips.items()})
        arrays.update({f"xyz_{key}": value for key, value in xyz.items()})
        _atomic_write(npz_path, lambda f: np.savez(f, **arrays))
    except OSError as e:
        print(f"{PROG}: error: cannot write to {out}: {e}", file=sys.stderr)
        return 1
    finally:
        bar.close()

    print(png_path)
    print(npz_path)
    return 0


def _plot_gradients(theta_deg, curve_theta_deg, lambdas, ratios, d1_nm, d2_nm, strips, R_bragg, R_thin, args):
    """The atlas: rows Λ; a thin-film column, a gap, then one column per d1/Λ."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    rows, cols = len(lambdas), len(ratios)
    small, tiny = 7, 6
    half = 45.0 / (len(theta_deg) - 1)  # strips: pixel centres at the angles, edges half a step out
    extent = (-half, 90.0 + half, 0.0, 1.0)

    fig = plt.figure(figsize=(1.6 + 1.85 * (cols + 1), 1.55 + 2.05 * rows))
    outer = fig.add_gridspec(rows, cols + 2, width_ratios=[1.0, 0.12] + [1.0] * cols,
                             left=0.075, right=0.905, top=1 - 0.95 / fig.get_figheight(),
                             bottom=0.75 / fig.get_figheight(), wspace=0.1, hspace=0.32)

    def strip(ax, rgb, label, left_label, bottom):
        ax.imshow(rgb[None], extent=extent, aspect="auto", interpolation="nearest")
        ax.set_xlim(0.0, 90.0)
        ax.set_yticks([])
        ax.set_ylabel(label, rotation=0, ha="right" if left_label else "left", va="center", fontsize=tiny,
                      labelpad=2)
        if not left_label:
            ax.yaxis.set_label_position("right")
        ax.set_xticks([0, 30, 60, 90])
        ax.tick_params(axis="x", labelsize=tiny, length=2, pad=1, labelbottom=bottom)
        for spine in ax.spines.values():
            spine.set_linewidth(0.4)

    def curves(ax, R, title, ylabel):
        for k, color in enumerate(CURVE_COLORS):
            ax.plot(curve_theta_deg, R[:, k], color=color, lw=0.6)
        ax.set_xlim(0.0, 90.0)
        ax.set_ylim(-0.03, 1.05)
        ax.set_xticks([0, 30, 60, 90])
        ax.set_yticks([0, 0.5, 1])
        ax.tick_params(labelsize=tiny, length=2, pad=1, labelbottom=False, labelleft=ylabel is not None)
        ax.grid(alpha=0.25, lw=0.4)
        ax.set_title(title, fontsize=tiny, pad=2)
        if ylabel is not None:
            ax.set_ylabel(ylabel, fontsize=small)

    labels = [label for _, label, _ in GRADIENT_METHODS]
    for i, period in enumerate(lambdas):
        last_row = i == rows - 1
        # thin film: reflectance curves and the reference strip
        cell = outer[i, 0].subgridspec(4, 1, height_ratios=[4.2, 0.8, 0.8, 0.8], hspace=0.12)
        ax = fig.add_subplot(cell[0])
        curves(ax, R_thin[i], f"d = {period:g} nm", f"Λ = {period:g} nm\nR")
        strip(fig.add_subplot(cell[1]), strips["thin_film"][i], labels[0], True, last_row)
        if i == 0:
            ax.annotate(f"thin film (n = {args.n2:g})", (0.5, 1.0), xycoords="axes fraction", xytext=(0, 13),
                        textcoords="offset points", ha="center", va="bottom", fontsize=small + 1,
                        fontweight="bold")
        for j, r in enumerate(ratios):
            cell = outer[i, j + 2].subgridspec(4, 1, height_ratios=[4.2, 0.8, 0.8, 0.8], hspace=0.12)
            ax = fig.add_subplot(cell[0])
            curves(ax, R_bragg[i, j], f"d1 = {d1_nm[i, j]:.4g}, d2 = {d2_nm[i, j]:.4g} nm",
                   "R" if j == 0 else None)
            if i == 0:
                ax.annotate(f"d1/Λ = {r:g}", (0.5, 1.0), xycoords="axes fraction", xytext=(0, 13),
                            textcoords="offset points", ha="center", va="bottom", fontsize=small + 1,
                            fontweight="bold")
            for k, (key, label, _) in enumerate(GRADIENT_METHODS):
                # strip labels once per row, right of the last column
                strip(fig.add_subplot(cell[k + 1]), strips[key][i, j], label if j == cols - 1 else "", False,
                      last_row and k == len(GRADIENT_METHODS) - 1)
    fig.text(0.49, 0.3 / fig.get_figheight(), "incidence angle θ (degrees)", ha="center", va="center",
             fontsize=small)

    pol = "unpolarized" if args.polarization == "unpolarized" else f"{args.polarization}-polarized"
    fig.suptitle(
        f"Angular colour gradients of Bragg mirrors (after Fourneau et al. 2024, Fig. 4): "
        f"n1 = {args.n1:g}, n2 = {args.n2:g}, N = {args.cells}, {pol}; rows: period Λ = d1 + d2",
        fontsize=small + 2, y=1 - 0.22 / fig.get_figheight(),
    )
    handles = [Line2D([], [], color=c, lw=1.2) for c in CURVE_COLORS]
    fig.legend(handles, [f"R(θ) at {w:g} nm" for w in CURVE_WAVELENGTHS_NM], loc="upper center", ncol=3,
               fontsize=tiny + 0.5, frameon=False, bbox_to_anchor=(0.49, 1 - 0.42 / fig.get_figheight()))
    fig.text(
        0.5, 0.08 / fig.get_figheight(),
        "Curves at the CMF peaks 599 / 556 / 442 nm (the paper's caption prints 559, a typo for 599). "
        "Strips: sRGB (D65, CIE 1931 2°, clipped) against θ — ref. = exact spectrum; "
        "piecewise (s=8) = library's fringe-averaged approximation; paper sub. s=3 = the paper's subdivided one.",
        ha="center", va="bottom", fontsize=tiny - 0.5, color="0.3",
    )
    return fig


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``torchirid`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    raise SystemExit(main())
