"""``torchirid design SPEC.toml --out DIR`` (issue 36.4): design.json and the figures, the seed
reproduces the design, --time-limit bounds the search, and a bad spec is one stderr line naming
the key, exit status 2, with nothing written. Small problems: 4 layers, a few wavelengths."""

from __future__ import annotations

import json

import pytest
import torch

from torchirid.app import cli

#: a 4-layer TiO2/SiO2 mirror for 500-600 nm on glass (converges in well under a second)
SPEC = """\
name = "four layers"
incident = "air"
exit = "glass"

[optimiser]
seed = 0

[[layers]]
pattern = ["TiO2", "SiO2"]
repeat = 2
thickness = [10.0, 200.0]

[[targets]]
quantity = "R"
wavelength = {start = 500.0, stop = 600.0, count = 6}
value = 1.0
p = 1

[tolerance]
sigma = 1.0
samples = 200
"""

KEYS = {"layers", "incident", "exit", "merit", "seconds", "evaluations", "total_thickness_nm", "method", "history",
        "name", "tolerance"}


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    n = torch.get_num_threads()
    torch.set_num_threads(1)  # small batches: threads only add synchronisation (and the cores are shared)
    yield
    torch.set_num_threads(n)


def _spec(tmp_path, text=SPEC, name="spec.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _design(capsys, spec, out, *argv):
    assert cli.main(["design", str(spec), "--out", str(out), "--quiet", *argv]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    return json.loads((out / "design.json").read_text()), captured.out


def test_writes_design_json_and_figures(tmp_path, capsys):
    out = tmp_path / "made" / "here"  # created by the command, parents too
    data, printed = _design(capsys, _spec(tmp_path), out)
    assert set(data) >= KEYS
    assert data["name"] == "four layers" and data["incident"] == "air" and data["exit"] == "glass"
    assert len(data["layers"]) == 4 and all(set(layer) == {"material", "thickness_nm"} for layer in data["layers"])
    assert [layer["material"] for layer in data["layers"]] == ["TiO2", "SiO2"] * 2
    assert all(10.0 <= layer["thickness_nm"] <= 200.0 for layer in data["layers"])
    assert data["total_thickness_nm"] == pytest.approx(sum(layer["thickness_nm"] for layer in data["layers"]))
    assert 0 < data["merit"] < 0.5 and data["evaluations"] > 0 and data["method"] == "auto"
    history = data["history"]
    assert history and all(len(h) == 3 for h in history)
    assert [h[2] for h in history] == sorted((h[2] for h in history), reverse=True)  # the best only improves
    tol = data["tolerance"]
    assert tol["samples"] == 200 and tol["sigma"] == 1.0 and 0 <= tol["yield"] <= 1
    assert tol["nominal_merit"] == pytest.approx(data["merit"], rel=1e-9)
    assert tol["merit_limit"] == pytest.approx(1.1 * data["merit"], rel=1e-9) and "worst_delta_e2000" not in tol
    for name in ("design.json", "spectra.png", "tolerance.png", "convergence.png"):
        assert (out / name).stat().st_size > 0 and str(out / name) in printed, name
        if name.endswith(".png"):
            assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not (out / "colour.png").exists()  # no colour target
    assert sorted(p.name for p in out.parent.iterdir()) == ["here"]  # no temporary folder left beside it
    assert "four layers: 4 layers" in printed and "tolerance: yield" in printed


def test_colour_targets_and_formats(tmp_path, capsys):
    spec = SPEC.replace("[tolerance]", """[[targets]]
type = "colour"
lab = [[60.0, 20.0, 40.0], [50.0, -20.0, 10.0]]
angle_deg = [0.0, 50.0]
wavelength_step = 20.0

[tolerance]""").replace("samples = 200", "samples = 50")
    out = tmp_path / "out"
    data, printed = _design(capsys, _spec(tmp_path, spec), out, "--time-limit", "0.5", "--format", "png,svg")
    for name in ("spectra", "colour", "tolerance", "convergence"):
        for fmt in ("png", "svg"):
            assert (out / f"{name}.{fmt}").stat().st_size > 0 and str(out / f"{name}.{fmt}") in printed
    worst = data["tolerance"]["worst_delta_e2000"]
    assert data["tolerance"]["delta_e_limit"] == 1.0 and 0 <= worst["p05"] <= worst["median"] <= worst["max"]


def test_the_same_seed_gives_the_same_design(tmp_path, capsys):
    spec = _spec(tmp_path)
    a, _ = _design(capsys, spec, tmp_path / "a", "--seed", "3")
    b, _ = _design(capsys, spec, tmp_path / "b", "--seed", "3")
    assert a["layers"] == b["layers"] and a["merit"] == b["merit"] and a["evaluations"] == b["evaluations"]


def test_time_limit_bounds_the_search_and_overrides_the_spec(tmp_path, capsys):
    spec = _spec(tmp_path, SPEC.replace("seed = 0", "seed = 0\ntime_limit = 60.0"))
    data, _ = _design(capsys, spec, tmp_path / "out", "--time-limit", "0.5", "--method", "global")
    # with a limit the search starts again until it runs out; it stops within a round of it
    assert 0.5 <= data["seconds"] <= 0.5 + 1.0, data["seconds"]
    assert data["method"] == "global"


def test_an_existing_out_keeps_its_other_files(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    (out / "design.json").write_text("{}")
    data, _ = _design(capsys, _spec(tmp_path), out)
    assert (out / "notes.txt").read_text() == "mine" and data["layers"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "spec.toml"]


def test_a_failed_write_leaves_nothing(tmp_path, capsys, monkeypatch):
    from torchirid.app.figures import design as figures

    def full_disk(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(figures, "save_figure", full_disk)
    status = cli.main(["design", str(_spec(tmp_path)), "--out", str(tmp_path / "out"), "--quiet"])
    assert status == 1
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("torchirid design: error: cannot write to --out")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.toml"]  # no DIR, no temporary folder


BAD_SPECS = {
    "unknown key": (("wavelength = {", "wavelenght = {"), "targets[0].wavelenght"),
    "min > max": (("thickness = [10.0, 200.0]", "thickness = [200.0, 10.0]"), "layers[0].thickness"),
    "metres": (("thickness = [10.0, 200.0]", "thickness = 1e-7"), "layers[0].thickness"),
    "unknown material": (('pattern = ["TiO2", "SiO2"]\nrepeat = 2', 'material = "unobtainium"'), "layers[0].material"),
    "unknown tolerance key": (("samples = 200", "samples = 200\nsigmma = 2"), "tolerance.sigmma"),
    "bad tolerance sigma": (("sigma = 1.0", "sigma = -1.0"), "tolerance.sigma"),
    "invalid TOML": (("[optimiser]", "[optimiser"), "spec.toml"),
}


@pytest.mark.parametrize("case", sorted(BAD_SPECS))
def test_a_bad_spec_is_one_line_naming_the_key_and_writes_nothing(tmp_path, capsys, case):
    (old, new), key = BAD_SPECS[case]
    assert old in SPEC
    spec = _spec(tmp_path, SPEC.replace(old, new))
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        cli.main(["design", str(spec), "--out", str(out)])
    captured = capsys.readouterr()
    assert exc.value.code == 2
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("torchirid design: error: "), captured.err
    assert key in lines[0], lines[0]
    assert captured.out == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spec.toml"]  # no DIR, no temporary folder


def test_a_missing_spec_or_a_folder(tmp_path, capsys):
    for spec in (tmp_path / "nowhere.toml", tmp_path):
        with pytest.raises(SystemExit) as exc:
            cli.main(["design", str(spec), "--out", str(tmp_path / "out")])
        lines = capsys.readouterr().err.splitlines()
        assert exc.value.code == 2 and len(lines) == 1 and str(spec) in lines[0], lines
        assert not (tmp_path / "out").exists()
