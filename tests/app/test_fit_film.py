import argparse
import json

import pytest

from torchirid._io import json_ready
from torchirid.app.commands import fit_film as cli
from torchirid.estimation import synthetic_cube
from torchirid.estimation.cube_io import write_npz


def _parse(argv):
    parser = argparse.ArgumentParser(prog="torchirid")
    sub = parser.add_subparsers(dest="command", required=True)
    cli.add_parser(sub)
    return parser.parse_args(argv)


# The cubes are rendered as Kobayashi et al.'s camera sees them (the s wave, through a polarizer),
# so the fits pass ``--polarization s`` (the command, like the library, defaults to unpolarized).


def test_fit_film_on_a_tiny_cube(tmp_path, capsys):
    c = synthetic_cube("mgf2_400", height=12, width=12, seed=0, polarization="s")
    p = tmp_path / "cube.npz"
    write_npz(p, c.cube, c.wavelength, c.angles_deg, bandwidth=4.0, thickness=c.thickness, meta={"n_true": 1.37})
    out = tmp_path / "out"
    args = _parse(["fit-film", "--polarization", "s", str(p), "--out", str(out), "--threads", "1"])
    assert args.func is cli.run
    assert args.func(args) == 0
    for f in ("thickness.png", "fit_error.png", "thickness_error.png", "report.json", "thickness_nm.npy"):
        assert (out / f).stat().st_size > 0
    rep = json.loads((out / "report.json").read_text())
    assert abs(rep["n"] - 1.37) < 0.01 and rep["n_error"] < 0.01
    assert rep["thickness_error_nm"]["mean"] < 5
    assert "n = 1.37" in capsys.readouterr().out


def test_fit_film_bad_file(tmp_path, capsys):
    args = _parse(["fit-film", "--polarization", "s", str(tmp_path / "nope.txt"), "--out", str(tmp_path / "o")])
    assert args.func(args) == 2
    assert "fit-film" in capsys.readouterr().err


def _save_envi_per_angle(tmp_path, c, scale=1.0):
    """One standard ENVI file per angle: only 'wavelength' (+ fwhm) in the header, as a camera writes it."""
    import numpy as np
    from spectral.io import envi

    paths = []
    for a, ang in enumerate(c.angles_deg.tolist()):
        p = str(tmp_path / f"film_{ang:.0f}deg.hdr")
        md = {"wavelength": [f"{v:.6g}" for v in c.wavelength.tolist()], "wavelength units": "Nanometers",
              "fwhm": ["4"] * c.wavelength.numel()}
        if scale != 1.0:
            md["reflectance scale factor"] = str(scale)
        envi.save_image(p, (c.cube[:, :, a].numpy() * scale).astype(np.float32), metadata=md, force=True, ext=".img")
        paths.append(p)
    return paths


def test_fit_film_on_envi_files_one_per_angle(tmp_path, capsys):
    c = synthetic_cube("mgf2_400", height=10, width=10, seed=2, polarization="s")
    paths = _save_envi_per_angle(tmp_path, c, scale=10000.0)
    out = tmp_path / "out"
    # angles given in file order; the files need not be in increasing angle order
    order = [2, 0, 4, 1, 3]
    args = _parse(["fit-film", "--polarization", "s", *[paths[i] for i in order], "--angles",
                   *[str(c.angles_deg[i].item()) for i in order], "--index-model", "constant", "--out", str(out),
                   "--threads", "1"])
    assert args.func(args) == 0
    rep = json.loads((out / "report.json").read_text())
    assert rep["angles_deg"] == c.angles_deg.tolist() and rep["shape"] == [10, 10, 5, 81]
    assert abs(rep["n"] - 1.37) < 0.01 and rep["settings"]["bandwidth"] == 4.0
    import numpy as np

    d = np.load(out / "thickness_nm.npy")
    assert np.abs(d - c.thickness.numpy()).mean() < 5.0  # float32 on disk, scaled by 10^4


def test_fit_film_envi_angle_errors(tmp_path, capsys):
    c = synthetic_cube("mgf2_400", height=3, width=3, seed=0, angles_deg=(10.0, 30.0, 50.0))
    paths = _save_envi_per_angle(tmp_path, c)
    for extra, msg in [([], "angles_deg must give the incidence angle of each of the 3"),
                       (["--angles", "10", "30"], "3 angle(s), one per ENVI file"),
                       (["--angles", "10", "30", "95"], "[0, 90)"),
                       (["--angles", "10", "30", "30"], "distinct")]:
        args = _parse(["fit-film", "--polarization", "s", *paths, "--out", str(tmp_path / "o"), *extra])
        assert args.func(args) == 2
        assert msg in capsys.readouterr().err
    # a single camera file without an 'incidence angle' field needs --angles
    args = _parse(["fit-film", "--polarization", "s", paths[0], "--out", str(tmp_path / "o")])
    assert args.func(args) == 2
    assert "incidence angle" in capsys.readouterr().err


