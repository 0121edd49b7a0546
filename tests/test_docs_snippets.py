"""The code of the documentation pages runs as written (issue 26): the ```python blocks of
docs/getting_started.md and of each user-guide page (docs/guide/*.md) are executed in order,
one namespace per page, as a reader pastes them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
GUIDE = sorted((DOCS / "guide").glob("*.md"))


def _run(page: Path) -> None:
    blocks = re.findall(r"```python\n(.*?)```", page.read_text(encoding="utf-8"), flags=re.S)
    namespace: dict = {}
    for i, code in enumerate(blocks):
        exec(compile(code, f"{page.name}[block {i}]", "exec"), namespace)  # noqa: S102 (the docs' own code)


def test_getting_started_code_runs(capsys, tmp_path, monkeypatch):
    page = DOCS / "getting_started.md"
    assert len(re.findall(r"```python\n", page.read_text(encoding="utf-8"))) >= 4
    monkeypatch.chdir(tmp_path)  # the page writes cube.npz where the reader is
    _run(page)
    out = capsys.readouterr().out
    assert "torch.Size([90, 401])" in out and "torch.Size([90, 3])" in out
    assert (tmp_path / "cube.npz").is_file()  # the cube writer's file, for the page's torchirid fit-film


# what each guide page's code prints where it states a result (the rest must run without error)
EXPECTED = {
    "thin_films": ["torch.Size([90, 471]) True", "median 0.00"],
    "multilayers": ["torch.Size([20, 81]) True", "True"],
    "bragg_mirrors": ["torch.Size([90, 401]) True", "envelope: median ΔE2000 0."],
    "layered_brdfs": ["torch.Size([3, 41]) 1.000", "torch.Size([16, 16, 3])"],
    "film_estimation": ["(6, 6, 5, 81)", "peak method: n = 1.37"],
    "real_time": ["torch.Size([2, 3])", "True\nTrue"],
    "colour": ["Y = 0.500", "ΔE2000 from grey:"],
}


@pytest.mark.parametrize("page", GUIDE, ids=[p.stem for p in GUIDE])
def test_guide_page_code_runs(page, capsys):
    if page.stem == "mitsuba":  # the page renders in Mitsuba's LLVM variant
        pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (pip install 'torchirid[mitsuba]')")
        from torchirid.mitsuba.scenes import find_libllvm

        find_libllvm()
        import drjit as dr

        if not dr.has_backend(dr.JitBackend.LLVM):
            pytest.skip("Dr.Jit's LLVM backend is unavailable (needs libLLVM >= 16: apt-get install libllvm19)")
    _run(page)
    out = capsys.readouterr().out
    for text in EXPECTED.get(page.stem, []):
        assert text in out, f"{page.name}: expected {text!r} in its output:\n{out}"


def test_every_model_page_has_code_and_its_equations():
    for name in EXPECTED:  # the model-family pages (the guide's index is the other page)
        text = (DOCS / "guide" / f"{name}.md").read_text(encoding="utf-8")
        assert "```python" in text, name
        assert "{include} ../models.md" in text, f"{name}: no equation table from models.md"
        for section in ("## Which", "## Limits", "## Equations"):
            assert section in text, f"{name}: missing {section!r}"


def test_each_models_md_section_is_in_the_guide():
    """Every ``<!-- include: NAME -->`` block of models.md is shown by some guide page (the site
    excludes models.md itself), and every page's markers exist."""
    models = (DOCS / "models.md").read_text(encoding="utf-8")
    names = [n for n in re.findall(r"<!-- include: (\w+) -->", models) if n != "NAME"]  # NAME: the note on top
    assert len(names) >= 8
    guide = "\n".join(p.read_text(encoding="utf-8") for p in GUIDE)
    for name in names:
        assert f"<!-- end: {name} -->" in models, name
        assert f'"<!-- include: {name} -->"' in guide, f"models.md section {name!r} is shown by no guide page"
