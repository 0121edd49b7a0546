import json

import numpy as np
import pytest

from torchirid.app.cli import main
from torchirid.app.figures.thin_film_ibl import THIN_FILM_IBL_METHODS, thin_film_ibl_comparison


def test_comparison_panel_shapes_and_claims():
    p = thin_film_ibl_comparison("thickness", resolution=6)
    assert p.xyz["reference"].shape == (6, 6, 3) and p.albedo.shape == (6, 6)
    assert set(p.delta_e) == {k for k, _ in THIN_FILM_IBL_METHODS}
    assert np.all((p.albedo > 0) & (p.albedo <= 1 + 1e-9))
    s = p.stats()
    assert s["fitted"]["mean"] < s["kneiphof"]["mean"] < s["original"]["mean"]
    np.testing.assert_allclose(p.columns, (np.arange(6) + 0.5) / 6 * 1000)
    with pytest.raises(ValueError, match="panel"):
        thin_film_ibl_comparison("colour")


def test_cli_thin_film(tmp_path, capsys):
    assert main(["thin-film", "--resolution", "4", "--out", str(tmp_path), "--dpi", "40"]) == 0
    for name in ("thin_film.png", "thin_film_roughness.npz", "thin_film_thickness.npz", "thin_film.json"):
        assert (tmp_path / name).stat().st_size > 0
    report = json.loads((tmp_path / "thin_film.json").read_text())
    assert set(report) == {"roughness", "thickness"}
    with np.load(tmp_path / "thin_film_roughness.npz", allow_pickle=False) as z:
        assert z["xyz_fitted"].shape == (4, 4, 3)
    assert "ΔE2000" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["thin-film", "--n-film", "0.5", "--out", str(tmp_path)])
