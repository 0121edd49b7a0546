"""The shipped CIE tables (``src/torchirid/data/cie_tables.npz``, built by
``luts/build_cie_tables.py``) are colour-science's numbers, exactly.

colour-science stays the oracle: every registered observer (in each of its spaces) and
illuminant must be in the file, bit-for-bit equal to ``colour.MSDS_CMFS`` /
``colour.SDS_ILLUMINANTS`` (and colour's RGB→XYZ transform of Stiles & Burch); a table that
is not in the file comes from colour-science itself; a damaged file is refused.
"""

from __future__ import annotations

import json
import zipfile

import colour
import numpy as np
import pytest

from torchirid.color import ILLUMINANTS, OBSERVERS, cmfs, illuminant_spd
from torchirid.color import _tables
from torchirid.color.colorimetry import _ILLUMINANT_KEYS, _OBSERVER_KEYS, _RGB_OBSERVERS
from torchirid._cache import clear_caches

CMFS_CASES = [(o, s) for o in OBSERVERS for s in (("XYZ", "RGB") if o in _RGB_OBSERVERS else ("XYZ",))]


@pytest.fixture(scope="module")
def shipped():
    assert _tables.PATH.is_file(), f"{_tables.PATH} missing: run luts/build_cie_tables.py"
    return _tables.read(_tables.PATH)


@pytest.mark.parametrize("observer, space", CMFS_CASES)
def test_shipped_cmfs_equal_colour_science(shipped, observer, space):
    arrays, _ = shipped
    stem = _tables.cmfs_member(observer, space)
    data = colour.MSDS_CMFS[_OBSERVER_KEYS[observer]]
    if observer in _RGB_OBSERVERS and space == "XYZ":
        expected = colour.colorimetry.RGB_10_degree_cmfs_to_XYZ_10_degree_cmfs(data.wavelengths)
    else:
        expected = data.values
    for got, want in ((arrays[stem + "_wl"], data.wavelengths), (arrays[stem + "_values"], expected)):
        assert got.dtype == np.float64 and got.shape == np.shape(want)
        np.testing.assert_array_equal(got, want)  # exact: copied, never retyped


@pytest.mark.parametrize("name", ILLUMINANTS)
def test_shipped_illuminants_equal_colour_science(shipped, name):
    arrays, _ = shipped
    stem = _tables.illuminant_member(name)
    sd = colour.SDS_ILLUMINANTS[_ILLUMINANT_KEYS[name]]
    np.testing.assert_array_equal(arrays[stem + "_wl"], sd.wavelengths)
    np.testing.assert_array_equal(arrays[stem + "_values"], sd.values)


def test_file_holds_exactly_the_registered_tables(shipped):
    arrays, meta = shipped
    stems = [_tables.cmfs_member(o, s) for o, s in CMFS_CASES] + [_tables.illuminant_member(n) for n in ILLUMINANTS]
    assert sorted(arrays) == sorted(f"{s}_{k}" for s in stems for k in ("wl", "values"))
    assert sorted(meta["sources"]) == sorted(stems)
    assert meta["builder"] == "luts/build_cie_tables.py" and meta["format"] == _tables.FORMAT


def test_build_is_reproducible(shipped, tmp_path):
    """The builder's tables and content hash equal the shipped file's (same colour-science)."""
    from importlib import util
    from pathlib import Path

    script = Path(__file__).resolve().parents[2] / "luts" / "build_cie_tables.py"
    spec = util.spec_from_file_location("build_cie_tables", script)
    mod = util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.main(["--out", str(tmp_path / "t.npz")]) == 0
    arrays, meta = _tables.read(tmp_path / "t.npz")
    if meta["colour_science"] != shipped[1]["colour_science"]:
        pytest.skip("another colour-science version than the shipped file's: the content test above decides")
    assert meta["hash"] == shipped[1]["hash"]


def test_unshipped_table_comes_from_colour_science(tmp_path, monkeypatch):
    """Without the file (or without a table in it) the getters read colour-science: same numbers."""
    shipped_values = {o: cmfs(o)[1] for o in OBSERVERS}, {n: illuminant_spd(n)[1] for n in ILLUMINANTS}
    monkeypatch.setattr(_tables, "PATH", tmp_path / "absent.npz")
    clear_caches()
    try:
        for o in OBSERVERS:
            assert cmfs(o)[1].equal(shipped_values[0][o])
        for n in ILLUMINANTS:
            assert illuminant_spd(n)[1].equal(shipped_values[1][n])
        assert _tables.shipped(_tables.illuminant_member("D65")) is None
    finally:
        monkeypatch.undo()
        clear_caches()


def test_damaged_file_is_refused(tmp_path):
    arrays, meta = _tables.read(_tables.PATH)
    arrays = dict(arrays)
    arrays["illuminant_d65_values"] = arrays["illuminant_d65_values"].copy()
    arrays["illuminant_d65_values"][10] += 1e-12
    bad = tmp_path / "bad.npz"
    members = {**arrays, "meta": np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)}
    np.savez(bad, **members)
    with pytest.raises(ValueError, match="content hash mismatch"):
        _tables.read(bad)
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="junk.npz.*corrupt"):
        _tables.read(tmp_path / "junk.npz")
    with zipfile.ZipFile(tmp_path / "foreign.npz", "w") as z:
        z.writestr("meta.npy", b"")
    with pytest.raises(ValueError, match="foreign.npz"):
        _tables.read(tmp_path / "foreign.npz")
