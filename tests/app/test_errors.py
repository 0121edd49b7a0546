"""One error style for every subcommand: a bad argument → exit status 2 and exactly one line on
stderr, ``torchirid <subcommand>: error: <message>`` (no usage dump, no traceback)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import torchirid
from torchirid.app import cli


def _run(capsys, argv):
    with pytest.raises(SystemExit) as exc:
        cli.main(argv)
    captured = capsys.readouterr()
    return exc.value.code, captured.out, captured.err


def _check_one_line(code, err, command):
    assert code == 2
    lines = err.splitlines()
    assert len(lines) == 1, err
    prefix = f"torchirid {command}: error: " if command else "torchirid: error: "
    assert lines[0].startswith(prefix), err
    assert "Traceback" not in err and "usage:" not in err


#: one bad argument per subcommand that argparse itself rejects (non-numeric or NaN values)
PARSE_ERRORS = {
    "spectrum": ["--d1", "nan"],
    "gradients": ["--lambdas", "nan"],
    "scatterogram": ["--alpha", "nan"],
    "film-table": ["--angles", "many"],
    "render-sphere": ["--tau", "nan"],
    "thin-film": ["--alpha", "nan"],
    "fit-film": ["cube.npz", "--bandwidth", "nan"],
    "build-table": ["thin_film_reflectance", "--axis", "wavelength=nan:700:5"],
    "fit-batch": ["film", "c.npz", "--timeout", "nan"],
    "montecarlo": ["--incident", "nan", "0", "--exit", "30", "0"],
    "design": ["spec.toml", "--time-limit", "nan"],
    "explore": ["--port", "nan"],
    "render-mitsuba": ["thin_film", "--spp", "nan"],
}

#: one bad argument per subcommand that parses and is refused afterwards (by the command or the
#: library, as a ValueError naming the parameter)
LATE_ERRORS = {
    "spectrum": (["--cells", "0"], "cells"),
    "gradients": (["--n1", "2"], "n1"),
    "scatterogram": (["--beam", "120", "0"], "THETA"),
    "film-table": (["--wavelengths", "700", "400", "5"], "wavelengths"),
    "render-sphere": (["--preset", "custom", "--substrate", "1.5", "--size", "4"], "size"),
    "thin-film": (["--n-film", "0.5"], "n-film"),
    "fit-film": (["missing-cube.npz"], "missing-cube"),
    "build-table": (["thin_film_reflectance", "--axis", "wavelength=400:700:5", "--set", "bogus=1"], "bogus"),
    "fit-batch": (["film", "c.npz", "--set", "bogus=1"], "bogus"),
    "montecarlo": (["--incident", "95", "0", "--exit", "30", "0"], "THETA"),
    "design": (["missing-spec.toml"], "missing-spec"),
    "explore": (["--port", "70000"], "port"),
    "render-mitsuba": (["thin_film", "n_film=1.33", "--variant", "scalar_rgb"], "thickness"),
}


def test_every_subcommand_is_covered():
    names = {command.NAME for command in cli.COMMANDS}
    assert set(PARSE_ERRORS) == names and set(LATE_ERRORS) == names


@pytest.mark.parametrize("command", sorted(PARSE_ERRORS))
def test_parse_error_is_one_line_and_status_2(tmp_path, capsys, command):
    code, out, err = _run(capsys, [command, "--out", str(tmp_path / "out"), *PARSE_ERRORS[command]])
    _check_one_line(code, err, command)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", sorted(LATE_ERRORS))
def test_late_error_is_one_line_and_status_2(tmp_path, capsys, command):
    extra, word = LATE_ERRORS[command]
    out_dir = tmp_path if command == "render-sphere" else tmp_path / "out"  # render-sphere needs an existing --out
    code, out, err = _run(capsys, [command, "--out", str(out_dir), *extra])
    _check_one_line(code, err, command)
    assert word in err
    assert not (tmp_path / "out").exists()


def test_unrecognized_argument_names_the_subcommand(capsys):
    code, _, err = _run(capsys, ["spectrum", "--bogus", "1"])
    _check_one_line(code, err, "spectrum")
    assert "--bogus" in err


def test_no_or_unknown_subcommand(capsys):
    code, _, err = _run(capsys, [])
    _check_one_line(code, err, None)
    code, _, err = _run(capsys, ["paint"])
    _check_one_line(code, err, None)
    assert "paint" in err


def test_the_console_process(tmp_path):
    """The same through ``python -m torchirid`` in a fresh process: status 2, one stderr line."""
    src = str(Path(torchirid.__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]), MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-m", "torchirid", "spectrum", "--thickness", "abc", "--out",
                           str(tmp_path)], capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 2
    assert proc.stderr.splitlines() == [proc.stderr.strip()] and proc.stderr.startswith("torchirid spectrum: error: ")
    assert proc.stdout == ""


#: issue 22: every subcommand, every class of bad argument → status 2 and one line
#: (missing and empty files: the one command that reads files, tests/app/test_fit_film_bad_files.py)
ERROR_CLASSES = {
    "spectrum": {"nan": ["--d1", "nan"], "negative": ["--d1", "-5"], "unit": ["--wavelengths", "5e-7", "7.8e-7", "5"]},
    "gradients": {"nan": ["--lambdas", "nan"], "negative": ["--lambdas", "-244"], "unit": ["--lambdas", "2.44e-7"]},
    "scatterogram": {"nan": ["--alpha", "nan"], "negative": ["--alpha", "-0.1"],
                     "unit": ["--wavelengths", "4.2e-7", "6.8e-7", "4"]},
    "film-table": {"nan": ["--wavelengths", "400", "nan", "5"], "negative": ["--angles", "-3"],
                   "unit": ["--wavelengths", "4e-7", "7e-7", "5"]},
    "render-sphere": {"nan": ["--tau", "nan"], "negative": ["--tau", "-1"], "unit": ["--wavelength-step", "5e-9"]},
    "thin-film": {"nan": ["--alpha", "nan"], "negative": ["--thickness", "-10"], "unit": ["--thickness", "3e-7"]},
    "fit-film": {"nan": ["c.npz", "--bandwidth", "nan"], "negative": ["c.npz", "--bandwidth", "-4"],
                 "unit": ["c.npz", "--thickness-range", "2e-8", "2e-6"]},
    "build-table": {k: ["thin_film_reflectance", "--axis", axis, "--set", "cos_theta=1", "--set", "n_film=1.3",
                        "--set", "n_substrate=1.5", "--set", "thickness=100"]
                    for k, axis in (("nan", "wavelength=400:nan:5"), ("negative", "wavelength=-400:700:5"),
                                    ("unit", "wavelength=4e-7:7e-7:5"))},
    "fit-batch": {"nan": ["film", "c.npz", "--timeout", "nan"], "negative": ["film", "c.npz", "--workers", "-2"],
                  "unit": ["film", "c.npz", "--set", "thickness_range=[2e-8,2e-6]"]},
    "montecarlo": {k: ["--incident", "30", "0", "--exit", "30", "0", *extra]
                   for k, extra in (("nan", ["--wavelengths", "400", "nan", "5"]), ("negative", ["--samples", "-5"]),
                                    ("unit", ["--wavelengths", "4e-7", "7e-7", "5"]))},
    "design": {"nan": ["s.toml", "--time-limit", "nan"], "negative": ["s.toml", "--seed", "-1"],
               "unit": None},  # lengths are in the spec: tests/app/test_design_command.py
    "explore": {"nan": ["--port", "nan"], "negative": ["--port", "-1"], "unit": None},  # no lengths to give in metres
    "render-mitsuba": {k: ["thin_film", "n_film=1.33", f"thickness={v}", "--variant", "scalar_rgb"]
                       for k, v in (("nan", "NaN"), ("negative", "-10"), ("unit", "3e-7"))},
}


def test_error_classes_cover_every_subcommand():
    assert set(ERROR_CLASSES) == {command.NAME for command in cli.COMMANDS}


@pytest.mark.parametrize("command,kind", [(c, k) for c in sorted(ERROR_CLASSES) for k in ("nan", "negative", "unit")
                                          if ERROR_CLASSES[c][k] is not None])
def test_every_bad_argument_class_is_one_line_and_status_2(tmp_path, capsys, command, kind):
    code, out, err = _run(capsys, [command, "--out", str(tmp_path / "out"), *ERROR_CLASSES[command][kind]])
    _check_one_line(code, err, command)
    if kind == "unit":
        assert "nm" in err
    assert not (tmp_path / "out").exists()


def test_a_missing_app_extra_says_how_to_install_it(monkeypatch, capsys):
    """Installed without the ``app`` extra, a figure command names the extra (exit 2), not a traceback."""
    from torchirid.app import cli

    def no_matplotlib(args):
        raise ModuleNotFoundError("No module named 'matplotlib'", name="matplotlib")

    parser = cli.build_parser()
    args = parser.parse_args(["spectrum", "--out", "x"])
    monkeypatch.setattr(cli, "build_parser", lambda: parser)
    monkeypatch.setattr(args, "func", no_matplotlib, raising=False)
    monkeypatch.setattr(parser, "parse_known_args", lambda argv=None: (args, []))
    with pytest.raises(SystemExit) as stop:
        cli.main(["spectrum"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "matplotlib" in err and "torchirid[app]" in err
