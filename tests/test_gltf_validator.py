"""The exported glTF passes Khronos' glTF validator (npm's ``gltf-validator``, run under node;
``bash run.sh test`` installs it into .venv/node_modules, ``TORCHIRID_GLTF_VALIDATOR`` may name
another copy): no errors and no warnings, and a broken file is caught (a positive control)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from torchirid.export import write_thin_film_material

ROOT = Path(__file__).resolve().parents[1]
VALIDATOR = Path(os.environ.get("TORCHIRID_GLTF_VALIDATOR", ROOT / ".venv" / "node_modules" / "gltf-validator"))
SCRIPT = """
const [module, file] = process.argv.slice(-2);  // (node -e: the arguments follow the interpreter)
const validator = require(module);
const data = new Uint8Array(require('fs').readFileSync(file));
validator.validateBytes(data, {uri: file})
  .then((r) => console.log(JSON.stringify(r)))
  .catch((e) => { console.error(String(e)); process.exit(1); });
"""

pytestmark = [pytest.mark.integration,  # node and npm's gltf-validator
              pytest.mark.skipif(shutil.which("node") is None or not (VALIDATOR / "package.json").is_file(),
                                 reason="node or npm's gltf-validator missing (bash run.sh test installs it)")]


def _validate(path: Path) -> dict:
    run = subprocess.run(["node", "-e", SCRIPT, str(VALIDATOR), str(path)], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    return json.loads(run.stdout)["issues"]


@pytest.mark.parametrize("kw", [dict(n_film=1.33, thickness=(100.0, 700.0)),
                                dict(n_film=1.45, thickness=300.0, n_substrate=1.52, roughness=0.3),
                                dict(n_film=1.38, thickness=(50.0, 900.0), n_substrate=complex(0.2, 3.0))])
def test_exported_gltf_has_no_errors_or_warnings(tmp_path, kw):
    (path,) = write_thin_film_material(tmp_path / "film.gltf", kw.pop("n_film"), kw.pop("thickness"), **kw)
    issues = _validate(path)
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]


def test_the_validator_catches_a_broken_file(tmp_path):
    (path,) = write_thin_film_material(tmp_path / "film.gltf", 1.33, 300.0)
    doc = json.loads(path.read_text())
    doc["materials"][0]["extensions"]["KHR_materials_iridescence"]["iridescenceFactor"] = -1.0  # out of range
    del doc["asset"]
    path.write_text(json.dumps(doc))
    assert _validate(path)["numErrors"] > 0