def test_fit_film_default_auto_index_on_zns(tmp_path, capsys):
    c = synthetic_cube("zns_500", height=12, width=12, seed=0, polarization="s")
    p = tmp_path / "zns.npz"
    write_npz(p, c.cube, c.wavelength, c.angles_deg, bandwidth=4.0, thickness=c.thickness, meta={"n_true": 2.367})
    args = _parse(["fit-film", "--polarization", "s", str(p), "--out", str(tmp_path / "auto"), "--threads", "1"])
    assert args.index_model == "auto" and args.func(args) == 0
    rep = json.loads((tmp_path / "auto" / "report.json").read_text())
    assert rep["index_model"] in ("cauchy", "cauchy3") and rep["warnings"] == []
    assert rep["n_error"] < 0.01 and rep["thickness_error_nm"]["mean"] < 5
    assert set(rep["index_selection"]) == {"constant", "cauchy", "cauchy3"}
    capsys.readouterr()
    args = _parse(["fit-film", "--polarization", "s", str(p), "--out", str(tmp_path / "const"),
                   "--index-model", "constant"])
    assert args.func(args) == 0
    assert "warning" in capsys.readouterr().err and "noise level" in (tmp_path / "const" / "report.json").read_text()


def _strict_json(text):
    """json.loads that refuses NaN / Infinity / -Infinity (not JSON; Python's json writes them by default)."""
    def refuse(name):
        raise ValueError(f"not strict JSON: {name}")

    return json.loads(text, parse_constant=refuse)


@pytest.mark.slow
def test_fit_film_dead_pixels_from_an_envi_ignore_value(tmp_path, capsys):
    """Issue 21 item 8: dead pixels (the header's 'data ignore value') are invalid, not NaN statistics."""
    import numpy as np
    from spectral.io import envi

    c = synthetic_cube("mgf2_400", height=8, width=8, seed=2, polarization="s")
    dead = [(0, 0), (2, 5), (7, 3)]
    paths = []
    for a, ang in enumerate(c.angles_deg.tolist()):
        data = (c.cube[:, :, a].numpy() * 10000.0).astype(np.float32)
        for i, j in dead:
            data[i, j, :] = -9999.0
        p = str(tmp_path / f"film_{ang:.0f}deg.hdr")
        envi.save_image(p, data, force=True, ext=".img", metadata={
            "wavelength": [f"{v:.6g}" for v in c.wavelength.tolist()], "wavelength units": "Nanometers",
            "fwhm": ["4"] * c.wavelength.numel(), "reflectance scale factor": "10000", "data ignore value": "-9999"})
        paths.append(p)
    out = tmp_path / "out"
    args = _parse(["fit-film", "--polarization", "s", *paths, "--angles", *map(str, c.angles_deg.tolist()),
                   "--out", str(out), "--threads", "1"])
    assert args.func(args) == 0
    rep = _strict_json((out / "report.json").read_text())  # old code: bare NaN in the statistics
    assert rep["pixels"] == {"total": 64, "valid": 61, "invalid": 3, "missing_samples": 0}
    assert rep["index_model"] == "constant" and abs(rep["n"] - 1.37) < 0.005 and rep["warnings"] == []
    assert all(v is not None for v in rep["thickness_nm"].values()) and rep["rms_residual_mean"] is not None
    sel = rep["index_selection"]
    assert all(v["bic"] is not None and None not in v["order_sse"].values() for v in sel.values())
    d = np.load(out / "thickness_nm.npy")
    mask = np.zeros((8, 8), dtype=bool)
    mask[tuple(zip(*dead))] = True
    assert np.isnan(d[mask]).all() and np.isfinite(d[~mask]).all()
    assert np.abs(d[~mask] - c.thickness.numpy()[~mask]).mean() < 2.0
    assert "3 invalid pixels" in capsys.readouterr().out


def test_report_is_strict_json_and_maps_mark_invalid_pixels():
    import math

    import numpy as np
    import torch

    from torchirid.app.figures.film_maps import INVALID_COLOUR, plot_film_map
    from matplotlib.colors import to_rgba

    rep = json_ready({"a": [math.nan, 1.0, math.inf], "b": {"c": -math.inf}, "t": torch.tensor([2.0, math.nan]),
                            "n": np.float64("nan"), "k": 3})
    assert _strict_json(json.dumps(rep, allow_nan=False)) == {"a": [None, 1.0, None], "b": {"c": None},
                                                             "t": [2.0, None], "n": None, "k": 3}
    assert cli._stats(torch.full((2, 2), math.nan))["mean"] is None
    img = torch.arange(12.0).reshape(3, 4)
    img[1, 2] = math.nan
    fig = plot_film_map(img, "thickness", "d (nm)")
    ax = fig.axes[0]
    assert ax.images[0].cmap.get_bad() == pytest.approx(to_rgba(INVALID_COLOUR))
    assert "1 pixel without data" in ax.get_xlabel()
    assert plot_film_map(torch.ones(2, 2), "t", "l").axes[0].get_xlabel() == ""
