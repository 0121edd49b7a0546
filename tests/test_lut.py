"""Tests of torchirid.lut: the one LUT container (values + named axes + metadata)."""

from __future__ import annotations

import json
import os
import zipfile

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from torchirid.lut import EXTRAPOLATE_MODES, FORMAT_VERSION, LUT

F64 = torch.float64


def _t(x):
    return torch.as_tensor(x, dtype=F64)


def _cmf_like(n=41):
    """A 1-D cumulative-style table: axis omega (nm), channels X, Y, Z."""
    w = torch.linspace(380.0, 780.0, n, dtype=F64)
    vals = torch.stack([torch.sin(w / 50), torch.cos(w / 70), (w / 400) ** 2], -1)
    return LUT(vals, {"omega": w}, builder="tests/test_lut.py:_cmf_like",
               parameters={"n": n, "observer": "CIE 1931 2°", "range": (380.0, 780.0)},
               units={"omega": "nm", "values": "1"})


def _grid3():
    a = _t([0.0, 0.5, 1.5, 3.0])
    b = _t([-1.0, 0.0, 2.0])
    c = _t([10.0, 11.0, 13.0, 14.0, 20.0])
    return a, b, c


# ----------------------------------------------------------------------------- round trip
def test_round_trip_exact(tmp_path):
    lut = _cmf_like()
    path = lut.write(tmp_path / "cmf.npz")
    back = LUT.read(path, builder="tests/test_lut.py:_cmf_like",
                    parameters={"n": 41, "range": [380.0, 780.0]},
                    expect={"axes": ("omega",), "channels": (3,), "units": {"omega": "nm"}})
    assert torch.equal(back.values, lut.values) and back.values.dtype == F64
    assert list(back.axes) == ["omega"]
    assert torch.equal(back.axes["omega"], lut.axes["omega"])
    assert back.meta == lut.meta
    assert back.hash == lut.hash and len(lut.hash) == 64
    assert back.parameters["range"] == [380.0, 780.0]  # JSON-normalised at construction
    assert back.torchirid_version == lut.torchirid_version
    assert lut.meta["format_version"] == FORMAT_VERSION


@pytest.mark.parametrize("dtype", [torch.float16, torch.float32])
def test_round_trip_other_dtypes(tmp_path, dtype):
    lut = _cmf_like().to(dtype)
    back = LUT.read(lut.write(tmp_path / "x.npz"))
    assert back.values.dtype == dtype and torch.equal(back.values, lut.values)
    assert back.hash == lut.hash != _cmf_like().hash  # the hash identifies the dtype too


def test_load_dtype_conversion(tmp_path):
    lut = _cmf_like()
    back = LUT.read(lut.write(tmp_path / "x.npz"), dtype=torch.float32)
    assert back.dtype == torch.float32 and back.axes["omega"].dtype == torch.float32
    assert torch.allclose(back.values.double(), lut.values, rtol=1e-6)


def test_saved_file_has_no_pickle(tmp_path):
    path = _cmf_like().write(tmp_path / "x.npz")
    with np.load(path, allow_pickle=False) as z:
        assert sorted(z.files) == ["axis_0", "meta", "values"]
        for name in z.files:
            assert z[name].dtype.kind in "fu", name  # nothing object-typed
        meta = json.loads(z["meta"].tobytes().decode("utf-8"))
    assert meta["builder"] == "tests/test_lut.py:_cmf_like"
    with zipfile.ZipFile(path) as zf:
        for info in zf.infolist():
            assert b"'descr': '|O'" not in zf.read(info.filename)[:128]


def test_save_requires_npz_suffix(tmp_path):
    with pytest.raises(ValueError, match=r"\.npz"):
        _cmf_like().write(tmp_path / "x.safetensors")
    assert not os.listdir(tmp_path)


# ----------------------------------------------------------------------------- atomicity
def _failing_savez(*args, **kwargs):
    f = args[0]
    f.write(b"PK\x03\x04 partial garbage")  # a half-written archive, then a crash
    raise OSError("disk full (simulated)")


