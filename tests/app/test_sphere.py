"""Tests of torchirid.app.figures.spheres: spectral sphere renders of Hirayama 2000 Fig. 8 / Table 1.

References: colour-science (the lamp's SPD, the CIE 1931 CMFs for an independent Y of a smooth
sphere pixel, the Bradford adaptation taking the lamp white to D65), torchirid.multilayer
(the smooth limit), the chroma claim of Hirayama §6 reproduced on small renders, and the
``render-sphere`` CLI on a tiny image.
"""

from __future__ import annotations

import argparse
import math

import numpy as np
import pytest
import torch

import torchirid
from torchirid.app.commands import render_sphere
from torchirid.app.figures import spheres as sp

SMALL = dict(size=24, wavelength_step=10.0)


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    """Small renders are many tiny ops: on a shared 2-core machine 2 threads are ~50x slower."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


def test_lamp_spd_is_colour_science_scaled_to_white():
    import colour

    wl = torch.arange(380.0, 781.0, 5.0, dtype=torch.float64)
    S = sp.lamp_spd(wl, "FL11")
    ref = np.asarray(colour.SDS_ILLUMINANTS["FL11"].values, dtype=float)
    ratio = S.numpy() / ref
    assert np.allclose(ratio, ratio[0], rtol=1e-12)  # same shape as colour's table, one scale
    assert abs(float(torchirid.spectrum_to_xyz(S, wl, illuminant="E")[1]) - 1.0) < 1e-12
    with pytest.raises(ValueError, match="lamp"):
        sp.lamp_spd(wl, "D65")


def test_render_shapes_and_ranges():
    r = sp.render_sphere("Al", [(1.4, 1000.0), ("Ag", 5.0), (1.4, 1000.0)], 25.0, **SMALL)
    assert r.srgb.shape == (24, 24, 3) and r.lab.shape == (24, 24, 3)
    assert np.all((r.srgb >= 0) & (r.srgb <= 1))
    c = (np.arange(24) + 0.5) / 24 * 2 - 1
    radius = np.hypot(*np.meshgrid(c, c))
    assert np.all(r.srgb[radius >= 1 + 1 / 24] == 0) and np.all(np.isnan(r.lab[~r.mask]))
    # issue 22.8: an antialiased silhouette — rim pixels just outside the disc carry a fraction of
    # the colour, less than their inside neighbours (was a binary, jagged edge)
    rim = (radius >= 1) & (radius < 1 + 1 / 24)
    assert r.srgb[rim].max() > 0 and r.srgb[rim].sum(-1).mean() < r.srgb[r.mask].sum(-1).mean()
    assert np.all(r.lit <= r.mask) and r.lit.sum() > 0.3 * r.mask.sum()
    assert np.all(np.isfinite(r.lab[r.mask]))
    assert 0 < r.chroma_mean <= r.chroma_p95


def test_grey_object_is_neutral_after_adaptation():
    """A dispersion-free dielectric reflects the lamp white unchanged: a* = b* = 0 (Bradford → D65)."""
    r = sp.render_sphere(1.5, [], 0.0, coated=False, **SMALL)
    assert r.chroma_p95 < 1e-6


def test_smooth_pixel_luminance_vs_colour_science():
    """σ = 0, bare Al: Y of a pixel = ambient · ∫ R S ȳ / ∫ S ȳ (tmm-tested multilayer R, colour's CMFs)."""
    import colour

    step = 10.0
    r = sp.render_sphere("Al", [], 0.0, coated=False, size=24, wavelength_step=step, ambient=0.35)
    i, j = 12, 20  # a pixel right of the centre, away from the lamp's mirror image
    assert r.lit[i, j]
    c = (np.arange(24) + 0.5) / 24 * 2 - 1
    x, y = c[j], -c[i]
    cv = math.sqrt(1 - x * x - y * y)
    wl = np.arange(380.0, 780.0 + 1e-9, step)
    n = torchirid.materials.refractive_index("Al", torch.tensor(wl, dtype=torch.float64))
    R = torchirid.multilayer(torch.tensor(wl), torch.tensor(cv, dtype=torch.float64),
                             torch.stack([torch.ones_like(n), n], -1), torch.zeros(len(wl), 0, dtype=torch.float64))[0]
    S = np.interp(wl, colour.SDS_ILLUMINANTS["FL10"].wavelengths, colour.SDS_ILLUMINANTS["FL10"].values)
    ybar = np.interp(wl, colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].wavelengths,
                     colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].values[:, 1])
    Y = 0.35 * np.trapezoid(R.numpy() * S * ybar, wl) / np.trapezoid(S * ybar, wl)
    # L* from the render (after adaptation Y is unchanged to < 1e-3: Bradford keeps Y of white)
    L_ref = 116 * Y ** (1 / 3) - 16
    assert abs(r.lab[i, j, 0] - L_ref) < 0.05


def test_rough_sphere_has_a_diffuse_lobe_and_smooth_does_not():
    films = [(1.4, 1000.0), ("Ag", 5.0), (1.4, 1000.0)]
    smooth = sp.render_sphere("Al", films, 0.0, **SMALL)
    rough = sp.render_sphere("Al", films, 50.0, **SMALL)
    # near the light's mirror direction (but outside the lamp disk) the rough sphere is brighter
    L_s, L_r = smooth.lab[..., 0], rough.lab[..., 0]
    hi = rough.lit & (L_r > np.nanpercentile(L_r[rough.lit], 90))
    assert np.nanmean(L_r[hi]) > np.nanmean(L_s[hi]) + 5


