"""The package's layering rules (docs/architecture.md), checked on the source and at run time.

- the library never imports the application (``torchirid.app``), argparse, matplotlib or tqdm;
- a library layer imports only lower layers (the ranks below) and its own subpackage;
- no import cycle between modules (lazy imports inside functions count too);
- no ``_private`` name crosses a subpackage boundary, and a library package takes from another
  only names of that package's ``__all__`` or the declared shared kernels (``SHARED_KERNELS``);
- the public surface: a module's ``__all__`` holds only names its package exports (no second
  tier), and the root and the subpackages stay within the name budget;
- no module is shadowed by a function of its package; every subpackage has an explicit
  ``__all__``;
- the public signatures speak one vocabulary (docs/conventions.md).
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import re
from pathlib import Path

import pytest

import torchirid

SRC = Path(torchirid.__file__).resolve().parent

#: Layer of each top-level part of the package: a module may import only from a lower rank (or
#: from its own subpackage). ``<root>`` is ``torchirid/__init__.py``.
RANKS = {
    # shared internals: the version and the cache registry below the rest
    "_version": 0, "_cache": 0,
    "_checks": 0.5, "_compile": 0.5, "_quadrature": 0.5, "_io": 0.5, "_lut_file": 0.5,
    "_autograd": 0.6,  # inference mode / autograd around public calls (uses _checks.traceable)
    "_threads": 0.6,  # the small-work thread policy (uses _checks.traceable)
    "_chunks": 0.75,  # block-wise evaluation (uses _checks.traceable, _threads)
    "_options": 0.8,
    "_shipped": 1.5,  # reading a shipped table or building it (uses lut.LUT)  # torchirid.options(): the switches of _checks, _chunks, _threads, _compile
    # tables, materials, colorimetry: no optics inside
    "lut": 1, "materials": 1, "color": 1,
    # exact optics and microfacets
    "optics": 2, "microfacet": 2,
    # geometry and the colour of structures
    "layered": 3, "spectral": 3,
    # products
    "ibl": 4, "estimation": 4, "export": 4,
    "fitting": 5,
    # inverse design: optimisers over the optics and colour of stacks
    "design": 5,
    # the papers' structures: built from optics, layered and estimation
    "presets": 4.5,
    # scale-out above the products: distributes library calls (table builds, Monte Carlo, fits)
    "scale": 5.5,
    # renderer plugins: the library's materials as Mitsuba 3 BSDFs (opt-in: not imported by the root)
    "mitsuba": 5.5,
    # real time: textures for shaders fitted to the products' exact colours
    "realtime": 5,
    # the curated public API
    "<root>": 6,
    # the application
    "app": 7, "__main__": 8,
}
APPLICATION = ("app", "__main__")
FORBIDDEN_IN_LIBRARY = ("argparse", "matplotlib", "tqdm")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(SRC.rglob("*.py"))}


def _part(module: str) -> str:
    """Top-level part of a module name: ``torchirid.optics.bragg`` → ``optics``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "<root>"


def _imports(module: str):
    """(line, imported module, imported name or None) for every import in ``module``."""
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name, None
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for alias in node.names:
                full = f"{target}.{alias.name}"
                if full in MODULES:  # `from . import x` of a submodule
                    yield node.lineno, full, None
                else:
                    yield node.lineno, target, alias.name


def _graph() -> dict[str, set[str]]:
    graph = {m: set() for m in MODULES}
    for m in MODULES:
        for _, target, _ in _imports(m):
            if target in MODULES and target != m:
                graph[m].add(target)
    return graph


def test_every_part_has_a_rank():
    assert {_part(m) for m in MODULES} <= set(RANKS), {_part(m) for m in MODULES} - set(RANKS)


def test_library_does_not_import_the_application_or_its_tools():
    bad = []
    for m in MODULES:
        if _part(m) in APPLICATION:
            continue
        for line, target, _ in _imports(m):
            if target.split(".")[0] in FORBIDDEN_IN_LIBRARY or _part(target) in APPLICATION and target.startswith(
                    "torchirid"):
                bad.append(f"{m}:{line} imports {target}")
    assert not bad, "\n".join(bad)


