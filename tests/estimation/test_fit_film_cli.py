import argparse
import json


from torchirid.estimation import cli, synthetic_cube
from torchirid.estimation.cube_io import write_npz


def _parse(argv):
    parser = argparse.ArgumentParser(prog="torchirid")
    sub = parser.add_subparsers(dest="command", required=True)
    cli.add_parser(sub)
    return parser.parse_args(argv)


def test_fit_film_on_a_tiny_cube(tmp_path, capsys):
    c = synthetic_cube("mgf2_400", height=12, width=12, seed=0)
    p = tmp_path / "cube.npz"
    write_npz(p, c.cube, c.wavelength, c.angles_deg, bandwidth=4.0, thickness=c.thickness, meta={"n_true": 1.37})
    out = tmp_path / "out"
    args = _parse(["fit-film", str(p), "--out", str(out), "--threads", "1"])
    assert args.func is cli.run
    assert args.func(args) == 0
    for f in ("thickness.png", "fit_error.png", "thickness_error.png", "report.json", "thickness_nm.npy"):
        assert (out / f).stat().st_size > 0
    rep = json.loads((out / "report.json").read_text())
    assert abs(rep["n"] - 1.37) < 0.01 and rep["n_error"] < 0.01
    assert rep["thickness_error_nm"]["mean"] < 5
    assert "n = 1.37" in capsys.readouterr().out


def test_fit_film_bad_file(tmp_path, capsys):
    args = _parse(["fit-film", str(tmp_path / "nope.txt"), "--out", str(tmp_path / "o")])
    assert args.func(args) == 2
    assert "fit-film" in capsys.readouterr().err