def test_chroma_claim_reproduced_on_small_renders():
    """Hirayama §6: on aluminium the films look more iridescent on the rough spheres (Fig. 8 e, f vs d)."""
    panels = sp.render_panels({"Al/Ag": sp.FIG8_ROWS["aluminium / dielectric-Ag-dielectric (d-f)"]},
                              sigmas=(0.0, 25.0, 50.0), size=32, wavelength_step=5.0)
    coated_mean = panels.chroma[0, :, 0, 0]
    uncoated_mean = panels.chroma[0, :, 1, 0]
    assert coated_mean[1] > 2 * coated_mean[0] and coated_mean[2] > 2 * coated_mean[0]
    assert np.all(coated_mean > uncoated_mean)
    md = sp.chroma_table_markdown(panels)
    assert md.count("\n") == 2 + 3 - 1 and "| Al/Ag | 25 |" in md


def test_chroma_stats_validation():
    with pytest.raises(ValueError, match="no pixel"):
        sp.chroma_stats(np.zeros((2, 2, 3)), np.zeros((2, 2), bool))
    with pytest.raises(ValueError, match="lab must be"):
        sp.chroma_stats(np.zeros((2, 2, 2)), np.ones((2, 2), bool))


@pytest.mark.parametrize("kwargs, match", [(dict(size=4), "size"), (dict(sigma=-1.0), "sigma"),
                                           (dict(tau=0.0), "tau"), (dict(light=(0, 0, -1)), "light"),
                                           (dict(lamp="A"), "lamp"), (dict(wavelength_step=0.0), "wavelength_step")])
def test_render_validation(kwargs, match):
    args = dict(sigma=10.0, tau=300.0, size=16, wavelength_step=20.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        sp.render_sphere("Al", [], args.pop("sigma"), args.pop("tau"), **args)


def _parser():
    parser = argparse.ArgumentParser(prog="torchirid")
    sub = parser.add_subparsers(dest="command", required=True)
    render_sphere.add_parser(sub)
    return parser


def test_cli_tiny_render(tmp_path, capsys):
    args = _parser().parse_args(["render-sphere", "--preset", "custom", "--substrate", "Al", "--film", "Ag:5",
                                 "--film", "1.4:500", "--sigma", "0", "30", "--size", "12", "--wavelength-step", "25",
                                 "--out", str(tmp_path), "--name", "tiny"])
    assert args.func(args) == 0
    png, npz = tmp_path / "tiny.png", tmp_path / "tiny.npz"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with np.load(npz, allow_pickle=False) as z:
        assert z["images"].shape == (1, 2, 2, 12, 12, 3)
        assert z["chroma"].shape == (1, 2, 2, 2)
        assert list(z["sigmas_nm"]) == [0.0, 30.0]
    out = capsys.readouterr().out
    assert out.startswith("| stack | σ₀ (nm)") and "| Al custom | 30 |" in out


def test_cli_errors(tmp_path, capsys):
    (tmp_path / "a_file").write_text("x")
    args = _parser().parse_args(["render-sphere", "--size", "12", "--out", str(tmp_path / "a_file")])
    assert args.func(args) == 2
    args = _parser().parse_args(["render-sphere", "--size", "4", "--out", str(tmp_path)])
    assert args.func(args) == 2
    assert "size" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        _parser().parse_args(["render-sphere", "--film", "Ag"])


def test_presets_are_built_lazily_and_match_hirayama_stacks():
    """FIG8_ROWS / TABLE1_OBJECTS are built on first access (they load database pages), from hirayama_stacks()."""
    stacks = torchirid.presets.hirayama_stacks()
    rows = sp.fig8_rows()
    assert rows == sp.FIG8_ROWS and rows is not sp.fig8_rows()  # a new dict per call
    assert sp.FIG8_ROWS is sp.FIG8_ROWS  # the module attribute is built once
    assert sp.TABLE1_OBJECTS == sp.table1_objects()
    teapot = stacks["teapot"]
    assert sp.TABLE1_OBJECTS["teapot (Al)"] == (teapot.n_substrate, [(m, float(t)) for m, t in teapot.layers])
    assert sp.FIG8_ROWS["silicon / dielectric-Ag-dielectric (a-c)"][0] == stacks["fig8_abc_silicon_silver"].n_substrate
    assert sorted(render_sphere.PRESETS) == ["fig8", "table1"] and render_sphere.PRESETS["table1"]() == sp.TABLE1_OBJECTS
    with pytest.raises(AttributeError, match="NO_SUCH_PRESET"):
        sp.NO_SUCH_PRESET  # noqa: B018


def test_cli_creates_the_folder_prints_paths_and_writes_formats(tmp_path, capsys):
    """Issue 22.3/22.8: a missing --out folder is created, every written path is printed, and
    --format png,svg writes both figures."""
    out = tmp_path / "new" / "folder"
    args = _parser().parse_args(["render-sphere", "--preset", "custom", "--substrate", "1.5", "--film", "1.4:300",
                                 "--sigma", "0", "--size", "8", "--wavelength-step", "50", "--out", str(out),
                                 "--name", "s", "--format", "png,svg", "--quiet"])
    assert args.func(args) == 0
    printed = capsys.readouterr().out
    for name in ("s.png", "s.svg", "s.npz"):
        assert (out / name).is_file() and str(out / name) in printed
    assert (out / "s.svg").read_text().lstrip().startswith("<?xml")
