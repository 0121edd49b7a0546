#!/usr/bin/env python
r"""(Re)build the cumulative colour-matching tables C̄(ω) that torchirid ships.

C̄(ω) = ∫_{ω_min}^{ω} c̄(ω') dω' (Fourneau et al. 2024, eq. 15–16), ω = 2π/λ in nm⁻¹, built
by :func:`torchirid.spectral.cumulative.cumulative_cmf_lut` and written atomically
(:meth:`torchirid.lut.LUT.write`) to ``src/torchirid/data/cmf_cumulative/<slug>.npz``, where
:func:`torchirid.spectral.cumulative.shipped_cumulative_cmf_lut` finds them.

Defaults build the shipped set: observers "CIE 1931 2" and "CIE 1964 10" × illuminants
"D65" and "E", 380–780 nm, automatic node count (measured interpolation error ≤ 5e-7)::

    PYTHONPATH=src python luts/build_cumulative_cmf.py
    PYTHONPATH=src python luts/build_cumulative_cmf.py --observers "CIE 1931 2" \
        --illuminants D50 --range 360 830 --out /tmp/tables

Only tables built with the automatic node count are picked up by ``shipped_cumulative_cmf_lut``
(``--nodes`` is for experiments; such a file is refused there and rebuilt in memory).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from torchirid.lut import LUT
from torchirid.spectral.cumulative import (
    CUMULATIVE_CMF_BUILDER,
    cumulative_cmf_lut,
    cumulative_cmf_path,
)

DEFAULT_OBSERVERS = ("CIE 1931 2", "CIE 1964 10")
DEFAULT_ILLUMINANTS = ("D65", "E")
DEFAULT_OUT = Path(__file__).resolve().parent.parent / "src" / "torchirid" / "data" / "cmf_cumulative"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--observers", nargs="+", default=list(DEFAULT_OBSERVERS),
                        help="observer names (default: %(default)s)")
    parser.add_argument("--illuminants", nargs="+", default=list(DEFAULT_ILLUMINANTS),
                        help="illuminant names (default: %(default)s)")
    parser.add_argument("--range", nargs=2, type=float, default=(380.0, 780.0),
                        metavar=("LMIN", "LMAX"), help="wavelength range in nm (default: 380 780)")
    parser.add_argument("--nodes", type=int, default=None,
                        help="number of ω nodes (default: automatic, error ≤ 5e-7)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="output directory (default: the package's data/cmf_cumulative)")
    args = parser.parse_args(argv)

    args.out.mkdir(parents=True, exist_ok=True)
    worst = 0.0
    for observer in args.observers:
        for illuminant in args.illuminants:
            lut = cumulative_cmf_lut(observer, illuminant, tuple(args.range), args.nodes)
            err = lut.parameters["max_interp_error"]
            if max(err) > 1e-6 and not (args.nodes is not None):  # check before writing: a shipped table stays as it was
                print(f"{observer} / {illuminant}: interpolation error {max(err):.3g} above the promise "
                      f"1e-6; nothing written", file=sys.stderr)
                return 1
            path = args.out / Path(str(cumulative_cmf_path(observer, illuminant, tuple(args.range)))).name
            lut.write(path)
            os.chmod(path, 0o644)  # LUT.write's temporary file is private (0600); data files are public
            # read it back through the verifying loader (hash, builder, parameters)
            back = LUT.read(path, builder=CUMULATIVE_CMF_BUILDER, parameters=lut.parameters)
            err = back.parameters["max_interp_error"]
            worst = max(worst, *err)
            x, y, z = back.values[-1].tolist()
            print(f"{path.name}: {back.parameters['nodes']} nodes, {path.stat().st_size / 1000:.1f} kB, "
                  f"max |interp - exact| X {err[0]:.3g} Y {err[1]:.3g} Z {err[2]:.3g}, "
                  f"white XYZ ({x:.6f}, {y:.6f}, {z:.6f})")
    print(f"worst measured interpolation error: {worst:.3g} (promise: 1e-6"
          + ("; not met with the --nodes given)" if worst > 1e-6 else ")"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
