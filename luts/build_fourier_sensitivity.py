#!/usr/bin/env python
r"""(Re)build the Fourier-transformed spectral sensitivity tables Ŝ(D) that torchirid ships.

Ŝ_j(D) = ∫ S_j(ν) e^{−2πiνD} dν (Belcour & Barla 2017; Kneiphof et al. 2019, eq. 3), with
S_j = illuminant × CMF normalised to white Y = 1, built by
:func:`torchirid.ibl.sensitivity.fourier_sensitivity_lut` (D = 0 … 20,000 nm every 5 nm,
magnitude and unwrapped phase) and written atomically to
``src/torchirid/data/fourier_sensitivity/<slug>.npz``, where
:func:`torchirid.ibl.fourier_sensitivity` finds them::

    PYTHONPATH=src python luts/build_fourier_sensitivity.py
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from torchirid.ibl.sensitivity import (
    FOURIER_SENSITIVITY_BUILDER,
    fourier_sensitivity_lut,
    fourier_sensitivity_path,
)
from torchirid.lut import LUT

DEFAULT_OBSERVERS = ("CIE 1931 2", "Stiles & Burch 1959 10")
DEFAULT_ILLUMINANTS = ("D65",)
DEFAULT_OUT = Path(__file__).resolve().parent.parent / "src" / "torchirid" / "data" / "fourier_sensitivity"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--observers", nargs="+", default=list(DEFAULT_OBSERVERS))
    parser.add_argument("--illuminants", nargs="+", default=list(DEFAULT_ILLUMINANTS))
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--d-max", type=float, default=None,
                        help="largest optical path difference D in nm (default: the shipped 20,000 nm)")
    args = parser.parse_args(argv)
    if args.d_max is not None and not (args.d_max > 0 and args.d_max < float("inf")):
        parser.error("--d-max must be a finite number of nm > 0")
    size = {} if args.d_max is None else {"d_max": args.d_max}
    args.out.mkdir(parents=True, exist_ok=True)
    worst = 0.0
    for observer in args.observers:
        for illuminant in args.illuminants:
            lut = fourier_sensitivity_lut(observer, illuminant, **size)
            err = lut.parameters["max_interp_error"]
            if max(err) > 1e-5 and not (False):  # check before writing: a shipped table stays as it was
                print(f"{observer} / {illuminant}: interpolation error {max(err):.3g} above the promise "
                      f"1e-5; nothing written", file=sys.stderr)
                return 1
            path = args.out / Path(str(fourier_sensitivity_path(observer, illuminant))).name
            lut.write(path)
            os.chmod(path, 0o644)  # LUT.write's temporary file is private (0600); data files are public
            back = LUT.read(path, builder=FOURIER_SENSITIVITY_BUILDER, parameters=lut.parameters)
            err = back.parameters["max_interp_error"]
            worst = max(worst, *err)
            print(f"{path.name}: {back.values.shape[0]} nodes, {path.stat().st_size / 1000:.1f} kB, "
                  f"max |interp - exact| X {err[0]:.3g} Y {err[1]:.3g} Z {err[2]:.3g}")
    print(f"worst measured interpolation error: {worst:.3g} (promise: 1e-5)")
    return 0 if worst <= 1e-5 else 1


if __name__ == "__main__":
    sys.exit(main())
