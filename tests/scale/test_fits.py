"""Batch fitting (issue 24.3): many cubes / scatterograms, one result table with per-item status;
a bad input is reported and the rest finish; in process and on a LocalCluster of 2 workers."""

from __future__ import annotations

import csv
import json

import pytest
import torch

import torchirid.estimation as E
from torchirid.scale import fit_batch, write_results
from torchirid.scale.fits import fit_item

F64 = torch.float64


@pytest.fixture(scope="module")
def cubes(tmp_path_factory):
    """Two good cubes (different films), one corrupt file, one missing path."""
    folder = tmp_path_factory.mktemp("cubes")
    paths = []
    for name, sample, seed in (("a", "mgf2_400", 1), ("b", "mgf2_600", 2)):
        c = E.synthetic_cube(sample, height=4, width=5, seed=seed)
        E.write_npz(folder / f"{name}.npz", c.cube, c.wavelength, c.angles_deg)
        paths.append(folder / f"{name}.npz")
    (folder / "corrupt.npz").write_bytes(b"not a zip file at all")
    return [paths[0], folder / "corrupt.npz", paths[1], folder / "missing.npz"]


def _direct(path):
    cube = E.read_cube(path)
    return E.estimate_film(cube.cube, cube.wavelength, cube.cos_theta, 1.64)


def test_in_process_batch_reports_each_item(cubes):
    seen = []
    recs = fit_batch("film", cubes, progress=lambda d, t: seen.append((d, t)))
    assert [r["item"] for r in recs] == [str(p) for p in cubes]
    assert [r["status"] for r in recs] == ["ok", "error", "ok", "error"]
    assert recs[1]["error"].startswith("FileContentError") and "corrupt.npz" in recs[1]["error"]
    assert "does not exist" in recs[3]["error"] and recs[3]["n"] is None
    assert seen == [(1, 4), (2, 4), (3, 4), (4, 4)]
    for rec, path in ((recs[0], cubes[0]), (recs[2], cubes[2])):
        est = _direct(path)
        assert rec["n"] == float(est.n) and rec["pixels"] == 20 and rec["pixels_valid"] == 20
        assert rec["thickness_mean_nm"] == float(est.thickness.double().mean())
        assert rec["seconds"] > 0 and rec["error"] is None
    # the two films: MgF2 (n = 1.38) at ~400 and ~600 nm
    assert abs(recs[0]["n"] - 1.38) < 0.02 and abs(recs[0]["thickness_mean_nm"] - 400) < 40
    assert abs(recs[2]["thickness_mean_nm"] - 600) < 60


def test_fit_options_reach_the_fit(cubes):
    rec = fit_item("film", cubes[0], fit={"n_substrate": 1.64, "index_model_name": "cauchy"})
    assert rec["status"] == "ok" and rec["index_model"] == "cauchy" and len(rec["index_params"]) == 2
    bad = fit_item("film", cubes[0], fit={"index_model_name": "nonsense"})  # (a bad value: the item's error)
    assert bad["status"] == "error" and "index_model_name" in bad["error"]


def test_local_cluster_gives_the_in_process_records(cubes):
    pytest.importorskip("distributed", reason="needs dask.distributed")
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # the workers run one thread each: the same reductions, the same bits
    try:
        here = fit_batch("film", cubes)
    finally:
        torch.set_num_threads(threads)
    seen = []
    there = fit_batch("film", cubes, scheduler="local", workers=2, progress=lambda d, t: seen.append(d))
    drop = lambda r: {k: v for k, v in r.items() if k != "seconds"}  # noqa: E731
    assert [drop(r) for r in there] == [drop(r) for r in here]
    assert sorted(seen) == [1, 2, 3, 4]


def test_scatterogram_batch(tmp_path):
    from torchirid.fitting import render_targets, write_scatterogram
    from torchirid.presets import jewel_beetle

    lam = torch.linspace(380.0, 780.0, 41, dtype=F64)
    target = render_targets(jewel_beetle("green"), [(0.0, 0.0)], resolution=12, wavelength=lam)[0]
    good = write_scatterogram(tmp_path / "green.png", target / float(target[..., 1].max()) * 0.8)
    (tmp_path / "empty.png").write_bytes(b"")
    fit = dict(incident_deg=(0.0, 0.0), n1=1.59, cells=(8,), period_range=None, wavelength=lam,
               init={"period": 166.0, "delta": 0.51, "dn": 0.08, "alpha": 0.07}, short_iter=4, max_iter=6)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # (hundreds of small renders: see tests/fitting)
    try:
        recs = fit_batch("scatterogram", [good, tmp_path / "empty.png"], fit=fit)
    finally:
        torch.set_num_threads(threads)
    assert [r["status"] for r in recs] == ["ok", "error"]
    assert recs[0]["cells"] == 8 and abs(recs[0]["period_nm"] - 166.0) < 10 and recs[0]["delta_e2000"] < 5
    assert "empty.png" in recs[1]["error"]


