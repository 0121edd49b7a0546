"""``torchirid montecarlo`` shows multiple scattering (issue 35.3): structures where the full light
transport differs from the single-reflection BRDF (a reflective base, several layers, a coating),
the standard error and eq. 34 beside the estimate; on those the estimate changes with the seed
and its standard error falls as 1/√samples, and where eq. 34 is exact the estimate is eq. 34."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from torchirid.app import cli
from torchirid.layered import single_reflection_brdf
from torchirid.presets import fourneau_fig7

DIRECTIONS = ["--incident", "30", "0", "--exit", "0", "0", "--exit", "45", "180", "--exit", "60", "90"]


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    # many small elementwise ops per block: intra-op threads only add synchronisation
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


def _run(capsys, tmp_path, *argv, name="mc.json"):
    out = tmp_path / name
    status = cli.main(["montecarlo", *DIRECTIONS, "--quiet", "--out", str(out), *argv])
    assert status == 0
    text = capsys.readouterr().out
    if out.suffix == ".json":
        data = json.loads(out.read_text())
        return {k: np.asarray(data[k]) for k in ("brdf", "stderr", "single_reflection", "wavelength_nm")}, data, text
    return np.load(out), None, text


def test_exact_where_every_path_reflects_once(capsys, tmp_path):
    # a preset alone: one rough layer in air over a black base, where eq. 34 is exact; the
    # estimate is eq. 34 for any seed, sample count and transmission mode, standard error 0
    a, data, text = _run(capsys, tmp_path, "--preset", "green", "--samples", "64", "--blocks", "4")
    b, _, _ = _run(capsys, tmp_path, "--preset", "green", "--samples", "32", "--blocks", "2", "--seed", "7",
                   "--transmission", "microfacet", name="b.json")
    np.testing.assert_allclose(a["brdf"], a["single_reflection"], rtol=1e-12, atol=0)
    np.testing.assert_allclose(b["brdf"], a["brdf"], rtol=1e-12, atol=0)
    assert (a["stderr"] <= 1e-12 * a["brdf"]).all() and (a["brdf"] > 0).all()
    assert data["settings"]["layers"] == 1 and data["settings"]["base_albedo"] == 0.0
    assert "reflects exactly once" in text and "--base-albedo" in text
    assert text.count("—") == 3 * 7  # no z-score where there is no noise


def test_multiple_scattering_shows_and_changes_with_the_seed(capsys, tmp_path):
    # Fig. 7's A, two layers over a diffuse base ρd = 0.5: light between the layers and the base
    argv = ["--preset", "fig7_a", "--layers", "2", "--base-albedo", "0.5", "--samples", "2048", "--blocks", "8"]
    a, data, text = _run(capsys, tmp_path, *argv)
    b, _, _ = _run(capsys, tmp_path, *argv, "--seed", "1", name="b.json")
    c, _, _ = _run(capsys, tmp_path, *argv, name="c.json")
    assert np.array_equal(a["brdf"], c["brdf"]) and np.array_equal(a["stderr"], c["stderr"])  # same seed, same bits
    assert (a["stderr"] > 0).all()
    m, _, _ = _run(capsys, tmp_path, *argv, "--transmission", "microfacet", name="m.json")
    for other in (b, m):  # another seed, the other transmission sampling: the same expectation
        assert (a["brdf"] != other["brdf"]).all()
        assert (np.abs(a["brdf"] - other["brdf"]) / np.hypot(a["stderr"], other["stderr"])).max() < 4.5
    # the single-reflection model beside it, as the library computes it; the difference is
    # multiple scattering, never negative beyond the noise, many standard errors in places
    s = fourneau_fig7("a", layers=2, base_albedo=0.5)
    wi, wo = torch.tensor(data["wi"], dtype=torch.float64), torch.tensor(data["wo"], dtype=torch.float64)
    lam = torch.tensor(data["wavelength_nm"], dtype=torch.float64)
    np.testing.assert_allclose(a["single_reflection"], single_reflection_brdf(lam, wi, wo, s).numpy(), rtol=1e-12)
    excess = (a["brdf"] - a["single_reflection"]) / a["stderr"]
    assert excess.min() > -4.5 and excess.max() > 6 and np.median(excess) > 3
    assert data["settings"]["layers"] == 2 and data["settings"]["base_albedo"] == 0.5
    assert "multiple scattering: the estimate exceeds eq. 34 by up to" in text
    lines = text.splitlines()
    assert "eq. 34" in lines[1] and "± SE" in lines[1] and len(lines) == 2 + 3 * 7 + 2


def test_stderr_falls_as_inverse_sqrt_samples(capsys, tmp_path):
    # one layer of A over a diffuse base: 4× the paths, half the standard error
    argv = ["--preset", "fig7_a", "--base-albedo", "0.5", "--blocks", "8", "--seed", "3"]
    a, _, _ = _run(capsys, tmp_path, *argv, "--samples", "2048")
    b, _, _ = _run(capsys, tmp_path, *argv, "--samples", "8192", name="b.json")
    ratio = np.median(b["stderr"] / a["stderr"])
    assert 0.4 <= ratio <= 0.6, ratio  # 1/2; excludes 1/√2 (∝ samples^-1/4) and 1/4 (∝ 1/samples)
    assert np.abs(a["brdf"] - b["brdf"]).max() > 0
    assert (np.abs(a["brdf"] - b["brdf"]) < 4.5 * np.hypot(a["stderr"], b["stderr"])).all()


def test_coated_preset_and_npz(capsys, tmp_path):
    # A′ under a coating of index 1.35 over a black base: total internal reflection at the
    # coating sends light back onto the layer (a little multiple scattering, no base needed)
    f, _, text = _run(capsys, tmp_path, "--preset", "fig7_a_coated", "--samples", "512", "--blocks", "2",
                      "--wavelengths", "450", "650", "3", name="mc.npz")
    assert set(f.files) >= {"brdf", "stderr", "single_reflection", "wavelength_nm", "wi", "wo", "settings"}
    assert f["brdf"].shape == f["single_reflection"].shape == (3, 3)
    assert json.loads(str(f["settings"]))["preset"] == "fig7_a_coated"
    assert "under a smooth coating of index 1.35" in text and "reflects exactly once" not in text


@pytest.mark.parametrize("argv, match", [
    (["--base-albedo", "1.5"], "--base-albedo"),
    (["--base-albedo", "-0.1"], "--base-albedo"),
    (["--layers", "0"], "--layers"),
    (["--seed", "-1"], "--seed"),
    (["--preset", "blue"], "--preset"),
])
def test_bad_structure_options(capsys, tmp_path, argv, match):
    with pytest.raises(SystemExit) as exc:
        cli.main(["montecarlo", *DIRECTIONS, "--out", str(tmp_path / "x.json"), *argv])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and match in err and len(err.splitlines()) == 1
    assert not (tmp_path / "x.json").exists()