def test_imports_point_downwards():
    bad = []
    for m in MODULES:
        for line, target, _ in _imports(m):
            if not target.startswith("torchirid") or target not in MODULES and _part(target) not in RANKS:
                continue
            src, dst = _part(m), _part(target)
            if src != dst and RANKS[dst] >= RANKS[src]:
                bad.append(f"{m}:{line} ({src}, rank {RANKS[src]}) imports {target} ({dst}, rank {RANKS[dst]})")
    assert not bad, "\n".join(bad)


def test_no_import_cycles():
    graph = _graph()
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    assert not cycles, cycles


def test_the_cycle_check_can_fail():
    """The graph builder sees lazy imports inside functions (they make cycles too)."""
    graph = _graph()
    assert "torchirid._checks" in graph["torchirid.optics.bragg"]
    assert all(isinstance(v, set) for v in graph.values())


def test_no_private_name_crosses_a_subpackage():
    bad = []
    for m in MODULES:
        for line, target, name in _imports(m):
            if not target.startswith("torchirid"):
                continue
            src, dst = _part(m), _part(target)
            if src == dst or dst.startswith("_"):  # own subpackage, or the shared internals
                continue
            private_module = any(p.startswith("_") and not p.startswith("__") for p in target.split(".")[2:])
            private_name = name is not None and name.startswith("_") and not name.startswith("__")
            if private_module or private_name:
                bad.append(f"{m}:{line} imports {target}{'.' + name if name else ''}")
    assert not bad, "\n".join(bad)


#: Kernels that a library package takes from another package's modules without making them public
#: API (docs/architecture.md, "Rules"): module → names. A new entry is a design decision: either
#: the kernel belongs here, or the caller should use a public function.
SHARED_KERNELS = {
    # the colour-matching tables as NumPy, and the observer/illuminant name checks
    "torchirid.color.colorimetry": ("weighted_cmfs_numpy", "check_illuminant", "check_observer"),
    # the colour weights of a wavelength grid that the caller built itself (no checks)
    "torchirid.color.convert": ("xyz_weights_kernel",),
    # the complex interface amplitudes, admittances and normal wavenumbers of a stack
    "torchirid.optics.fresnel": ("admittance", "interface", "normal_wavenumber"),
    # Yeh's closed form on prepared tensors (no checks): the envelope colour evaluates it per node;
    # the mirror's arguments checked once and the unchecked reflectance (the spectral colour's blocks)
    "torchirid.optics.bragg": ("yeh_reflectance_kernel", "prepare_bragg_mirror", "bragg_reflectance_kernel"),
    # Kobayashi's samples: synthetic_cube renders them by name; torchirid.presets publishes them
    "torchirid.estimation.synthetic": ("SAMPLES",),
    # a stack's interface terms computed once and its response to many thickness sets (the design
    # optimisers' populations)
    "torchirid.optics.transfer": ("stack_pieces", "stack_response", "stack_fluxes"),
    # GGX D, Smith G1 and the mirror direction without the argument checks (inner loops of quadratures)
    "torchirid.microfacet.ggx": ("ggx_d_kernel", "smith_g1_kernel", "reflect_kernel"),
}


def _public_names(package: str) -> set[str]:
    return set(importlib.import_module(package).__all__)


def test_cross_package_imports_are_public_or_declared():
    """A library package imports from another one only its public names (its ``__all__``) or a
    kernel declared in ``SHARED_KERNELS`` (the application may use any non-private name)."""
    bad = []
    for m in MODULES:
        src = _part(m)
        if src in APPLICATION or src == "<root>" or src.startswith("_"):
            continue
        for line, target, name in _imports(m):
            if not target.startswith("torchirid.") or name is None:
                continue
            dst = _part(target)
            if dst == src or dst.startswith("_") or dst in APPLICATION:
                continue
            package = f"torchirid.{dst}"
            if package not in MODULES:
                continue
            if name in _public_names(package) or name in SHARED_KERNELS.get(target, ()):
                continue
            bad.append(f"{m}:{line} imports {target}.{name}")
    assert not bad, "\n".join(bad)