def test_atomic_write_failure_leaves_no_file(tmp_path, monkeypatch):
    monkeypatch.setattr(np, "savez", _failing_savez)
    with pytest.raises(OSError, match="simulated"):
        _cmf_like().write(tmp_path / "x.npz")
    assert os.listdir(tmp_path) == []  # neither target nor temporary file


def test_atomic_write_failure_keeps_existing_target(tmp_path, monkeypatch):
    path = _cmf_like().write(tmp_path / "x.npz")
    before = path.read_bytes()
    monkeypatch.setattr(np, "savez", _failing_savez)
    other = LUT(torch.zeros(2, 3, dtype=F64), {"omega": _t([0.0, 1.0])}, builder="other")
    with pytest.raises(OSError, match="simulated"):
        other.write(path)
    assert path.read_bytes() == before
    assert os.listdir(tmp_path) == ["x.npz"]
    monkeypatch.undo()
    assert LUT.read(path).hash == _cmf_like().hash


# ----------------------------------------------------------------------------- corruption
def _assert_corrupt(path, match="corrupt"):
    with pytest.raises(ValueError) as info:
        LUT.read(path)
    msg = str(info.value)
    assert match in msg.lower() and str(path) in msg, msg


def test_flipped_byte_in_values(tmp_path):
    lut = _cmf_like()
    path = lut.write(tmp_path / "x.npz")
    raw = bytearray(path.read_bytes())
    at = raw.find(lut.values.numpy().tobytes())
    assert at > 0
    raw[at + 77] ^= 0x10
    path.write_bytes(bytes(raw))
    _assert_corrupt(path)  # caught by the zip CRC


def _rewrite(path, **changes):
    """Rewrite the archive with some members replaced (valid zip, stale hash)."""
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(changes)
    with open(path, "wb") as f:
        np.savez(f, **arrays)


def _meta_array(path, **edits):
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(z["meta"].tobytes())
    meta.update(edits)
    return np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)


def test_tampered_values_hash_mismatch(tmp_path):
    lut = _cmf_like()
    path = lut.write(tmp_path / "x.npz")
    vals = lut.values.numpy().copy()
    vals[3, 1] = np.nextafter(vals[3, 1], 2.0)  # one ulp
    _rewrite(path, values=vals)
    _assert_corrupt(path, match="content hash mismatch")


def test_tampered_axis_and_meta_hash_mismatch(tmp_path):
    lut = _cmf_like()
    path = lut.write(tmp_path / "x.npz")
    _rewrite(path, axis_0=lut.axes["omega"].numpy() + 1.0)
    _assert_corrupt(path, match="content hash mismatch")
    path = lut.write(tmp_path / "y.npz")
    _rewrite(path, meta=_meta_array(path, builder="someone else"))
    _assert_corrupt(path, match="content hash mismatch")
    path = lut.write(tmp_path / "z.npz")
    _rewrite(path, meta=_meta_array(path, dtype="float32"))  # meta disagrees with arrays
    _assert_corrupt(path, match="corrupt")


def test_future_format_version_refused(tmp_path):
    path = _cmf_like().write(tmp_path / "x.npz")
    _rewrite(path, meta=_meta_array(path, format_version=FORMAT_VERSION + 1))
    with pytest.raises(ValueError, match="format_version") as info:
        LUT.read(path)
    assert str(path) in str(info.value) and str(FORMAT_VERSION + 1) in str(info.value)


@pytest.mark.parametrize("kind", ["truncated", "garbage", "empty", "plain_npy", "foreign_npz"])
def test_unreadable_files(tmp_path, kind):
    path = _cmf_like().write(tmp_path / "x.npz")
    raw = path.read_bytes()
    if kind == "truncated":
        path.write_bytes(raw[: len(raw) // 2])
    elif kind == "garbage":
        path.write_bytes(np.random.default_rng(0).bytes(400))
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "plain_npy":
        with open(path, "wb") as f:
            np.save(f, np.arange(3.0))
    else:
        with open(path, "wb") as f:
            np.savez(f, values=np.arange(3.0), meta=np.frombuffer(b'{"a": 1}', np.uint8))
    _assert_corrupt(path)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError):
        LUT.read(tmp_path / "nope.npz")


# ----------------------------------------------------------------------------- expectations
@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"builder": "luts/other.py:build"}, "builder"),
        ({"parameters": {"n": 42}}, "parameters['n']"),
        ({"parameters": {"missing_key": 1}}, "parameters['missing_key']"),
        ({"parameters": {"range": (380.0, 781.0)}}, "parameters['range']"),
        ({"expect": {"axes": ("omega", "cos_theta")}}, "axes"),
        ({"expect": {"axes": ("wavelength",)}}, "axes"),
        ({"expect": {"channels": (4,)}}, "channels"),
        ({"expect": {"units": {"omega": "um"}}}, "units['omega']"),
    ],
)
def test_mismatch_refused(tmp_path, kwargs, field):
    path = _cmf_like().write(tmp_path / "x.npz")
    with pytest.raises(ValueError) as info:
        LUT.read(path, **kwargs)
    msg = str(info.value)
    assert field in msg and "expected" in msg and "found" in msg and str(path) in msg, msg


