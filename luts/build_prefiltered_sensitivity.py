#!/usr/bin/env python
r"""(Re)build Kneiphof's 2-D prefiltered sensitivity tables Ŝ(μ_D, σ²_D) that torchirid ships.

Ŝ_j(μ, σ²) = ∫ S_j(ν) e^{−2πiνμ − 2π²ν²σ²} dν (Kneiphof et al. 2019, eq. 18), the Fourier
sensitivity of a Gaussian distribution of path differences, built by
:func:`torchirid.ibl.sensitivity.prefiltered_sensitivity_lut` on the shipped grid
(``PREFILTERED_SHIPPED``: μ = 0 … 20,000 nm every 10 nm, 41 nodes in the warped σ axis up to
σ = 1000 nm; demodulated real and imaginary parts), stored with float32 values (the float64
build rounded: within 1e-7, far below the table's interpolation error, ~5e-4) and written
atomically to ``src/torchirid/data/prefiltered_sensitivity/<slug>.npz``, where
:func:`torchirid.ibl.shipped_prefiltered_sensitivity_lut` finds them::

    PYTHONPATH=src python luts/build_prefiltered_sensitivity.py

The script prints each file's size, its interpolation error (``parameters["max_interp_error"]``,
measured at build time against the exact eq. 18) and the float32 rounding of the values and
of lookups, and exits non-zero if the interpolation error is above the promised 5e-4.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import torch

from torchirid.ibl.sensitivity import (
    PREFILTERED_SENSITIVITY_BUILDER,
    PREFILTERED_SHIPPED,
    lookup_prefiltered_sensitivity,
    prefiltered_sensitivity_lut,
    prefiltered_sensitivity_path,
)
from torchirid.lut import LUT

DEFAULT_OBSERVERS = ("CIE 1931 2",)
DEFAULT_ILLUMINANTS = ("D65",)
DEFAULT_OUT = Path(__file__).resolve().parent.parent / "src" / "torchirid" / "data" / "prefiltered_sensitivity"
PROMISE = 5e-4  # lookup_prefiltered_sensitivity: within 5e-4 of the exact eq. 18 on the default grid


def lookup_rounding(lut: LUT, stored: LUT, points: int = 20000) -> float:
    """Largest |lookup(stored) − lookup(lut)| over random (μ, σ) inside the table (σ below 50 nm for a third)."""
    g = torch.Generator().manual_seed(1)
    mu = torch.rand(points, generator=g, dtype=torch.float64) * float(lut.axes["mu"][-1])
    sigma = torch.rand(points, generator=g, dtype=torch.float64) * float(lut.parameters["sigma_max"])
    sigma[: points // 3] *= 0.05
    a = lookup_prefiltered_sensitivity(mu, sigma * sigma, lut=lut)
    b = lookup_prefiltered_sensitivity(mu, sigma * sigma, lut=stored.to(torch.float64))
    return float((a - b).abs().max())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--observers", nargs="+", default=list(DEFAULT_OBSERVERS))
    parser.add_argument("--illuminants", nargs="+", default=list(DEFAULT_ILLUMINANTS))
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--d-max", type=float, default=None,
                        help="largest mean path difference μ in nm (default: the shipped 20,000 nm; another "
                             "value gives a table the package does not load)")
    args = parser.parse_args(argv)
    if args.d_max is not None and not (args.d_max > 0 and args.d_max < float("inf")):
        parser.error("--d-max must be a finite number of nm > 0")
    grid = dict(PREFILTERED_SHIPPED, **({} if args.d_max is None else {"d_max": args.d_max}))
    args.out.mkdir(parents=True, exist_ok=True)
    for observer in args.observers:
        for illuminant in args.illuminants:
            lut = prefiltered_sensitivity_lut(observer, illuminant, **grid)
            err = max(lut.parameters["max_interp_error"])
            if err > PROMISE:  # check before writing: a shipped table stays as it was
                print(f"{observer} / {illuminant}: interpolation error {err:.3g} above the promise "
                      f"{PROMISE:g}; nothing written", file=sys.stderr)
                return 1
            stored = lut.to(torch.float32)
            path = args.out / Path(str(prefiltered_sensitivity_path(observer, illuminant))).name
            stored.write(path)
            os.chmod(path, 0o644)  # LUT.write's temporary file is private (0600); data files are public
            back = LUT.read(path, builder=PREFILTERED_SENSITIVITY_BUILDER, parameters=lut.parameters)
            rounding = float((back.values.double() - lut.values).abs().max())
            print(f"{path.name}: {tuple(back.values.shape)} float32, {path.stat().st_size / 1e6:.2f} MB, "
                  f"max |interp - exact| {err:.3g}, float32 rounding: values {rounding:.2g}, "
                  f"lookups {lookup_rounding(lut, back):.2g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
