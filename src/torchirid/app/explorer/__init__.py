r"""The explorer page of ``torchirid explore``: a static WebGL2 page of one material at a time.

:func:`write_page` writes ``index.html``, ``explorer.js``, ``explorer.css`` (this package's
``static/`` folder, written by hand: no framework, nothing fetched at run time) and ``data.js``
(made here from shipped files only: the fitted textures of :mod:`torchirid.realtime`, the
library's shader functions, the prefiltered synthetic sky of ``luts/build_explorer_sky.py`` and
the split-sum albedo table; nothing is computed, so writing it costs little more than importing
torch), so the page opens from the file system with no server and no internet.

What the page draws, all on the GPU with WebGL2 and redrawn on every slider move:

* a sphere under the sky (Kneiphof et al.'s split sum, as :mod:`torchirid.ibl.shading`):
  :math:`L = A(\cos θ_o, α)\,\bar L(ω_r, α) ⊙ \mathrm{RGB}(\cos θ_o)` with the albedo A of
  :func:`~torchirid.ibl.shipped_dfg_lut` at F ≡ 1, the prefiltered radiance :math:`\bar L` of
  :func:`~torchirid.ibl.prefilter_environment` and the material's colour looked up in its
  fitted texture, tone mapped :math:`1 - e^{-L}` and sRGB encoded;
* a scatterogram: the GGX microfacet BRDF × cos θ_o over the hemisphere of exit directions
  (orthographic projection) for a collimated light at θ_i, the reflectance looked up at
  cos θ_d = ⟨ω_i, h⟩ and scaled by :math:`4πα^2\cos θ_i` so the peak shows the colour; a
  yellow ring marks ω_i, the direction towards the light;
* the reflectance map R(θ, λ) (θ 0–90°, λ 380–780 nm; grey level = √R), evaluated spectrally in
  the shader (``tirid_bragg_reflectance`` / ``tirid_thin_film_reflectance``), beside its colour
  scale (grey against R, with ticks);
* the colour strip: the specular colour RGB(cos θ) for θ from 0° to 90°, sRGB encoded —
  what the browser tests compare with the library's spectral colour.

Families: Bragg mirrors (sliders Λ, δ, N, α; n1 = 1.59, n2 = 1.67 lit from air, the shipped
``bragg_n{6,8,10}`` textures) and thin films (sliders d, n, base — shown with its index —, α;
the shipped ``thin_film_path_{air,glass,absorbing}`` textures). Over the sliders' whole ranges
(``slider_ranges()``) every material's colour is within ΔE2000 1.0 mean / 2.5 max of the
library's (``material_errors()``; tests/realtime/test_explorer_page.py).
"""

from __future__ import annotations

import base64
import functools
import http.server
import json
import math
import re
import threading
from importlib import resources
from pathlib import Path

import numpy as np
import torch

from ... import __version__
from ..._cache import cached
from ..._io import atomic_write
from ..._shipped import read_or_build
from ...ibl import shipped_dfg_lut
from ...lut import LUT
from ...realtime import glsl_source, shipped_texture

__all__ = ["BASES", "BRAGG_CELLS", "SKY_ALPHAS", "STATIC_FILES", "page_data", "reference_rgb", "serve", "write_page"]

#: the page's static files (this package's ``static/`` folder)
STATIC_FILES = ("index.html", "explorer.js", "explorer.css")
#: Bragg mirrors of the N slider → shipped texture
BRAGG_CELLS = {6: "bragg_n6", 8: "bragg_n8", 10: "bragg_n10"}
#: thin-film bases of the base slider → shipped texture
BASES = {"air": "thin_film_path_air", "glass": "thin_film_path_glass", "absorbing": "thin_film_path_absorbing"}
#: the roughness levels of the prefiltered sky (the α slider's range)
SKY_ALPHAS = tuple(float(a) for a in np.linspace(0.05, 0.5, 6))