def test_shared_kernels_exist_and_are_not_public():
    for module, names in SHARED_KERNELS.items():
        mod = importlib.import_module(module)
        package = ".".join(module.split(".")[:2])
        for name in names:
            assert hasattr(mod, name), f"{module}.{name} is declared shared but does not exist"
            assert name not in _public_names(package), f"{module}.{name} is public: no need to declare it"


def _public_packages():
    for info in pkgutil.iter_modules(torchirid.__path__):
        if not info.name.startswith("_") and info.name != "app":
            yield importlib.import_module(f"torchirid.{info.name}")


def test_no_second_tier():
    """A module's ``__all__`` lists only names its package's ``__all__`` exports: a package's
    ``__all__`` is its whole public surface."""
    bad = []
    for package in _public_packages():
        if not hasattr(package, "__path__"):
            continue
        exported = set(package.__all__)
        for info in pkgutil.walk_packages(package.__path__, prefix=f"{package.__name__}."):
            if any(p.startswith("_") for p in info.name.split(".")[1:]):
                continue
            module = importlib.import_module(info.name)
            bad += [f"{info.name}.{n}" for n in getattr(module, "__all__", []) if n not in exported]
    assert not bad, "\n".join(bad)


#: the public surface's budget (benchmarks/api_surface.py prints the figures): names of the root's
#: ``__all__``, and unique names over the root and every public subpackage's ``__all__``
ROOT_BUDGET, PUBLIC_BUDGET = 45, 180


def test_public_surface_budget():
    subpackages = {p.__name__.split(".")[1] for p in _public_packages()}
    unique = {n for n in torchirid.__all__ if n not in subpackages and n != "__version__"}
    for package in _public_packages():
        unique |= set(package.__all__)
    assert len(torchirid.__all__) <= ROOT_BUDGET, len(torchirid.__all__)
    assert len(unique) <= PUBLIC_BUDGET, len(unique)


def test_root_names_resolve_lazily():
    """``import torchirid`` imports no subpackage; each root name resolves on first use."""
    import subprocess
    import sys

    code = ("import sys, torchirid; assert not [m for m in sys.modules if m.startswith('torchirid.') "
            "and m.split('.')[1] in torchirid._SUBPACKAGES], sorted(sys.modules)\n"
            "missing = [n for n in torchirid.__all__ if getattr(torchirid, n, None) is None]\n"
            "assert not missing, missing")
    subprocess.run([sys.executable, "-c", code], check=True)


def _packages():
    yield torchirid
    for info in pkgutil.walk_packages(torchirid.__path__, "torchirid."):
        if info.ispkg:
            yield importlib.import_module(info.name)


def test_no_module_is_shadowed_by_a_function():
    bad = []
    for package in _packages():
        for info in pkgutil.iter_modules(package.__path__):
            module = importlib.import_module(f"{package.__name__}.{info.name}")
            attribute = getattr(package, info.name, module)
            if attribute is not module:
                bad.append(f"{package.__name__}.{info.name} is {attribute!r}")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("package", [p.__name__ for p in _packages()])
def test_every_package_has_an_explicit_all(package):
    path = MODULES[package]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    assigned = [n for n in tree.body if isinstance(n, ast.Assign)
                and any(isinstance(t, ast.Name) and t.id == "__all__" for t in n.targets)]
    assert len(assigned) == 1, f"{package}: no single __all__ assignment"
    value = assigned[0].value
    assert isinstance(value, (ast.List, ast.Tuple)) and all(
        isinstance(e, ast.Constant) and isinstance(e.value, str) for e in value.elts), \
        f"{package}.__all__ must be a literal list of names"
    module = importlib.import_module(package)
    missing = [n for n in module.__all__ if not hasattr(module, n)]
    assert not missing, f"{package}.__all__ names missing attributes: {missing}"
    assert len(set(module.__all__)) == len(module.__all__), f"{package}.__all__ has duplicates"