def test_result_tables(tmp_path, cubes):
    recs = [fit_item("film", cubes[0]), fit_item("film", cubes[3])]
    recs[0]["rms_mean"] = float("nan")  # a non-finite figure: null in JSON, empty in CSV
    back = json.loads(write_results(tmp_path / "r.json", recs).read_text())
    assert [r["status"] for r in back] == ["ok", "error"] and back[0]["rms_mean"] is None
    assert back[0]["index_params"] == recs[0]["index_params"]
    with open(write_results(tmp_path / "sub" / "r.csv", recs), newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows[0]["status"] == "ok" and rows[0]["rms_mean"] == "" and float(rows[0]["n"]) == recs[0]["n"]
    assert rows[1]["error"].startswith("ValueError") and rows[1]["n"] == ""
    try:
        import pyarrow.parquet as pq
    except ImportError:
        with pytest.raises(ValueError, match="pyarrow"):
            write_results(tmp_path / "r.parquet", recs)
    else:
        table = pq.read_table(write_results(tmp_path / "r.parquet", recs)).to_pylist()
        assert [r["status"] for r in table] == ["ok", "error"]
    with pytest.raises(ValueError, match=r"\.json, \.csv or \.parquet"):
        write_results(tmp_path / "r.txt", recs)


@pytest.mark.parametrize("call, match", [
    (lambda: fit_batch("films", ["a.npz"]), "kind"),
    (lambda: fit_batch("film", "a.npz"), "items"),
    (lambda: fit_batch("film", []), "items"),
    (lambda: fit_batch("film", ["a.npz"], fit=[1]), "fit"),
    (lambda: fit_batch("film", ["a.npz"], progress=True), "progress"),
    (lambda: fit_batch("film", ["a.npz"], fit={"bogus": 1}), "bogus"),
    (lambda: fit_batch("film", ["a.npz"], fit={"wavelength": 1}), "comes from each file"),
    (lambda: fit_batch("film", ["a.npz"], read={"exposure": 2}), "exposure"),
    (lambda: fit_batch("film", ["a.npz"], fit={"thickness_range": [2e-8, 2e-6]}), "in nm"),
    (lambda: fit_batch("scatterogram", ["a.png"], fit={"period_range": [300, 100]}), "period_range"),
])
def test_bad_arguments(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_cli_fit_batch(tmp_path, cubes, capsys):
    from torchirid.app.cli import main

    out = tmp_path / "fits.csv"
    assert main(["fit-batch", "film", *map(str, cubes), "--set", "n_substrate=1.64", "--out", str(out),
                 "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "2 of 4 items fitted (0 flagged), 2 failed" in text and str(out) in text
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["status"] for r in rows] == ["ok", "error", "ok", "error"]
    with pytest.raises(SystemExit) as e:
        main(["fit-batch", "film", str(cubes[0]), "--out", str(tmp_path / "x.txt")])
    assert e.value.code == 2 and ".json, .csv or .parquet" in capsys.readouterr().err


def test_cli_fit_batch_fails_when_no_file_was_fitted(tmp_path, cubes, capsys):
    """Issue 35.2: every file failed → exit status 1 (a failure after the checks), the table still written."""
    from torchirid.app.cli import main

    out = tmp_path / "fits.csv"
    assert main(["fit-batch", "film", str(cubes[1]), str(cubes[3]), "--out", str(out), "--quiet"]) == 1
    io = capsys.readouterr()
    assert "0 of 2 items fitted" in io.out
    assert "torchirid fit-batch: error: no file was fitted (2 of 2 failed" in io.err and str(out) in io.err
    with open(out, newline="") as f:
        assert [r["status"] for r in csv.DictReader(f)] == ["error", "error"]


@pytest.fixture(scope="module")
def zns_cube(tmp_path_factory):
    """Kobayashi's dispersive ZnS film (Sample 3), 6 × 6 pixels: a constant index misfits it."""
    c = E.synthetic_cube("zns_500", height=6, width=6, seed=0)
    path = tmp_path_factory.mktemp("zns") / "zns_500.npz"
    E.write_npz(path, c.cube, c.wavelength, c.angles_deg)
    return path, c


def test_a_flagged_fit_is_not_ok(zns_cube, tmp_path, capsys):
    """Issue 35.2: a fit the estimate itself doubts (here a constant index on a dispersive film: the
    residual far above the noise) is "flagged" with its reason, in the records, the table and the
    command's summary — and the command exits 0 (it was fitted)."""
    path, truth = zns_cube
    with pytest.warns(RuntimeWarning, match="noise level"):
        rec = fit_item("film", path, fit={"index_model_name": "constant"})
    assert rec["status"] == "flagged" and rec["error"] is None
    assert "noise level" in rec["flags"] and "index_model_name='auto'" in rec["flags"]
    assert rec["index_model"] == "constant" and rec["n"] is not None  # the figures are still there
    good = fit_item("film", path)  # the default (auto): a Cauchy index, no flag
    assert good["status"] == "ok" and good["flags"] is None and good["index_model"].startswith("cauchy")
    assert abs(good["thickness_mean_nm"] - float(truth.thickness.mean())) < 5.0
    from torchirid.app.cli import main

    out = tmp_path / "fits.json"
    with pytest.warns(RuntimeWarning):
        assert main(["fit-batch", "film", str(path), "--set", "index_model_name=constant", "--out", str(out),
                     "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "1 of 1 items fitted (1 flagged), 0 failed" in text and "flagged: estimate_film: the median RMS" in text
    (row,) = json.loads(out.read_text())
    assert row["status"] == "flagged" and "noise level" in row["flags"]


def test_an_index_search_fallback_and_an_ambiguous_match_are_flagged(cubes, tmp_path, monkeypatch):
    """The other flags: a film fit whose index search fell back from the peaks to a grid (its
    ``settings["flags"]``), and an ambiguous scatterogram match."""
    from types import SimpleNamespace

    import torchirid.fitting as F
    from torchirid.estimation.estimate import RESTART_FLAG

    real = E.estimate_film

    def fell_back(*args, **kwargs):
        est = real(*args, **kwargs)
        est.settings["flags"] = [RESTART_FLAG]  # (what estimate_film reports when the grid overrules the peaks)
        return est

    monkeypatch.setattr(E, "estimate_film", fell_back)
    rec = fit_item("film", cubes[0], fit={"iterations": 1, "final_iterations": 0})
    assert rec["status"] == "flagged" and "fell back" in rec["flags"]
    alt = SimpleNamespace(label="2Λ", near_degenerate=True)
    fit = SimpleNamespace(period=160.0, delta=0.5, n1=1.59, n2=1.67, cells=8, alpha=0.05, exposure=1.0, loss=0.1,
                          delta_e2000=0.5, iterations=3, alternatives=(alt,), ambiguous=True)
    monkeypatch.setattr(F, "match_scatterogram", lambda *a, **k: fit)
    png = F.write_scatterogram(tmp_path / "s.png", torch.full((8, 8, 3), 0.3, dtype=F64))
    rec = fit_item("scatterogram", png)
    assert rec["status"] == "flagged" and rec["flags"].startswith("ambiguous") and "2Λ" in rec["flags"]
    assert rec["period_nm"] == 160.0


@pytest.mark.slow
def test_the_zns_batch_fits_by_default(tmp_path, capsys):
    """Issue 35.2's case: ``fit-batch film mgf2_400.npz mgf2_600.npz zns_500.npz --set n_substrate=1.64``
    on Kobayashi's three samples (16 × 16 pixels, seed 2: ZnS 502.6 nm thick on average). With the old
    default (a constant index) ZnS came out ~616 nm; by default (auto) it is within 5 nm, and every
    row is "ok"."""
    from torchirid.app.cli import main

    paths, truth = [], {}
    for name in ("mgf2_400", "mgf2_600", "zns_500"):
        c = E.synthetic_cube(name, height=16, width=16, seed=2)
        paths.append(tmp_path / f"{name}.npz")
        E.write_npz(paths[-1], c.cube, c.wavelength, c.angles_deg)
        truth[name] = float(c.thickness.mean())
    assert round(truth["zns_500"], 1) == 502.6
    out = tmp_path / "fits.json"
    assert main(["fit-batch", "film", *map(str, paths), "--set", "n_substrate=1.64", "--out", str(out), "--quiet"]) == 0
    assert "3 of 3 items fitted (0 flagged), 0 failed" in capsys.readouterr().out
    rows = {r["item"].rsplit("/", 1)[-1][:-4]: r for r in json.loads(out.read_text())}
    assert [r["status"] for r in rows.values()] == ["ok", "ok", "ok"]
    assert rows["zns_500"]["index_model"].startswith("cauchy")
    for name, d in truth.items():
        assert abs(rows[name]["thickness_mean_nm"] - d) < 5.0, (name, rows[name]["thickness_mean_nm"], d)
