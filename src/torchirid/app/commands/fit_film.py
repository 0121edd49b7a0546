"""``torchirid fit-film CUBE --out DIR``: film index and thickness map from a hyperspectral cube (Kobayashi et al.).

Writes ``<out>/thickness.png``, ``<out>/fit_error.png`` (per-pixel RMS residual),
``<out>/thickness_nm.npy``, ``<out>/report.json`` (n, index parameters, thickness statistics,
timings, settings) and, when the cube carries a ground truth (``thickness_nm`` in the .npz),
``<out>/thickness_error.png`` and the Table-1 errors in the report.

Dead pixels (no finite sample: NaN in a .npz, an ENVI header's ``data ignore value``) have no
estimate: NaN in ``thickness_nm.npy``, grey in the maps, left out of every statistic, and
counted in the report's ``pixels`` (``total``, ``valid``, ``invalid``, ``missing_samples``: valid
pixels fitted from part of their samples). ``report.json`` is strict JSON: a number that is not
finite (a statistic of no pixel, an infinite misfit) is written ``null``.
"""

from __future__ import annotations

import inspect
import os
import sys
import warnings

import numpy as np
import torch

from ..._io import write_json
from ...estimation import estimate_film
from ...estimation.cube_io import read_cube
from ...estimation.peaks import NoTrackError, radians_hint
from ...estimation.problem import INDEX_CHOICES
from .. import _args
from ..figures.film_maps import save_film_map_png

NAME = "fit-film"
#: the largest reflectance accepted in a cube (noise may push a true 1 a little above it);
#: beyond it the data are taken to be in percent or counts and refused
MAX_REFLECTANCE = 1.5

__all__ = ["NAME", "add_parser", "run"]

#: estimate_film's defaults: each option of the fit takes its default from the library (one default per parameter)
FIT_DEFAULTS = {name: p.default for name, p in inspect.signature(estimate_film).parameters.items()
                if p.default is not inspect.Parameter.empty}


def add_parser(subparsers):
    """Register ``fit-film`` on an argparse subparsers object (``func=run``); returns its parser."""
    p = _args.add_command_parser(
        subparsers,
        NAME,
        help="film index n and thickness map from a hyperspectral cube (Kobayashi et al.) → PNGs + JSON",
        description=(
            "Estimate the refractive index (shared) and the per-pixel thickness of a thin film on a\n"
            "known substrate from a hyperspectral cube seen at several incidence angles (Kobayashi et al.,\n"
            "peak-wavelength method eq. 8-14, then a joint least-squares refinement).\n\n"
            "CUBE is a .npz (cube (H, W, A, B), wavelength_nm, angle_deg), or an ENVI .hdr whose bands\n"
            "carry 'wavelength' (angle-major when several angles share one file) with the angles from\n"
            "--angles or a per-band 'incidence angle' field, or several ENVI .hdr files, one per angle,\n"
            "with --angles giving each file's angle in the same order:\n"
            "  torchirid fit-film a10.hdr a20.hdr a30.hdr a40.hdr a50.hdr --angles 10 20 30 40 50 --out fit/"
        ),
    )
    p.add_argument("cube", metavar="CUBE", nargs="+", help=".npz cube, ENVI .hdr cube, or one ENVI .hdr per angle")
    p.add_argument("--angles", type=_args.number, nargs="+", default=None, metavar="DEG",
                   help="incidence angles in degrees: one per CUBE file, or one per block of bands of a single "
                        "ENVI file without an 'incidence angle' field")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--n-substrate", type=_args.positive, default=1.64, metavar="N", help="substrate index (PET: 1.64)")
    p.add_argument("--polarization", choices=_args.POLARIZATIONS, default=FIT_DEFAULTS["polarization"],
                   help="polarization seen by the camera (default: unpolarized, as everywhere in torchirid; "
                        "Kobayashi et al. measure the s wave through a polarizer: --polarization s)")
    p.add_argument("--bandwidth", type=_args.positive_length, default=None, metavar="NM",
                   help=f"band width in nm (default: from the file, else {FIT_DEFAULTS['bandwidth']:g})")
    p.add_argument("--passband", choices=("box", "gaussian"), default=FIT_DEFAULTS["passband"],
                   help="shape of each band's spectral response, --bandwidth wide")
    p.add_argument("--index-model", choices=INDEX_CHOICES, default=FIT_DEFAULTS["index_model_name"],
                   help="film index model, as in estimate_film and fit-batch film: auto fits constant, cauchy and "
                        "cauchy3 on a pixel sample and keeps the least BIC; constant misfits a dispersive film such "
                        "as ZnS")
    p.add_argument("--thickness-range", type=_args.positive_length, nargs=2, default=FIT_DEFAULTS["thickness_range"],
                   metavar=("MIN", "MAX"), help="film thicknesses searched, in nm")
    p.add_argument("--smoothness", type=_args.nonnegative, default=FIT_DEFAULTS["smoothness"],
                   help="spatial smoothness weight (reflectance²/nm²)")
    p.add_argument("--threads", type=_args.count, default=None, help="torch threads (default: torch's)")
    p.add_argument("--seed", type=int, default=FIT_DEFAULTS["seed"],
                   help="seed of the random pixel sample on which the index is searched")
    _args.add_output_options(p)
    p.set_defaults(func=run, parser=p)
    return p


