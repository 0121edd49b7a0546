"""The scatterogram figures and files (torchirid.app.figures.scatterograms) and the
``torchirid scatterogram`` command."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchirid.app import cli, figures
from torchirid.layered import scatterogram, scatterogram_srgb
from torchirid.presets import jewel_beetle

F64 = torch.float64
LAM = torch.tensor([450.0, 550.0, 650.0], dtype=F64)
FAST = dict(wavelength=LAM, lobe_nodes=(12, 8))


def test_png_npz_and_srgb(tmp_path):
    rows = [[scatterogram(jewel_beetle(n), resolution=6, title=n, **FAST) for n in ("green", "red")],
            [scatterogram(jewel_beetle(n), incident_deg=(10.0, 0.0), resolution=6, wavelength=LAM)
             for n in ("green", "red")]]
    rgb = scatterogram_srgb(rows[1][0])
    assert rgb.shape == (6, 6, 3) and rgb.min() >= 0 and rgb.max() <= 1 and np.all(rgb[~rows[1][0].mask.numpy()] == 0)
    assert abs(rgb.max() - 1.0) < 1e-9  # auto exposure: the brightest pixel's Y → 1 saturates a channel
    png = figures.save_scatterograms_png(rows, tmp_path / "s.png", dpi=40, row_labels=["white", "beam"])
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    npz = figures.save_scatterograms_npz(rows, tmp_path / "s.npz")
    with np.load(npz, allow_pickle=False) as z:
        assert z["xyz"].shape == (2, 2, 6, 6, 3) and z["titles"][0, 1] == "red"
        np.testing.assert_allclose(z["xyz"][1, 0], rows[1][0].xyz.numpy())
    with pytest.raises(ValueError, match="exposure"):
        scatterogram_srgb(rows[0][0], exposure=-1.0)
    with pytest.raises(ValueError, match="row_labels"):
        figures.plot_scatterograms(rows, row_labels=["one"])


def test_cli_scatterogram(tmp_path, capsys):
    rc = cli.main(["scatterogram", "--preset", "green", "custom", "--resolution", "6", "--wavelengths", "420", "680",
                   "4", "--beam", "0", "0", "--beam", "30", "90", "--out", str(tmp_path), "--name", "sg", "--dpi", "40"])
    assert rc == 0
    assert (tmp_path / "sg.png").read_bytes()[:4] == b"\x89PNG"
    with np.load(tmp_path / "sg.npz", allow_pickle=False) as z:
        assert z["xyz"].shape == (3, 2, 6, 6, 3)
    assert "sg.png" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:
        cli.main(["scatterogram", "--beam", "120", "0", "--out", str(tmp_path)])
    assert e.value.code == 2
    capsys.readouterr()
    with pytest.raises(SystemExit) as e:
        cli.main(["scatterogram", "--help"])
    assert e.value.code == 0 and "scatterometer" in capsys.readouterr().out