def test_unknown_expect_key(tmp_path):
    path = _cmf_like().write(tmp_path / "x.npz")
    with pytest.raises(ValueError, match="expect"):
        LUT.read(path, expect={"axis": ("omega",)})


# ----------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    "values, axes, match",
    [
        (torch.zeros(3), {"x": torch.zeros(3, 1)}, "1-D"),
        (torch.zeros(3), {"x": [0.0, 2.0, 1.0]}, "strictly increasing"),
        (torch.zeros(3), {"x": [0.0, 1.0, 1.0]}, "strictly increasing"),
        (torch.zeros(3), {"x": [0.0, float("nan"), 2.0]}, "NaN"),
        (torch.zeros(3), {"x": [0.0, 1.0, float("inf")]}, "infinite"),
        (torch.zeros(3), {"x": [0.0, 1.0]}, "2 nodes but values has 3"),
        (torch.zeros(1), {"x": [0.0]}, "at least 2"),
        (torch.zeros(3), {}, "at least one axis"),
        (torch.zeros(3), {"x": [0.0, 1.0, 2.0], "y": [0.0, 1.0]}, "dims but 2 axes"),
        (torch.zeros(3, dtype=torch.int64), {"x": [0.0, 1.0, 2.0]}, "floating"),
        (torch.zeros(3), {"not an id": [0.0, 1.0, 2.0]}, "identifier"),
        (torch.zeros(3), {"extrapolate": [0.0, 1.0, 2.0]}, "reserved"),
        (torch.zeros(3), {"x": torch.zeros(3, dtype=torch.complex64)}, "real"),
    ],
)
def test_bad_axes(values, axes, match):
    with pytest.raises(ValueError, match=match):
        LUT(values, axes, builder="t")


def test_axis_collapsing_in_lower_precision():
    # 1 and 1 + 1e-9 are distinct in float64 but equal in float32
    with pytest.raises(ValueError, match="strictly increasing"):
        LUT(torch.zeros(3), {"x": _t([0.0, 1.0, 1.0 + 1e-9])}, builder="t")


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"builder": ""}, "builder"),
        ({"builder": 3}, "builder"),
        ({"builder": "t", "parameters": [1, 2]}, "parameters must be a dict"),
        ({"builder": "t", "parameters": {"a": torch.ones(2)}}, "JSON"),
        ({"builder": "t", "parameters": {"a": float("nan")}}, "JSON"),
        ({"builder": "t", "units": {"y": "nm"}}, "neither an axis"),
        ({"builder": "t", "units": {"x": 1.0}}, "string"),
    ],
)
def test_bad_metadata(kwargs, match):
    with pytest.raises(ValueError, match=match):
        LUT(torch.zeros(3), {"x": [0.0, 1.0, 2.0]}, **kwargs)


def test_properties_and_repr():
    lut = _cmf_like()
    r = repr(lut)
    assert "omega: 41 in [380, 780]" in r and "channels=(3,)" in r and "float64" in r
    assert lut.axis_names == ("omega",) and lut.channel_shape == (3,)
    assert lut.units == {"omega": "nm", "values": "1"}
    m = lut.meta
    m["builder"] = "changed"  # meta is a copy
    assert lut.meta["builder"] == "tests/test_lut.py:_cmf_like"
    h = lut.hash
    with torch.no_grad():
        lut.values[0, 0] += 1.0  # in-place edit: the cached hash must not go stale
    assert lut.hash != h


