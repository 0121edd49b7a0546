#!/usr/bin/env python
r"""(Re)build the CIE tables that torchirid reads at run time, copied from colour-science.

Every registered observer's colour matching functions (``torchirid.color.OBSERVERS``: CIE 1931
2°, CIE 1964 10°, Stiles & Burch 1959 10° in XYZ and in RGB) and every registered
illuminant's relative spectral power distribution (``torchirid.color.ILLUMINANTS``: D65, D50,
A, E), as float64 arrays taken from ``colour.MSDS_CMFS`` / ``colour.SDS_ILLUMINANTS`` (the XYZ
functions of Stiles & Burch are ``colour.colorimetry.RGB_10_degree_cmfs_to_XYZ_10_degree_cmfs``
of its tabulated wavelengths), written atomically to ``src/torchirid/data/cie_tables.npz``,
where ``torchirid.color.colorimetry`` reads them (the format is described in
``torchirid/color/_tables.py``). Nothing is computed: the file holds colour-science's numbers,
so ``import torchirid`` and the first colour need not import colour-science (which imports
matplotlib and scipy). tests/color/test_cie_tables.py checks the shipped file equals
colour-science exactly.

Reproducible: the content hash stored in the file (SHA-256 of the metadata and the arrays)
depends only on colour-science's numbers and version; the script reads the file back through
the verifying loader and prints it::

    PYTHONPATH=src python luts/build_cie_tables.py
    PYTHONPATH=src python luts/build_cie_tables.py --out /tmp/cie_tables.npz
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from torchirid.color import ILLUMINANTS, OBSERVERS
from torchirid.color import _tables
from torchirid.color.colorimetry import _ILLUMINANT_KEYS, _OBSERVER_KEYS, _RGB_OBSERVERS

DEFAULT_OUT = _tables.PATH


def tables() -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """``(arrays, sources)``: every registered table from colour-science, by member name."""
    arrays, sources = {}, {}
    for observer in OBSERVERS:
        spaces = ("XYZ", "RGB") if observer in _RGB_OBSERVERS else ("XYZ",)
        for space in spaces:
            wl, values, source = _tables.colour_cmfs(_OBSERVER_KEYS[observer],
                                                     rgb_to_xyz=observer in _RGB_OBSERVERS and space == "XYZ")
            stem = _tables.cmfs_member(observer, space)
            arrays[stem + "_wl"], arrays[stem + "_values"] = wl, values
            sources[stem] = source
    for name in ILLUMINANTS:
        wl, values, source = _tables.colour_illuminant(_ILLUMINANT_KEYS[name])
        stem = _tables.illuminant_member(name)
        arrays[stem + "_wl"], arrays[stem + "_values"] = wl, values
        sources[stem] = source
    return arrays, sources


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help="output file (default: the package's data/cie_tables.npz)")
    args = parser.parse_args(argv)

    import colour  # noqa: PLC0415  (its version goes in the metadata)

    arrays, sources = tables()
    meta = {"format": _tables.FORMAT, "builder": _tables.BUILDER, "colour_science": colour.__version__,
            "sources": sources}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    path = _tables.write(args.out, arrays, meta)
    back, meta_back = _tables.read(path)  # read back through the verifying loader
    assert back.keys() == arrays.keys() and all(np.array_equal(back[k], arrays[k]) for k in arrays)
    for stem in sources:
        wl, v = back[stem + "_wl"], back[stem + "_values"]
        print(f"{stem:<36} {wl[0]:.0f}–{wl[-1]:.0f} nm, {wl.size} rows, values {v.shape}")
    print(f"{path} ({path.stat().st_size / 1000:.1f} kB), colour-science {meta_back['colour_science']}, "
          f"content hash {meta_back['hash']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
