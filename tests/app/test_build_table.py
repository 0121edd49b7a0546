"""Issue 35.4: ``torchirid build-table`` errors say what to do — the function's missing arguments
with the ``--set NAME=VALUE`` / ``--axis`` forms, the function's argument names for an unknown
one — and exit 2; every listed function resolves (thin_film_xyz_* live in torchirid.ibl)."""

from __future__ import annotations

import inspect

import pytest

from torchirid.app.cli import main
from torchirid.app.commands import build_table


def _error(capsys, argv):
    with pytest.raises(SystemExit) as e:
        main(argv)
    err = capsys.readouterr().err
    assert e.value.code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("torchirid build-table: error: "), err
    assert "Traceback" not in err and "torchirid.spectral" not in err  # no internal module path
    return lines[0]


def test_missing_arguments_are_listed_with_the_set_form(tmp_path, capsys):
    line = _error(capsys, ["build-table", "bragg_xyz", "--axis", "cos_theta=0:1:5", "--out", str(tmp_path / "t.zarr")])
    assert "needs a value for n1, n2, d1, d2, cells" in line
    assert "--set NAME=VALUE" in line and "--set n1=VALUE" in line and "--axis NAME=START:STOP:COUNT" in line
    assert "cos_theta, n1, n2, d1, d2, cells (each an --axis or a --set)" in line  # which can be axes
    assert not (tmp_path / "t.zarr").exists()


@pytest.mark.parametrize("option,spec,near", [("--axis", "theta=0:1:5", "cos_theta"),
                                              ("--set", "polarisation=s", "polarization")])
def test_an_unknown_name_lists_the_arguments(tmp_path, capsys, option, spec, near):
    given = ["--set", "n1=1", "--set", "n2=1.5", "--set", "d1=100", "--set", "d2=200", "--set", "cells=5"]
    axis = [] if option == "--axis" else ["--axis", "cos_theta=0:1:5"]
    line = _error(capsys, ["build-table", "bragg_xyz", *axis, option, spec, *given, "--out", str(tmp_path / "t.zarr")])
    name = spec.split("=")[0]
    assert f"{option} {name}: bragg_xyz has no argument '{name}'" in line
    assert f"did you mean {near}?" in line
    for argument in inspect.signature(build_table._function("bragg_xyz")).parameters:
        assert argument in line  # every valid name


def test_a_name_both_axis_and_set(tmp_path, capsys):
    line = _error(capsys, ["build-table", "thin_film_reflectance", "--axis", "wavelength=400:700:3",
                           "--set", "wavelength=500", "--out", str(tmp_path / "t.zarr")])
    assert "wavelength is both an --axis and a --set" in line


@pytest.mark.parametrize("name", sorted(build_table.FUNCTIONS))
def test_every_function_resolves(name):
    fn = build_table._function(name)
    assert fn.__name__ == name and callable(fn)


def test_an_ibl_function_builds(tmp_path, capsys):
    pytest.importorskip("zarr", reason="needs the scale extra")
    assert main(["build-table", "thin_film_xyz_fourier", "--axis", "cos_theta=0.5:1:3", "--set", "n_film=1.33",
                 "--set", "thickness=300", "--set", "n_substrate=1.5", "--out", str(tmp_path / "t.zarr"),
                 "--quiet"]) == 0
    assert "1 chunks computed" in capsys.readouterr().out


# ------------------------------------------------------------------ issue 35.4: the size of a grid, before any work
HUGE = {
    "build-table": (["bragg_xyz", "--axis", "cos_theta=0:1:1000", "--axis", "d1=50:250:1000", "--axis",
                     "d2=100:400:1000", "--set", "n1=1", "--set", "n2=1.5", "--set", "cells=20"],
                    ["1,000,000,000 points", "24.0 GB"]),
    "spectrum": (["--angles", "100000", "--wavelengths", "380", "780", "100000"], ["10,000,000,000 points", "80.0 GB"]),
    "film-table": (["--angles", "20000", "--wavelengths", "380", "780", "20000"], ["400,000,000 points", "3.2 GB"]),
}


@pytest.mark.parametrize("command", sorted(HUGE))
def test_a_huge_grid_is_refused_with_its_size(tmp_path, capsys, command):
    argv, sizes = HUGE[command]
    with pytest.raises(SystemExit) as e:
        main([command, *argv, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert e.value.code == 2, err
    assert any(size in err for size in sizes[:-1]) and sizes[-1] in err, err  # the points and the bytes
    assert "--yes" in err and ("smaller" in err or "fewer" in err), err  # how to go on
    assert not (tmp_path / "o").exists()


def test_yes_runs_a_large_grid_and_says_its_size(tmp_path, capsys, monkeypatch):
    from torchirid.app import _args

    monkeypatch.setattr(_args, "LARGE_POINTS", 4)  # "large" without computing anything large
    argv = ["spectrum", "--angles", "3", "--wavelengths", "400", "700", "3", "--out", str(tmp_path)]
    with pytest.raises(SystemExit):
        main(argv)
    assert "9 points" in capsys.readouterr().err
    assert main([*argv, "--yes"]) == 0
    err = capsys.readouterr().err
    assert "torchirid spectrum: the map 3 angles × 3 wavelengths of float64: 9 points, 72 bytes (--yes)" in err