# ----------------------------------------------------------------------------- interpolation
def test_exact_on_nodes():
    a, b, c = _grid3()
    vals = torch.randn(4, 3, 5, 2, dtype=F64, generator=torch.Generator().manual_seed(1))
    lut = LUT(vals, {"a": a, "b": b, "c": c}, builder="t")
    A, B, C = torch.meshgrid(a, b, c, indexing="ij")
    out = lut(a=A, b=B, c=C)
    assert out.shape == (4, 3, 5, 2)
    assert torch.equal(out, vals)  # bitwise exact, including the last node of each axis
    l1 = _cmf_like()
    assert torch.equal(l1(omega=l1.axes["omega"]), l1.values)


def _affine_lut(k):
    grids = [torch.sort(torch.rand(n, dtype=F64, generator=torch.Generator().manual_seed(n)))[0]
             * 4 - 1 for n in (5, 4, 6)[:k]]
    coef = _t([[1.5, -2.0], [0.25, 3.0], [-0.75, 0.5]])[:k]
    mesh = torch.meshgrid(*grids, indexing="ij")
    # two channels, each multi-affine: a0 + sum_i c_i x_i + (for k >= 2) x_0 x_1
    vals = torch.stack([
        0.3 + sum(coef[i, ch] * mesh[i] for i in range(k)) + (mesh[0] * mesh[1] if k >= 2 else 0)
        for ch in range(2)], -1)
    names = ["x", "y", "z"][:k]

    def f(*xs):
        return torch.stack([
            0.3 + sum(coef[i, ch] * xs[i] for i in range(k)) + (xs[0] * xs[1] if k >= 2 else 0)
            for ch in range(2)], -1)

    return LUT(vals, dict(zip(names, grids)), builder="t"), grids, f


@pytest.mark.parametrize("k", [1, 2, 3])
def test_exact_for_multiaffine(k):
    lut, grids, f = _affine_lut(k)
    gen = torch.Generator().manual_seed(k)
    xs = [g[0] + (g[-1] - g[0]) * torch.rand(200, dtype=F64, generator=gen) for g in grids]
    assert torch.allclose(lut(*xs), f(*xs), rtol=0, atol=1e-12)
    # linear extrapolation reproduces affine (per-axis) functions outside the grid as well
    far = [g[-1] + 0.7 + torch.rand(50, dtype=F64, generator=gen) for g in grids]
    if k == 1:
        assert torch.allclose(lut(*far, extrapolate="linear"), f(*far), rtol=0, atol=1e-12)


def test_matches_numpy_interp_1d():
    rng = np.random.default_rng(3)
    grid = np.sort(rng.uniform(0, 10, 30))
    vals = rng.normal(size=30)
    lut = LUT(torch.from_numpy(vals), {"x": torch.from_numpy(grid)}, builder="t")
    x = rng.uniform(grid[0] - 1, grid[-1] + 1, 1000)  # np.interp clamps, as does the default
    np.testing.assert_allclose(lut(x=torch.from_numpy(x)).numpy(), np.interp(x, grid, vals),
                               rtol=0, atol=1e-13)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1e3, 1e3), min_size=2, max_size=12, unique=True),
       st.lists(st.floats(-2e3, 2e3), min_size=1, max_size=8))
def test_matches_numpy_interp_property(nodes, points):
    grid = np.sort(np.array(nodes))
    if np.any(np.diff(grid) < 1e-6 * (1 + np.abs(grid[1:]))):
        return  # near-duplicate nodes make the reference itself ill-conditioned
    vals = np.cos(grid / 100.0)
    lut = LUT(torch.from_numpy(vals), {"x": torch.from_numpy(grid)}, builder="t")
    out = lut(torch.tensor(points, dtype=F64)).numpy()
    np.testing.assert_allclose(out, np.interp(points, grid, vals), rtol=0, atol=1e-12)