def _stats(x) -> dict:
    """mean, min, max and std of the finite values of a tensor (None where there are none)."""
    v = x[x.isfinite()].double()
    if v.numel() == 0:
        return {"mean": None, "min": None, "max": None, "std": None}
    return {"mean": float(v.mean()), "min": float(v.min()), "max": float(v.max()),
            "std": float(v.std()) if v.numel() > 1 else 0.0}


def _no_track_message(angles_deg) -> str:
    """The error of a cube in which no extremum could be followed over the angles, with what to do
    on the command line: angles in radians given as degrees (the commonest cause) or others."""
    shown = " ".join(f"{a:g}" for a in angles_deg)
    head = (f"no extremum of the cube could be followed over the angles ({shown} degrees as read): the film's index "
            "cannot be estimated; ")
    where = "the .npz's angle_deg, the ENVI header's 'incidence angle', or --angles"
    hint = radians_hint(angles_deg)
    if hint:
        return head + f"{hint}: multiply them by 180/π ({where})"
    return head + (f"check the angles, in degrees ({where}), and --n-substrate; a film whose index lies outside "
                   "1.2–3.5, or with too few fringes that move with the angle, cannot be fitted")


@_args.reports_bad_arguments(NAME)
def run(args) -> int:
    """Estimate the film and write the maps and the report. Exit status: 0, 1 (write), 2 (bad argument or cube)."""
    _args.check_range(args.thickness_range, "--thickness-range", "nm")  # before the (slow) read
    if args.threads:
        torch.set_num_threads(args.threads)
    try:
        paths = args.cube if len(args.cube) > 1 else args.cube[0]
        cube = read_cube(paths, angles_deg=args.angles)  # ValueError naming the file (→ exit 2)
    except (OSError, ImportError) as exc:  # an unreadable CUBE, or ENVI without 'spectral': one line too
        return _args.fail(NAME, exc)
    top = float(torch.nan_to_num(cube.cube, nan=0.0, posinf=0.0, neginf=0.0).max())  # (read_cube gives float64)
    if top > MAX_REFLECTANCE:
        # data in percent (or counts): the fit would chase n ≈ 100 and exit 0 with nonsense
        raise ValueError(f"the cube holds reflectances up to {top:g} (> {MAX_REFLECTANCE:g}): fit-film needs reflectance "
                         "as a fraction of 1; data in percent? divide by 100, or give the ENVI header a "
                         "'reflectance scale factor = 100'")
    bw = args.bandwidth if args.bandwidth is not None else (
        cube.bandwidth if cube.bandwidth is not None else FIT_DEFAULTS["bandwidth"])
    bar = _args.progress_bar(f"torchirid {NAME}", unit="stage", quiet=args.quiet)  # (estimate_film gives the total)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RuntimeWarning)
            est = estimate_film(cube.cube, cube.wavelength, cube.cos_theta, args.n_substrate,
                                index_model_name=args.index_model, bandwidth=bw, passband=args.passband,
                                polarization=args.polarization, thickness_range=tuple(args.thickness_range),
                                smoothness=args.smoothness, seed=args.seed,
                                progress=_args.progress_callback(bar))
    except NoTrackError:  # (the library's remedies name its own arguments: say it in the command's terms)
        raise ValueError(_no_track_message(cube.angles_deg.tolist())) from None
    finally:
        bar.close()
    notes = [str(w.message) for w in caught]
    notes += [flag for flag in est.settings["flags"] if flag not in notes]  # (a fallback flags without a warning)
    for note in notes:
        print(f"{_args.PROG} {NAME}: warning: {_args.one_line(note)}", file=sys.stderr)
    d, valid = est.thickness, est.valid
    report = {
        "cube": [os.fspath(c) for c in args.cube] if len(args.cube) > 1 else os.fspath(args.cube[0]),
        "angles_deg": cube.angles_deg.tolist(),
        "shape": list(cube.cube.shape),
        "n": est.n,
        "n_reference_wavelength_nm": 589.3,
        "index_model": est.index_model,
        "index_params": est.params.tolist(),
        "n_peak_method": est.n_peak,
        "pixels": {"total": valid.numel(), "valid": int(valid.sum()), "invalid": int((~valid).sum()),
                   "missing_samples": est.settings["pixels_missing_samples"]},
        "thickness_nm": _stats(d[valid]),
        "rms_residual_mean": _stats(est.rms[valid])["mean"],
        "noise_level": est.settings["noise_level"],
        "residual_to_noise": est.settings["residual_to_noise"],
        "index_selection": est.settings["index_selection"],
        "warnings": notes,
        "timings_s": est.timings,
        "settings": dict(est.settings, bandwidth=bw, thickness_range=list(args.thickness_range)),
    }
    try:
        os.makedirs(args.out, exist_ok=True)
        np.save(os.path.join(args.out, "thickness_nm.npy"), d.numpy())
        written = [os.path.join(args.out, "thickness_nm.npy")]
        maps = [(d, "thickness", f"thickness, n = {est.n:.4f}", "d (nm)", "viridis"),
                # (invalid pixels are NaN in every map: drawn grey, outside the colour scale)
                (est.rms, "fit_error", "RMS residual per pixel", "reflectance", "magma")]
        if cube.thickness is not None:
            err = (d - cube.thickness).abs()
            maps.append((err, "thickness_error", "|d − d_true|", "nm", "magma"))
        for values, stem, title, unit, cmap in maps:
            for path in _args.figure_paths(args.out, stem, args.format):
                save_film_map_png(values, path, title, unit, cmap=cmap)
                written.append(os.fspath(path))
        if cube.thickness is not None:
            report["thickness_error_nm"] = {k: v for k, v in _stats(err[valid]).items() if k in ("mean", "max")}
            if "n_true" in cube.meta:
                report["n_error"] = abs(est.n - float(cube.meta["n_true"]))
        write_json(os.path.join(args.out, "report.json"), report)  # strict JSON (NaN → null), atomic
        written.append(os.path.join(args.out, "report.json"))
    except OSError as e:
        return _args.cannot_write(NAME, args.out, e)
    dead = int((~valid).sum())
    print(f"n = {est.n:.4f} ({est.index_model}), mean d = {float(d[valid].mean()):.1f} nm"
          f"{f' ({dead} invalid pixels)' if dead else ''}, {est.timings['total']:.1f} s")
    for path in written:
        print(path)
    return 0