# ------------------------------------------------------------------------------ vocabulary
#: parameter names replaced by the vocabulary of docs/conventions.md (old name → new name)
FORBIDDEN_PARAMETERS = {
    "n_outer": "n_incident", "n_host": "n_incident", "n_medium": "n_incident", "incident_medium": "n_incident",
    "host": "n_incident", "n_inner": "n_substrate", "n_exit": "n_substrate", "n_base": "n_substrate",
    "substrate": "n_substrate", "incident": "n_incident (a medium) or incident_deg (a beam)", "cos_in": "cos_theta_i", "cos_out": "cos_theta_o", "cos_light": "cos_theta_i",
    "cos_view": "cos_theta_o", "lambdas_nm": "periods", "thickness_nm": "thickness",
}
_COUNT_SUFFIXES = ("_nodes", "_cells", "_samples", "_bins", "_steps")


def _vocabulary_problem(name: str) -> str | None:
    if name in FORBIDDEN_PARAMETERS:
        return f"use {FORBIDDEN_PARAMETERS[name]!r}"
    if name.startswith("cos_") and not re.match(r"cos_(theta|phi)(_\w+)?$", name) and name != "cos_range":
        return "cosines are cos_theta[_suffix] or cos_phi"
    if re.search(r"theta|phi", name) and not name.startswith("cos_") \
            and not name.endswith(("_deg", "_rad")) and not name.endswith(_COUNT_SUFFIXES):
        return "a raw angle needs a _deg or _rad suffix (or pass its cosine)"
    return None


def _public_callables():
    seen = set()
    for package in _packages():
        if package.__name__.startswith("torchirid.app"):
            continue
        for name in getattr(package, "__all__", []):
            obj = getattr(package, name)
            candidates = []
            if inspect.isfunction(obj):
                candidates.append((f"{package.__name__}.{name}", obj))
            elif inspect.isclass(obj):
                candidates.append((f"{package.__name__}.{name}", obj.__init__))
                for attr, value in vars(obj).items():
                    if inspect.isfunction(value) and (not attr.startswith("_") or attr == "__call__"):
                        candidates.append((f"{package.__name__}.{name}.{attr}", value))
            for qual, fn in candidates:
                if fn in seen:
                    continue
                seen.add(fn)
                yield qual, fn


def test_public_signatures_use_the_vocabulary():
    bad = []
    count = 0
    for qual, fn in _public_callables():
        try:
            parameters = inspect.signature(fn).parameters
        except (TypeError, ValueError):
            continue
        for p in parameters:
            count += 1
            problem = _vocabulary_problem(p)
            if problem:
                bad.append(f"{qual}({p}): {problem}")
    assert count > 300  # the walk saw the API
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("name, ok", [("n_incident", True), ("n_outer", False), ("cos_theta_o", True),
                                      ("cos_in", False), ("theta_i", False), ("theta_i_rad", True),
                                      ("rotation_deg", True), ("theta_nodes", True), ("substrate", False)])
def test_the_vocabulary_rule_itself(name, ok):
    assert (_vocabulary_problem(name) is None) == ok


def test_reflectance_functions_take_wavelength_then_geometry():
    """Reflectance-like functions: ``(wavelength, cos_theta | directions, <structure…>)``."""
    from torchirid import layered, optics

    for fn in (optics.bragg_reflectance, optics.thin_film_reflectance, optics.multilayer, optics.film_reflectance,
               optics.rough_multilayer_reflectance, optics.bragg_dispersion, optics.bragg_envelope,
               layered.integrated_transmissivity, layered.importance_sampling.layer_reflection_probabilities):
        assert list(inspect.signature(fn).parameters)[:2] == ["wavelength", "cos_theta"], fn.__name__
    for fn in (layered.single_reflection_brdf, layered.single_reflection_pdf, layered.montecarlo_brdf):
        assert list(inspect.signature(fn).parameters)[:4] == ["wavelength", "wi", "wo", "structure"], fn.__name__


def test_test_module_basenames_are_unique():
    """tests/ has no __init__.py files: pytest imports test modules by basename, so two files of
    one name in different folders fail collection (tests/layered and tests/scale once did)."""
    root = Path(__file__).resolve().parent
    names = [p.name for p in root.rglob("test_*.py")]
    assert sorted({n for n in names if names.count(n) > 1}) == []