@pytest.mark.parametrize("k", [2, 3])
def test_matches_scipy_regular_grid(k):
    interpolate = pytest.importorskip("scipy.interpolate")
    rng = np.random.default_rng(k)
    grids = [np.sort(rng.uniform(0, 5, n)) for n in (7, 5, 4)[:k]]
    vals = rng.normal(size=tuple(len(g) for g in grids) + (3,))
    ref = interpolate.RegularGridInterpolator(grids, vals, method="linear")
    pts = np.stack([rng.uniform(g[0], g[-1], 300) for g in grids], -1)
    lut = LUT(torch.from_numpy(vals), {f"x{i}": torch.from_numpy(g) for i, g in enumerate(grids)},
              builder="t")
    out = lut(*[torch.from_numpy(pts[:, i]) for i in range(k)]).numpy()
    np.testing.assert_allclose(out, ref(pts), rtol=0, atol=1e-12)


def test_broadcasting_and_channels():
    a, b, c = _grid3()
    lut = LUT(torch.rand(4, 3, 2, 5, dtype=F64), {"a": a, "b": b}, builder="t")
    out = lut(a=torch.rand(5, 1, dtype=F64), b=torch.rand(1, 7, dtype=F64))
    assert out.shape == (5, 7, 2, 5)
    assert lut(a=1.0, b=torch.zeros(3, dtype=F64)).shape == (3, 2, 5)
    assert lut(a=1.0, b=0.5).shape == (2, 5)
    # each batch element equals the scalar lookup
    xa, xb = _t([[0.2], [2.9]]), _t([-0.5, 1.0, 1.9])
    out = lut(a=xa, b=xb)
    for i in range(2):
        for j in range(3):
            assert torch.equal(out[i, j], lut(a=xa[i, 0], b=xb[j]))
    # 1-D table without channels, N-D coordinates
    l0 = LUT(a ** 2, {"a": a}, builder="t")
    assert l0(a=torch.rand(2, 3, 4, dtype=F64)).shape == (2, 3, 4)
    with pytest.raises(ValueError, match="broadcast"):
        lut(a=torch.zeros(2, dtype=F64), b=torch.zeros(3, dtype=F64))


def test_coordinate_argument_errors():
    lut, _, _ = _affine_lut(2)
    with pytest.raises(ValueError, match="unknown axis 'q'"):
        lut(x=0.0, y=0.0, q=1.0)
    with pytest.raises(ValueError, match="missing coordinate"):
        lut(x=0.0)
    with pytest.raises(ValueError, match="both positionally and by name"):
        lut(0.0, x=0.0)
    with pytest.raises(ValueError, match="complex"):
        lut(x=torch.zeros(2, dtype=torch.complex128), y=0.0)
    with pytest.raises(ValueError, match="extrapolate must be one of"):
        lut(x=0.0, y=0.0, extrapolate="nearest")
    assert set(EXTRAPOLATE_MODES) == {"clamp", "error", "linear"}


def test_dtype_device_follow_values():
    lut = _cmf_like().to(torch.float32)
    out = lut(omega=torch.tensor([500.0], dtype=F64))
    assert out.dtype == torch.float32
    ref = _cmf_like()(omega=_t([500.0])).float()
    assert torch.allclose(out, ref, rtol=1e-5, atol=1e-6)


def test_nan_propagates():
    lut, _, _ = _affine_lut(2)
    out = lut(x=_t([float("nan"), 0.0]), y=_t([0.0, 0.0]))
    assert torch.isnan(out[0]).all() and torch.isfinite(out[1]).all()
    out = lut(x=_t([float("nan")]), y=_t([0.0]), extrapolate="error")  # NaN is not "out of range"
    assert torch.isnan(out).all()


# ----------------------------------------------------------------------------- extrapolation
def test_extrapolate_clamp():
    lut = _cmf_like()
    x = _t([300.0, 379.0, 800.0, 1e6]).requires_grad_(True)
    out = lut(omega=x)
    v = lut.values
    assert torch.equal(out[:2], v[[0, 0]]) and torch.equal(out[2:], v[[-1, -1]])
    out.sum().backward()
    assert torch.equal(x.grad, torch.zeros(4, dtype=F64))  # zero gradient outside


