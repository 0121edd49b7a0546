"""Resolve cross-references to any name under which a documented object is reachable.

torchirid documents each object once, in its subpackage (``torchirid.optics.bragg_reflectance``),
while docstrings also name it by its curated root alias (``torchirid.bragg_reflectance``) or by
its defining module (``torchirid.optics.bragg.bragg_reflectance``). A reference that Sphinx cannot
find is imported by its dotted path here; if that object is documented under another name, the
reference points there. Anything else stays a missing reference (a warning under ``-n -W``).
"""

from __future__ import annotations

import importlib
import inspect
import sys

from sphinx.util.nodes import make_refnode


def _import(path: str):
    parts = path.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        try:
            for attr in parts[i:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return None
        return obj
    return None


_SCALARS = (int, float, complex, str, bytes, bool, type(None))


def _documented(env):
    """id(object) → (documented name, docname, node id), built once per build."""
    cache = getattr(env, "_torchirid_documented", None)
    if cache is None:
        cache = {}
        for name, entry in env.get_domain("py").objects.items():
            obj = _import(name)
            if obj is not None and not isinstance(obj, _SCALARS):
                cache.setdefault(id(obj), (name, entry.docname, entry.node_id))
        env._torchirid_documented = cache
    return cache


def _candidates(target: str, module: str | None):
    yield target
    if module:
        yield f"{module}.{target}"
    if "." not in target:  # a bare name used inside its defining module's docstrings
        for name, mod in sorted(sys.modules.items()):
            if name.startswith("torchirid") and mod is not None and target in vars(mod):
                yield f"{name}.{target}"


def missing_reference(app, env, node, contnode):
    if node.get("refdomain") != "py":
        return None
    target = node.get("reftarget", "").lstrip("~.")
    domain = env.get_domain("py")
    for name in _candidates(target, node.get("py:module")):
        if not name.startswith("torchirid"):
            continue
        obj = _import(name)
        if obj is None or isinstance(obj, _SCALARS):
            continue
        if inspect.ismodule(obj):  # a module of a subpackage: its package's page documents its names
            mod = obj.__name__
            while mod and mod not in domain.modules:
                mod = mod.rpartition(".")[0]
            if mod:
                entry = domain.modules[mod]
                return make_refnode(app.builder, node["refdoc"], entry.docname, entry.node_id, contnode, mod)
            continue
        hit = _documented(env).get(id(obj))
        if hit is not None:
            return make_refnode(app.builder, node["refdoc"], hit[1], hit[2], contnode, hit[0])
    return None


def _attr_docs(module: str) -> dict:
    from sphinx.pycode import ModuleAnalyzer

    try:
        return ModuleAnalyzer.for_module(module).find_attr_docs()
    except Exception:  # noqa: BLE001 (no source: nothing documented in place)
        return {}


def _data_directives(package: str) -> str:
    """``autodata`` directives for the data (constants) of ``package.__all__``, each under the
    submodule that defines it: autodoc documents module data only where a ``#:`` comment sits
    in the documented module itself, and a package re-exports its constants from submodules."""
    pkg = importlib.import_module(package)
    lines = []
    for name in getattr(pkg, "__all__", ()):
        obj = getattr(pkg, name)
        if inspect.ismodule(obj) or inspect.isclass(obj) or callable(obj):
            continue
        home = package
        for mod_name, mod in sorted(sys.modules.items()):
            if mod_name.startswith(package + ".") and mod is not None and vars(mod).get(name) is obj:
                home = mod_name
                break
        if home == package and ("", name) in _attr_docs(package):
            continue  # automodule documents it already (a ``#:`` comment in the module itself)
        directive = f".. autodata:: {home}.{name}"
        if len(repr(obj)) > 80 or "\n" in repr(obj):  # a long value breaks the signature line: its doc says it
            directive += "\n   :no-value:"
        lines.append(directive)
    return "\n\n" + "\n\n".join(lines) + "\n" if lines else ""


def _add_data(app, docname, source):
    if docname.startswith("api/"):
        for line in source[0].splitlines():
            if line.startswith(".. automodule:: torchirid"):
                source[0] += _data_directives(line.split("::", 1)[1].strip())


def _reset(app, env):
    env._torchirid_documented = None  # rebuilt from this build's objects on the first miss


def setup(app):
    app.connect("env-updated", _reset)
    app.connect("source-read", _add_data)
    app.connect("missing-reference", missing_reference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
