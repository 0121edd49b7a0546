"""One default per parameter across the library, the command line and the batch tools (issue 35.2).

Each fit is called for real through its three doors — the library function, its ``torchirid``
command and ``fit_batch`` — with the library function replaced by a recorder that binds the
arguments it receives to the real signature (defaults applied) and stops. Every argument that
the caller did not give must arrive with the library's default: a second literal in the command
or in the batch tool that drifts from the library fails here. (estimate_film: fit-film and
fit-batch film; match_scatterogram: fit-batch scatterogram and the settings the scatterogram
command shares with it.)
"""

from __future__ import annotations

import inspect

import pytest
import torch

import torchirid.estimation as E
import torchirid.fitting as F
from torchirid.app import cli
from torchirid.app.commands import fit_film, scatterogram as scatterogram_command
from torchirid.layered import scatterogram as render_scatterogram
from torchirid.scale import fit_batch


class _Stop(Exception):
    """Raised by the recorder once it has the arguments (the fit itself is not the point)."""


def _defaults(fn) -> dict:
    return {k: p.default for k, p in inspect.signature(fn).parameters.items() if p.default is not inspect.Parameter.empty}


def _recorder(fn, calls: list):
    sig = inspect.signature(fn)

    def record(*args, **kwargs):
        bound = sig.bind(*args, **kwargs)
        bound.apply_defaults()
        calls.append(dict(bound.arguments))
        raise _Stop

    return record


def _plain(value):
    """A setting as a comparable value: sequences of numbers as tuples of floats."""
    if isinstance(value, (list, tuple)):
        return tuple(_plain(v) for v in value)
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else value


@pytest.fixture(scope="module")
def cube_file(tmp_path_factory):
    """A one-pixel cube file without a stored band width (so fit-film falls back to the library's)."""
    c = E.synthetic_cube("mgf2_400", height=1, width=1, seed=0)
    path = tmp_path_factory.mktemp("cube") / "c.npz"
    E.write_npz(path, c.cube, c.wavelength, c.angles_deg)
    return path


def test_the_index_model_default_is_auto_everywhere():
    assert _defaults(E.estimate_film)["index_model_name"] == "auto"
    args = cli.build_parser().parse_args(["fit-film", "c.npz", "--out", "o"])
    assert args.index_model == "auto"
    # index_model / fit_index_model take the model by name, without a default: it fixes the parameter count
    for fn in (E.index_model, E.fit_index_model):
        assert inspect.signature(fn).parameters["model"].default is inspect.Parameter.empty


def test_estimate_film_gets_the_same_defaults_from_fit_film_and_fit_batch(cube_file, tmp_path, monkeypatch):
    library = _defaults(E.estimate_film)
    from_cli, from_batch = [], []
    monkeypatch.setattr(fit_film, "estimate_film", _recorder(E.estimate_film, from_cli))
    with pytest.raises(_Stop):
        cli.main(["fit-film", str(cube_file), "--out", str(tmp_path / "fit"), "--quiet"])
    monkeypatch.setattr(E, "estimate_film", _recorder(E.estimate_film, from_batch))
    (rec,) = fit_batch("film", [cube_file])
    assert rec["status"] == "error" and "_Stop" in rec["error"]
    (cli_call,), (batch_call,) = from_cli, from_batch
    for name, default in library.items():
        if name == "progress":  # (the command draws a progress bar)
            continue
        assert _plain(cli_call[name]) == _plain(default), f"fit-film passes {name}={cli_call[name]!r}, not {default!r}"
        assert _plain(batch_call[name]) == _plain(default), f"fit-batch passes {name}={batch_call[name]!r}"
    # n_substrate has no library default (a required argument); the command and the batch agree (PET)
    assert cli_call["n_substrate"] == batch_call["n_substrate"] == 1.64
    # and the parser's own defaults are the library's (what --help shows)
    args = cli.build_parser().parse_args(["fit-film", "c.npz", "--out", "o"])
    for option, name in (("index_model", "index_model_name"), ("polarization", "polarization"),
                         ("passband", "passband"), ("thickness_range", "thickness_range"),
                         ("smoothness", "smoothness"), ("seed", "seed")):
        assert _plain(getattr(args, option)) == _plain(library[name]), option


def test_match_scatterogram_gets_its_defaults_from_fit_batch(tmp_path, monkeypatch):
    library = _defaults(F.match_scatterogram)
    path = F.write_scatterogram(tmp_path / "s.png", torch.full((8, 8, 3), 0.3, dtype=torch.float64))
    calls = []
    monkeypatch.setattr(F, "match_scatterogram", _recorder(F.match_scatterogram, calls))
    (rec,) = fit_batch("scatterogram", [path])
    assert rec["status"] == "error" and "_Stop" in rec["error"]
    (call,) = calls
    for name, default in library.items():
        if name == "mask":  # (the file's valid pixels)
            continue
        assert _plain(call[name]) == _plain(default), f"fit-batch passes {name}={call[name]!r}, not {default!r}"


def test_the_scatterogram_command_shares_the_matchers_defaults():
    """The command renders (layered.scatterogram); the settings it shares with the matcher — the
    angular mapping, the reflectance, the medium, the base, the beam — have one default. (Its
    wavelength grid is the renderer's, 81 values over 380–780 nm; the matcher's model spectra
    default to 41 over the same range, the sampling its measured fit accuracy is stated for.)"""
    match, render = _defaults(F.match_scatterogram), _defaults(render_scatterogram)
    args = cli.build_parser().parse_args(["scatterogram"])
    assert args.projection == match["projection"] == render["projection"]
    assert _defaults(F.read_scatterogram)["projection"] == match["projection"]
    assert ("lut" if args.lut else "exact") == match["reflectance"] == render["reflectance"]
    assert args.n_incident == match["n_incident"] and args.base_albedo == match["base_albedo"]
    assert _plain(scatterogram_command.DEFAULT_BEAM) == _plain(match["incident_deg"])
    assert [float(v) for v in args.wavelengths[:2]] == [380.0, 780.0]