def test_extrapolate_error_names_axis():
    lut, grids, _ = _affine_lut(2)
    lut(x=grids[0][-1], y=grids[1][0], extrapolate="error")  # the edges are inside
    with pytest.raises(ValueError, match=r"coordinate 'y' outside the LUT range \[") as info:
        lut(x=grids[0][0], y=grids[1][-1] + 0.5, extrapolate="error")
    assert f"{float(grids[1][-1]):.6g}" in str(info.value)


def test_extrapolate_linear():
    x = _t([0.0, 1.0, 3.0])
    lut = LUT(torch.stack([x ** 2, -x], -1), {"x": x}, builder="t")  # values (0,0) (1,-1) (9,-3)
    out = lut(x=_t([-1.0, 4.0]), extrapolate="linear")
    # left cell slope (1, -1): -1 → (-1, 1); right cell slope (4, -1): 4 → (13, -4)
    assert torch.allclose(out, _t([[-1.0, 1.0], [13.0, -4.0]]), rtol=0, atol=1e-14)
    lut2, grids, f = _affine_lut(2)
    pts = [grids[0][0] - _t([0.3, 2.0]), grids[1][-1] + _t([1.0, 0.1])]
    assert torch.allclose(lut2(*pts, extrapolate="linear"), f(*pts), rtol=0, atol=1e-12)


# ----------------------------------------------------------------------------- gradients
def _interior_points(grids, n, seed):
    """Random points strictly inside cells (away from nodes, where the derivative jumps)."""
    gen = torch.Generator().manual_seed(seed)
    pts = []
    for g in grids:
        cell = torch.randint(0, len(g) - 1, (n,), generator=gen)
        frac = 0.1 + 0.8 * torch.rand(n, dtype=F64, generator=gen)
        pts.append(g[cell] + frac * (g[cell + 1] - g[cell]))
    return pts


@pytest.mark.parametrize("k", [1, 2, 3])
def test_gradcheck_coordinates(k):
    a, b, c = _grid3()
    grids = [a, b, c][:k]
    vals = torch.randn(*[len(g) for g in grids], 2, dtype=F64,
                       generator=torch.Generator().manual_seed(k))
    lut = LUT(vals, {f"x{i}": g for i, g in enumerate(grids)}, builder="t")
    pts = [p.requires_grad_(True) for p in _interior_points(grids, 4, seed=10 + k)]
    assert torch.autograd.gradcheck(lambda *xs: lut(*xs), pts)
    assert torch.autograd.gradcheck(lambda *xs: lut(*xs, extrapolate="linear"),
                                    [(p + 10.0).detach().requires_grad_(True) for p in pts])


@pytest.mark.parametrize("k", [1, 2, 3])
def test_gradcheck_values(k):
    a, b, c = _grid3()
    grids = [a, b, c][:k]
    vals = torch.randn(*[len(g) for g in grids], 2, dtype=F64,
                       generator=torch.Generator().manual_seed(k)).requires_grad_(True)
    pts = _interior_points(grids, 5, seed=20 + k)
    # include exact nodes and an out-of-range (clamped) point too: linear in values everywhere
    pts = [torch.cat([p, g[[0, -1]], g[-1:] + 1.0]) for p, g in zip(pts, grids)]
    axes = {f"x{i}": g for i, g in enumerate(grids)}
    assert torch.autograd.gradcheck(lambda v: LUT(v, axes, builder="t")(*pts), (vals,))


def test_gradient_values_value():
    """d lut(x) / d values is the hat-function weights: checked by hand in 1-D."""
    x = _t([0.0, 1.0, 2.0])
    v = torch.zeros(3, dtype=F64, requires_grad=True)
    LUT(v, {"x": x}, builder="t")(x=_t(0.25)).backward()
    assert torch.equal(v.grad, _t([0.75, 0.25, 0.0]))


def test_gradient_at_nodes_uses_right_cell():
    """Documented convention: a node belongs to the cell on its right (the last node to the
    last cell), so the coordinate derivative at a node is that cell's slope."""
    x = _t([0.0, 1.0, 3.0])
    lut = LUT(_t([0.0, 1.0, 9.0]), {"x": x}, builder="t")  # slopes 1 then 4
    c = _t([0.0, 1.0, 3.0]).requires_grad_(True)
    lut(x=c, extrapolate="linear").sum().backward()
    assert torch.equal(c.grad, _t([1.0, 4.0, 4.0]))
