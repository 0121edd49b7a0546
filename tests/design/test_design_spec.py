"""torchirid.design.spec: the TOML keys, and one error naming the key for every bad entry."""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest

from torchirid import design
from torchirid.design.problem import SpecError

GOOD = """
name = "mirror"
incident = "air"
exit = "glass"
min_thickness = 5.0
max_total_thickness = 3000.0
max_layers = 12

[optimiser]
method = "global"
seed = 3
time_limit = 20.0
goal = 0.01

[[layers]]
pattern = ["TiO2", "SiO2"]
repeat = 3
thickness = [10.0, 200.0]

[[layers]]
material = ["TiO2", 2.1]
thickness = 80.0

[[targets]]
quantity = "R"
wavelength = {start = 500.0, stop = 600.0, count = 11}
angle_deg = [0.0, 30.0]
weight = 2.0
p = 1

[[targets]]
type = "colour"
lab = [[60.0, 10.0, 50.0], [55.0, -30.0, 20.0]]
angle_deg = [0.0, 60.0]
illuminant = "D50"

[robust]
sigma = 1.5
objective = "cvar"
samples = 16

[tolerance]
sigma = 1.0
samples = 500
merit_limit = 0.1
"""


def _write(tmp_path, text):
    path = tmp_path / "spec.toml"
    path.write_text(textwrap.dedent(text))
    return path


def test_every_key_is_read(tmp_path):
    p, opts, tol = design.read_spec(_write(tmp_path, GOOD))
    assert p.name == "mirror" and p.n_incident == "air" and p.n_substrate == "glass"
    assert (p.min_thickness, p.max_total_thickness, p.max_layers) == (5.0, 3000.0, 12)
    assert [layer.candidates[0] for layer in p.layers[:6]] == ["TiO2", "SiO2"] * 3
    assert p.layers[6].candidates == ("TiO2", 2.1) and p.layers[6].thickness == 80.0
    assert p.free_thicknesses == 6 and p.choices == 1
    spectral, colour = p.targets
    np.testing.assert_allclose(spectral.wavelength, np.linspace(500, 600, 11))
    np.testing.assert_allclose(spectral.cos_theta, [1.0, math.cos(math.radians(30))])
    assert spectral.p == 1 and spectral.weight == (2.0,) * 11
    assert colour.illuminant == "D50" and colour.lab[1] == (55.0, -30.0, 20.0)
    assert p.robust.objective == "cvar" and p.robust.sigma == (1.5,) * 7
    assert opts == {"method": "global", "seed": 3, "time_limit": 20.0, "goal": 0.01}
    assert tol == {"sigma": 1.0, "samples": 500, "merit_limit": 0.1}


def test_wavelength_forms_and_tables(tmp_path):
    csv = tmp_path / "film.csv"
    csv.write_text("# nm, n, k\n400, 1.60, 0.01\n800, 1.50, 0.0\n")
    p, _, _ = design.read_spec(_write(tmp_path, f"""
        [[layers]]
        material = {{file = "{csv}"}}
        thickness = [0, 100]
        [[layers]]
        material = {{wavelength = [400.0, 800.0], n = [1.4, 1.3]}}
        thickness = 50
        [[targets]]
        quantity = "T"
        wavelength = {{start = 450.0, stop = 650.0, step = 50.0}}
        weight = "AM1.5G photon flux"
        """))
    assert p.targets[0].wavelength == (450.0, 500.0, 550.0, 600.0, 650.0)
    table = p.layers[0].candidates[0]
    assert table[0] == "table" and table[3] == (0.01, 0.0)
    d = design.optimise(p, seed=0)  # tables work through the whole pipeline
    assert len(d.layers) == 2 and d.layers[0]["material"] == "table"


BAD = [
    ("unknown top-level key", "colour = 1", "colour: unknown key"),
    ("unknown target key", None, "targets[0].wavelenght: unknown key"),
    ("min > max", "[[layers]]\nmaterial = 1.5\nthickness = [200.0, 10.0]", "layers[1].thickness: min 200 > max 10"),
    ("thickness in metres", "[[layers]]\nmaterial = 1.5\nthickness = 1e-7", "layers[1].thickness"),
    ("unknown material", "[[layers]]\nmaterial = \"unobtainium\"\nthickness = 10.0", "layers[1].material"),
    ("radians", None, "targets[0].angle_deg"),
    ("material range", "[[layers]]\nmaterial = \"PET\"\nthickness = 10.0", "layers[1].material: defined over 400"),
    ("bad exit", "exit = \"unobtainium\"", "exit:"),
    ("bad optimiser value", "[optimiser]\nseed = 1.5", "optimiser.seed"),
    ("bad robust", "[robust]\nobjective = \"worst\"", "robust.objective"),
]


@pytest.mark.parametrize("case, extra, key", BAD, ids=[b[0] for b in BAD])
def test_a_bad_spec_names_the_key(tmp_path, case, extra, key):
    target = '[[targets]]\nquantity = "R"\nwavelength = [380.0, 550.0]\n'
    if case == "unknown target key":
        target = '[[targets]]\nquantity = "R"\nwavelenght = [550.0]\n'
    if case == "radians":
        target = '[[targets]]\nquantity = "R"\nwavelength = [550.0]\nangle_deg = [0.0, 0.5, 1.0]\n'
    head = "[[layers]]\nmaterial = 1.5\nthickness = [0.0, 100.0]\n"
    top, body = ("", extra) if extra and extra.startswith("[") else (extra or "", "")
    text = top + "\n" + head + body + "\n" + target
    with pytest.raises(SpecError) as err:
        design.read_spec(_write(tmp_path, text))
    assert str(err.value).startswith(key.split(":")[0]), str(err.value)
    assert key in str(err.value)
    assert "\n" not in str(err.value)


def test_missing_file_and_bad_toml(tmp_path):
    with pytest.raises(SpecError, match="no such file"):
        design.read_spec(tmp_path / "nope.toml")
    with pytest.raises(SpecError, match="not valid TOML"):
        design.read_spec(_write(tmp_path, "layers = [\n"))