def _floats(t) -> str:
    """float32 little-endian bytes of ``t`` in C order, base64 (what ``explorer.js`` decodes)."""
    a = np.ascontiguousarray(torch.as_tensor(t).detach().cpu().numpy(), dtype="<f4")
    return base64.b64encode(a.tobytes()).decode("ascii")


def _ranges(lut) -> list:
    """``[lo, hi, n]`` of each LUT axis: what ``tirid_texcoord`` takes (uniform nodes)."""
    return [[float(g[0]), float(g[-1]), int(g.numel())] for g in lut.axes.values()]


def _texture(name: str) -> dict:
    lut = shipped_texture(name)
    return {"name": name, "axes": list(lut.axes), "ranges": _ranges(lut), "shape": list(lut.values.shape[:-1]),
            "parameters": lut.parameters, "values": _floats(lut.values)}


#: what rebuilds the page's prefiltered sky, shipped as ``torchirid/data/explorer/sky.npz``
SKY_BUILDER = "luts/build_explorer_sky.py"
#: the sky's provenance, stored in (and checked when reading) the shipped file
SKY_PARAMETERS = {"environment": "torchirid.ibl.synthetic_environment(64, 128, dtype=float32)",
                  "resolution": [32, 64], "alphas": list(SKY_ALPHAS)}


def sky_lut() -> LUT:
    """The page's sky, computed: :func:`~torchirid.ibl.synthetic_environment` (64 × 128) prefiltered
    by :func:`~torchirid.ibl.prefilter_environment` to 32 × 64 texels at each of :data:`SKY_ALPHAS`
    (float32; ~2 s of CPU, hence shipped: :func:`shipped_sky`). A LUT over ``alpha``, ``theta``
    and ``phi`` (radians, texel centres) of linear RGB radiance."""
    from ...ibl import prefilter_environment, synthetic_environment

    ho, wo = SKY_PARAMETERS["resolution"]
    env = synthetic_environment(64, 128, dtype=torch.float32)
    pre = prefilter_environment(env, torch.tensor(SKY_ALPHAS, dtype=torch.float32), resolution=(ho, wo))
    theta = (torch.arange(ho, dtype=torch.float64) + 0.5) * (math.pi / ho)
    phi = (torch.arange(wo, dtype=torch.float64) + 0.5) * (2.0 * math.pi / wo)
    axes = {"alpha": torch.tensor(SKY_ALPHAS), "theta": theta, "phi": phi}
    return LUT(pre.radiance.contiguous(), {k: v.to(torch.float32) for k, v in axes.items()}, builder=SKY_BUILDER,
               parameters=SKY_PARAMETERS, units={"alpha": "1", "theta": "rad", "phi": "rad",
                                                 "values": "radiance (linear RGB)"})


@cached(maxsize=1)
def shipped_sky() -> LUT:
    """The page's prefiltered sky as shipped (``torchirid/data/explorer/sky.npz``, written by
    ``luts/build_explorer_sky.py``; built by :func:`sky_lut` if missing or stale)."""
    resource = resources.files("torchirid") / "data" / "explorer" / "sky.npz"
    return read_or_build(resource, sky_lut, what="the explorer's prefiltered sky", script=SKY_BUILDER,
                         builder=SKY_BUILDER, parameters=SKY_PARAMETERS)


def _sky() -> dict:
    lut = shipped_sky()
    return {"alphas": list(SKY_ALPHAS), "shape": list(lut.values.shape[:-1]), "values": _floats(lut.values),
            "environment": "torchirid.ibl.synthetic_environment(64, 128), prefiltered to 32 × 64"}


def _albedo() -> dict:
    lut = shipped_dfg_lut(dtype=torch.float32)
    albedo = lut.values.sum(-1)  # F0·scale + bias at F0 = 1
    return {"axes": list(lut.axes), "ranges": _ranges(lut), "shape": list(albedo.shape), "values": _floats(albedo)}


