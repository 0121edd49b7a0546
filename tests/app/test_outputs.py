"""Issue 22.3 / 22.4 / 22.8: every figure command writes PNG, PDF and SVG on request, creates its
output folder, ends by printing every path it wrote, is quiet with --quiet (and when stderr is not
a terminal); fit-film refuses reflectances in percent."""

from __future__ import annotations

import pytest

from torchirid.app import _args
from torchirid.app.cli import main
from torchirid.estimation import synthetic_cube
from torchirid.estimation.cube_io import write_npz

FORMATS = ["--format", "png,pdf,svg", "--quiet"]
COMMANDS = {
    "spectrum": (["spectrum", "--angles", "3", "--wavelengths", "400", "700", "5", "--name", "x"],
                 ["x.png", "x.pdf", "x.svg", "x.npz"]),
    "gradients": (["gradients", "--angles", "3", "--lambdas", "244", "--ratios", "0.5", "--name", "x", "--dpi", "30"],
                  ["x.png", "x.pdf", "x.svg", "x.npz"]),
    "scatterogram": (["scatterogram", "--preset", "custom", "--resolution", "6", "--wavelengths", "420", "680", "4",
                      "--name", "x", "--dpi", "30"], ["x.png", "x.pdf", "x.svg", "x.npz"]),
    "thin-film": (["thin-film", "--resolution", "3", "--name", "x", "--dpi", "30"],
                  ["x.png", "x.pdf", "x.svg", "x.json", "x_roughness.npz"]),
    "render-sphere": (["render-sphere", "--preset", "custom", "--substrate", "1.5", "--film", "1.4:300", "--sigma",
                       "0", "--size", "8", "--wavelength-step", "50", "--name", "x"], ["x.png", "x.pdf", "x.svg", "x.npz"]),
}


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_formats_folder_and_printed_paths(name, tmp_path, capsys):
    argv, files = COMMANDS[name]
    out = tmp_path / "made" / "here"  # created by the command
    assert main([*argv, "--out", str(out), *FORMATS]) == 0
    captured = capsys.readouterr()
    for f in files:
        assert (out / f).is_file() and (out / f).stat().st_size > 0, f
        assert str(out / f) in captured.out, f  # every written path is printed
    assert (out / files[1]).read_bytes()[:4] == b"%PDF"
    assert captured.err == ""  # --quiet: no progress bar


def test_fit_film_formats_and_paths(tmp_path, capsys):
    c = synthetic_cube("mgf2_400", height=6, width=6, seed=0, polarization="s")
    cube = tmp_path / "c.npz"
    write_npz(cube, c.cube, c.wavelength, c.angles_deg, bandwidth=4.0)
    out = tmp_path / "fit"
    assert main(["fit-film", str(cube), "--n-substrate", "1.64", "--polarization", "s", "--out", str(out),
                 *FORMATS]) == 0
    printed = capsys.readouterr().out
    for f in ("thickness.png", "thickness.svg", "fit_error.pdf", "report.json", "thickness_nm.npy"):
        assert (out / f).is_file() and str(out / f) in printed, f


def test_fit_film_refuses_percent(tmp_path, capsys):
    c = synthetic_cube("mgf2_400", height=4, width=4, seed=0, polarization="s")
    cube = tmp_path / "pct.npz"
    write_npz(cube, 100 * c.cube, c.wavelength, c.angles_deg, bandwidth=4.0)  # percent: n came out 98.3
    with pytest.raises(SystemExit) as e:
        main(["fit-film", str(cube), "--n-substrate", "1.64", "--out", str(tmp_path / "o")])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "percent" in err[0] and "fit-film: error:" in err[0]


def test_bad_format_exits_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["spectrum", "--format", "jpg", "--out", str(tmp_path)])
    assert e.value.code == 2 and "png, pdf, svg" in capsys.readouterr().err


def test_progress_bar_quiet_and_non_tty():
    assert _args.progress_bar("x", total=3, quiet=True).disable
    bar = _args.progress_bar("x", total=3)  # pytest's stderr is not a terminal
    assert bar.disable
    bar.close()
