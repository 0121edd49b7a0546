"""Every torchirid name the README and docs/ mention exists (issue 22.9: the README named
``estimation.read_cube``, which was not there).

A reference is backticked text whose first dotted part is ``torchirid`` or one of its
subpackages/modules (``optics.multilayer``, ``torchirid.ibl.thin_film_xyz_fitted(...)``,
``spectral.piecewise.MIN_FRINGES``); a call's arguments are ignored. It resolves by importing
the longest module prefix and getting the rest as attributes."""

from __future__ import annotations

import importlib
import pkgutil
import re
from pathlib import Path

import pytest

import torchirid

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", ROOT / "CHANGELOG.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "docs" / "guide").glob("*.md")),
        ROOT / "luts" / "README.md", ROOT / "training" / "README.md", ROOT / "benchmarks" / "README.md"]
TOP = {m.name for m in pkgutil.iter_modules(torchirid.__path__)} - {"__main__"}
NAME = re.compile(r"^(?:torchirid\.)?([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*)(\(.*\))?$")
# old names quoted on purpose (the changelog's renames, "was"/"not" columns)
OLD_NAME_CONTEXT = re.compile(r"→|\bwas\b|\bold\b|\bno longer\b|\bremoved\b|\brenamed\b|\bnot\b|\|\s*`[^`]*`\s*\|", re.I)


def _lines(doc):
    """The lines to check: the changelog's latest section only (older sections quote the names of
    their time), every line elsewhere."""
    lines = doc.read_text(encoding="utf-8").splitlines()
    if doc.name == "CHANGELOG.md":
        heads = [i for i, line in enumerate(lines) if line.startswith("## ")]
        if len(heads) > 1:
            lines = lines[: heads[1]]
    return enumerate(lines, 1)


def _references():
    for doc in DOCS:
        if not doc.exists():
            continue
        for lineno, line in _lines(doc):
            for text in re.findall(r"`([^`\n]+)`", line):
                m = NAME.match(text.strip())
                if not m:
                    continue
                parts = m.group(1).split(".")
                explicit = text.strip().startswith("torchirid.")
                if not explicit and (parts[0] not in TOP or len(parts) < 2):
                    continue
                yield doc.relative_to(ROOT).as_posix(), lineno, line, parts


def _resolve(parts) -> bool:
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(["torchirid", *parts[:cut]]))
        except ImportError:
            continue
        try:
            for p in parts[cut:]:
                obj = getattr(obj, p)
        except AttributeError:
            return False
        return True
    obj = torchirid
    try:
        for p in parts:
            obj = getattr(obj, p)
    except AttributeError:
        return False
    return True


def test_docs_reference_names_that_exist():
    refs = list(_references())
    assert len(refs) > 100, "the reference extraction found too little"
    missing = []
    for doc, lineno, line, parts in refs:
        if _resolve(parts):
            continue
        if doc == "CHANGELOG.md" and OLD_NAME_CONTEXT.search(line):
            continue  # a rename or removal: the old name is quoted on purpose
        missing.append(f"{doc}:{lineno}: {'.'.join(parts)}")
    assert not missing, "names in the docs that do not exist:\n" + "\n".join(missing)


def _all_names() -> set[str]:
    out = set()
    for m in pkgutil.walk_packages(torchirid.__path__, "torchirid."):
        if m.name.endswith("__main__"):
            continue
        out |= set(dir(importlib.import_module(m.name)))
    return out


PLACEHOLDERS = {"f"}  # `f(wavelength, cos_theta, ...)`: the generic signature in docs/architecture.md


def test_docs_calls_name_functions_that_exist():
    """A bare call in backticks (``bragg_xyz(...)``, ``read_cube(path, ...)``) names a function of
    some torchirid module."""
    names = _all_names()
    missing = []
    for doc in DOCS:
        if not doc.exists() or doc.name == "CHANGELOG.md":
            continue
        for lineno, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), 1):
            for text in re.findall(r"`([^`\n]+)`", line):
                m = re.match(r"^([A-Za-z_]\w*)\(", text.strip())
                if m and m.group(1) not in names and m.group(1) not in PLACEHOLDERS:
                    missing.append(f"{doc.relative_to(ROOT).as_posix()}:{lineno}: {m.group(1)}")
    assert not missing, "calls in the docs to functions that do not exist:\n" + "\n".join(missing)