def page_data() -> dict:
    """Everything ``explorer.js`` needs, JSON-ready: textures, shader source, sky, albedo.

    Float arrays are base64 float32 (C order); a texture's ``ranges`` are ``[lo, hi, n]`` of
    its LUT axes (warped coordinates), as ``tirid_texcoord`` takes them.
    """
    return {
        "version": __version__,
        "glsl": glsl_source(),
        "bragg": {str(n): _texture(name) for n, name in BRAGG_CELLS.items()},
        "film": {base: _texture(name) for base, name in BASES.items()},
        "sky": _sky(),
        "albedo": _albedo(),
    }


def write_page(out, *, data: dict | None = None) -> Path:
    """Write the explorer page into the folder ``out`` (created); returns ``out/index.html``.

    ``data``: :func:`page_data` (read here by default from shipped files: the textures, the
    prefiltered sky, the albedo table; well under a second).
    Open ``index.html`` in a browser with WebGL2 (any current one), or :func:`serve` the folder.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    data = page_data() if data is None else data
    static = resources.files(__name__) / "static"
    for name in STATIC_FILES:
        with resources.as_file(static / name) as src:
            atomic_write(out / name, lambda f, src=src: f.write(Path(src).read_bytes()))
    text = "// written by torchirid explore: the data of the explorer page\nwindow.TORCHIRID_DATA = " + json.dumps(
        data, separators=(",", ":")) + ";\n"
    atomic_write(out / "data.js", lambda f: f.write(text.encode("utf-8")))
    return out / "index.html"


def reference_rgb(state, theta_deg) -> torch.Tensor:
    """The library's own colour of the page's material ``state`` at incidence angles
    ``theta_deg`` (degrees, in air): linear sRGB (D65, white Y = 1, not clipped), evaluated
    spectrally — what the page's colour strip approximates from its fitted texture.

    ``state``: the page's ``window.torchiridExplorer.state`` (``family`` ``"bragg"`` with
    ``period`` (nm), ``delta``, ``cells``; or ``"film"`` with ``thickness`` (nm), ``n_film``,
    ``base`` (index into :data:`BASES`)). Indices and the incident medium are those of the
    shipped textures the page reads.
    """
    from ...color import spectrum_to_xyz, xyz_to_linear_srgb
    from ...optics import thin_film_reflectance
    from ...spectral import bragg_xyz

    cos = torch.cos(torch.deg2rad(torch.as_tensor(theta_deg, dtype=torch.float64)))
    if state["family"] == "bragg":
        p = shipped_texture(BRAGG_CELLS[int(state["cells"])]).parameters
        period, delta = float(state["period"]), float(state["delta"])
        xyz = bragg_xyz(cos, p["n1"], p["n2"], period * (1 - delta), period * delta, int(state["cells"]),
                        n_incident=p["n_incident"], method="spectral")
    elif state["family"] == "film":
        p = shipped_texture(list(BASES.values())[int(state["base"])]).parameters
        n_sub = p["n_substrate"]
        n_sub = complex(*n_sub) if isinstance(n_sub, list) else n_sub
        lam = torch.linspace(360.0, 830.0, 471, dtype=torch.float64)
        R = thin_film_reflectance(lam, cos[..., None], float(state["n_film"]), float(state["thickness"]), n_sub,
                                  n_incident=p["n_incident"])
        xyz = spectrum_to_xyz(R, lam)
    else:
        raise ValueError(f"state['family'] must be 'bragg' or 'film'; got {state['family']!r}")
    return xyz_to_linear_srgb(xyz)


def slider_ranges() -> dict:
    """``{id: (min, max, step)}`` of the page's range inputs, read from ``static/index.html``: what
    its sliders reach (the range the explorer's error bar is tested over)."""
    text = (resources.files(__name__) / "static" / "index.html").read_text(encoding="utf-8")
    pattern = r'<input type="range" id="(\w+)" min="([\d.]+)" max="([\d.]+)" step="([\d.]+)"'
    return {m[1]: tuple(float(v) for v in m.groups()[1:]) for m in re.finditer(pattern, text)}


def _lab(rgb):
    from ...color import xyz_to_lab
    from ...color.convert import linear_srgb_to_xyz

    return xyz_to_lab(linear_srgb_to_xyz(rgb))


def material_errors(family: str, key, first, second, theta_deg, *, block: int = 200) -> torch.Tensor:
    """ΔE2000 of the page's colour (the fitted texture, :func:`torchirid.realtime.lookup`, what the
    colour strip draws) against the library's (as :func:`reference_rgb`), both clipped to the sRGB
    gamut as the page's output is, for many materials at once: ``(F, 3)`` = mean and max over
    ``theta_deg`` (degrees, in air) and the angle of the max, per material.

    ``family`` ``"film"``: ``key`` a base of :data:`BASES`, ``first`` the thicknesses (nm) and
    ``second`` the film indices ``(F,)``; ``"bragg"``: ``key`` the cells (:data:`BRAGG_CELLS`),
    ``first`` the periods Λ (nm), ``second`` the fractions δ. Bragg colours are integrated on
    401 wavelengths (380–780 nm; within ΔE2000 0.005 of the converged ``"spectral"`` colour for
    these mirrors of ≤ 10 cells, 50× cheaper).
    """
    from ...color import delta_e_2000, spectrum_to_xyz, xyz_to_linear_srgb
    from ...optics import thin_film_reflectance
    from ...realtime import bragg_wavelength, lookup, path_difference
    from ...spectral import bragg_xyz

    f64 = torch.float64
    theta = torch.as_tensor(theta_deg, dtype=f64)
    cos = torch.cos(torch.deg2rad(theta))
    lut = shipped_texture(BASES[key] if family == "film" else BRAGG_CELLS[int(key)]).to(f64)
    p = lut.parameters
    lam = torch.linspace(360.0, 830.0, 471, dtype=f64)
    first, second = (torch.as_tensor(v, dtype=f64).reshape(-1) for v in (first, second))
    out = []
    with torch.no_grad():
        for i in range(0, first.numel(), block):
            a, b = first[i:i + block, None], second[i:i + block, None]
            c = cos.expand(a.shape[0], -1)
            if family == "film":
                n_sub = complex(*p["n_substrate"]) if isinstance(p["n_substrate"], list) else p["n_substrate"]
                x = torch.stack([c, path_difference(c, b, a, n_incident=p["n_incident"]), b.expand_as(c)], -1)
                R = thin_film_reflectance(lam, c[..., None], b[..., None], a[..., None], n_sub, n_incident=p["n_incident"])
                xyz = spectrum_to_xyz(R, lam)
            else:
                x = torch.stack([c, bragg_wavelength(c, p["n1"], p["n2"], a, b, n_incident=p["n_incident"]),
                                 b.expand_as(c)], -1)
                xyz = bragg_xyz(c, p["n1"], p["n2"], a * (1 - b), a * b, int(key), n_incident=p["n_incident"],
                                method="sampled", samples=401)
            got = lookup(lut, "thin_film_path" if family == "film" else "bragg", x).clamp(0.0, 1.0)
            de = delta_e_2000(_lab(got), _lab(xyz_to_linear_srgb(xyz).clamp(0.0, 1.0)))
            out.append(torch.stack([de.mean(-1), de.amax(-1), theta[de.argmax(-1)]], -1))
    return torch.cat(out)


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args):  # noqa: A002 (http.server's signature)
        pass


def serve(directory, *, host: str = "127.0.0.1", port: int = 8000):
    """Serve ``directory`` over HTTP on ``host:port`` (``port=0``: any free port) in a daemon
    thread; returns ``(server, url)``. Stop it with ``server.shutdown()``."""
    directory = Path(directory)
    if not (directory / "index.html").is_file():
        raise ValueError(f"directory must hold the page's index.html (write_page); {directory} does not")
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise ValueError(f"port must be an int in [0, 65535]; got {port!r}")
    handler = functools.partial(_QuietHandler, directory=str(directory))
    server = http.server.ThreadingHTTPServer((host, port), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    h, p = server.server_address[:2]
    return server, f"http://{h}:{p}/"
