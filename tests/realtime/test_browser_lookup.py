"""The shipped GLSL evaluated by a real browser's WebGL2 (headless Chromium through Playwright;
software rendering is fine) agrees with the Python lookup texel for texel (issue 25.2): the
shipped textures are uploaded as float textures with LINEAR filtering, a fragment shader calls
the texture lookups (and the spectral functions) at query points read from a data texture, and
the float framebuffer is read back. ``bash run.sh test`` installs Debian's chromium and the Python
playwright package where it can; elsewhere these tests skip with their reason."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import torch

from torchirid.realtime import bragg_wavelength, glsl_source, lookup, shipped_texture

playwright = pytest.importorskip("playwright.sync_api", reason="the Python playwright package is not installed")
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = [pytest.mark.integration,  # a browser
              pytest.mark.skipif(CHROMIUM is None, reason="no chromium executable (Debian: apt-get install chromium)")]

F64 = torch.float64

PAGE = """<!doctype html><canvas id="c"></canvas>"""

@pytest.fixture(scope="module")
def browser():
    with playwright.sync_playwright() as p:
        try:
            b = p.chromium.launch(executable_path=CHROMIUM, headless=True,
                                  args=["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-sandbox"])
        except playwright.Error as e:  # a machine whose chromium cannot start headless: say why, in one line
            pytest.skip(f"{CHROMIUM} did not start headless: {str(e).splitlines()[0][:200]}")
        yield b
        b.close()


def _tolerance(lut):
    # float32 shader arithmetic plus the filtering weights' precision: GPUs quantise them (8 bits of
    # sub-texel position on most hardware); 1/256 of the largest step between neighbouring texels
    v = lut.values.double()
    step = max(float(v.diff(dim=d).abs().max()) for d in range(v.ndim - 1))
    return 1e-5 + step / 256


# --- any shader function at query points read from a data texture (one RGBA32F texel each):
# `evaluate(vec4 p)` of the body, rendered into a float framebuffer, one pixel per point ---

EVAL = r"""
([glsl, body, points, textures]) => {
  const n = points.length / 4;
  const canvas = document.getElementById('c');
  canvas.width = n; canvas.height = 1;
  const gl = canvas.getContext('webgl2');
  if (!gl) throw new Error('no WebGL2');
  if (!gl.getExtension('EXT_color_buffer_float')) throw new Error('no EXT_color_buffer_float');
  if (!gl.getExtension('OES_texture_float_linear')) throw new Error('no OES_texture_float_linear');
  const decl = textures.map((t) => `uniform ${t.shape.length === 3 ? 'sampler3D' : 'sampler2D'} ${t.name};`).join('\n');
  const fs = `#version 300 es
precision highp float;
precision highp sampler2D;
precision highp sampler3D;
${glsl}
${decl}
uniform sampler2D points;
out vec4 color;
${body}
void main() { color = evaluate(texelFetch(points, ivec2(gl_FragCoord.xy), 0)); }`;
  const vs = `#version 300 es
in vec2 pos; void main() { gl_Position = vec4(pos, 0.0, 1.0); }`;
  const compile = (type, src) => {
    const s = gl.createShader(type); gl.shaderSource(s, src); gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    return s;
  };
  const prog = gl.createProgram();
  gl.attachShader(prog, compile(gl.VERTEX_SHADER, vs));
  gl.attachShader(prog, compile(gl.FRAGMENT_SHADER, fs));
  gl.linkProgram(prog);
  if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
  gl.useProgram(prog);
  textures.forEach((t, i) => {
    gl.activeTexture(gl.TEXTURE0 + i);
    const three = t.shape.length === 3;
    const target = three ? gl.TEXTURE_3D : gl.TEXTURE_2D;
    gl.bindTexture(target, gl.createTexture());
    const data = new Float32Array(t.values);
    if (three) gl.texImage3D(target, 0, gl.RGB32F, t.shape[2], t.shape[1], t.shape[0], 0, gl.RGB, gl.FLOAT, data);
    else gl.texImage2D(target, 0, gl.RGB32F, t.shape[1], t.shape[0], 0, gl.RGB, gl.FLOAT, data);
    const f = t.linear ? gl.LINEAR : gl.NEAREST;
    gl.texParameteri(target, gl.TEXTURE_MIN_FILTER, f); gl.texParameteri(target, gl.TEXTURE_MAG_FILTER, f);
    for (const p of [gl.TEXTURE_WRAP_S, gl.TEXTURE_WRAP_T, gl.TEXTURE_WRAP_R]) gl.texParameteri(target, p, gl.CLAMP_TO_EDGE);
    gl.uniform1i(gl.getUniformLocation(prog, t.name), i);
  });
  const unit = textures.length;
  gl.activeTexture(gl.TEXTURE0 + unit);
  gl.bindTexture(gl.TEXTURE_2D, gl.createTexture());
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, n, 1, 0, gl.RGBA, gl.FLOAT, new Float32Array(points));
  for (const p of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, p, gl.NEAREST);
  gl.uniform1i(gl.getUniformLocation(prog, 'points'), unit);
  gl.activeTexture(gl.TEXTURE0 + unit + 1);
  const out = gl.createTexture(); gl.bindTexture(gl.TEXTURE_2D, out);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, n, 1, 0, gl.RGBA, gl.FLOAT, null);
  const fb = gl.createFramebuffer(); gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, out, 0);
  gl.viewport(0, 0, n, 1);
  gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 3, -1, -1, 3]), gl.STATIC_DRAW);
  const loc = gl.getAttribLocation(prog, 'pos');
  gl.enableVertexAttribArray(loc); gl.vertexAttribPointer(loc, 2, gl.FLOAT, false, 0, 0);
  gl.drawArrays(gl.TRIANGLES, 0, 3);
  const px = new Float32Array(4 * n);
  gl.readPixels(0, 0, n, 1, gl.RGBA, gl.FLOAT, px);
  const err = gl.getError();
  if (err !== gl.NO_ERROR) throw new Error('GL error ' + err);
  return Array.from(px);
}
"""


def _evaluate(browser, body, points, textures=()):
    """``evaluate(vec4 p)`` of ``body`` at each row of ``points`` (n, ≤ 4) in the browser → (n, 4)."""
    page = browser.new_page()
    errors = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.set_content(PAGE)
    pts = np.zeros((points.shape[0], 4), np.float32)
    pts[:, :points.shape[1]] = np.asarray(points, np.float32)
    out = page.evaluate(EVAL, [glsl_source(), body, pts.flatten().tolist(), list(textures)])
    page.close()
    assert not errors, errors
    return np.asarray(out, np.float64).reshape(-1, 4)


def _lut_texture(name, lut):
    return {"name": name, "shape": list(lut.values.shape[:-1]), "values": lut.values.flatten().tolist(), "linear": True}


def _axes(lut):
    return ", ".join(f"vec3({g[0]:.9g}, {g[-1]:.9g}, {g.numel()}.0)" for g in lut.axes.values())


def test_film_lookup_in_the_browser_is_the_python_lookup(browser):
    lut = shipped_texture("thin_film_soap")
    g = torch.Generator().manual_seed(5)
    pts = torch.rand(256, 2, generator=g, dtype=F64) * torch.tensor([1.0, 800.0], dtype=F64) + torch.tensor(
        [0.0, 50.0], dtype=F64)  # thickness 50–850 nm: some outside the texture's 100–800 (clamped)
    got = _evaluate(browser, f"vec4 evaluate(vec4 p) {{ return vec4(tirid_thin_film_rgb(tex, {_axes(lut)}, p.x, p.y), "
                             "1.0); }", pts, [_lut_texture("tex", lut)])
    want = lookup(lut.to(F64), "thin_film", pts).numpy()
    np.testing.assert_allclose(got[:, :3], want, rtol=0, atol=_tolerance(lut))


def test_bragg_lookup_in_the_browser_is_the_python_lookup(browser):
    lut = shipped_texture("bragg_n8")
    n1, n2, n0 = lut.parameters["n1"], lut.parameters["n2"], lut.parameters["n_incident"]
    g = torch.Generator().manual_seed(6)
    u = torch.rand(256, 3, generator=g, dtype=F64)
    cos, period, delta = u[:, 0], 120.0 + 200.0 * u[:, 1], 0.3 + 0.4 * u[:, 2]
    got = _evaluate(browser, f"vec4 evaluate(vec4 p) {{ return vec4(tirid_bragg_rgb(tex, {_axes(lut)}, p.x, p.y, p.z, "
                             f"{n1}, {n2}, {n0}), 1.0); }}", torch.stack([cos, period, delta], -1),
                    [_lut_texture("tex", lut)])
    lam_b = bragg_wavelength(cos, n1, n2, period, delta, n_incident=n0)
    want = lookup(lut.to(F64), "bragg", torch.stack([cos, lam_b, delta], -1)).numpy()
    np.testing.assert_allclose(got[:, :3], want, rtol=0, atol=_tolerance(lut))



def test_path_and_rough_film_lookups_in_the_browser_are_the_python_lookups(browser):
    from torchirid.realtime import path_difference

    g = torch.Generator().manual_seed(7)
    u = torch.rand(256, 3, generator=g, dtype=F64)
    lut = shipped_texture("thin_film_path_glass")
    cos, d, n = u[:, 0], 600.0 * u[:, 1], 1.2 + 1.2 * u[:, 2]
    got = _evaluate(browser, f"vec4 evaluate(vec4 p) {{ return vec4(tirid_thin_film_path_rgb(tex, {_axes(lut)}, "
                             "p.x, p.y, p.z, 1.0), 1.0); }", torch.stack([cos, d, n], -1), [_lut_texture("tex", lut)])
    want = lookup(lut.to(F64), "thin_film_path", torch.stack([cos, path_difference(cos, n, d), n], -1)).numpy()
    np.testing.assert_allclose(got[:, :3], want, rtol=0, atol=_tolerance(lut))

    lut = shipped_texture("rough_thin_film")
    pts = torch.stack([0.02 + 0.98 * u[:, 0], 0.05 + 0.45 * u[:, 1], 100.0 + 700.0 * u[:, 2]], -1)
    got = _evaluate(browser, f"vec4 evaluate(vec4 p) {{ return vec4(tirid_rough_thin_film_rgb(tex, {_axes(lut)}, "
                             "p.x, p.y, p.z), 1.0); }", pts, [_lut_texture("tex", lut)])
    want = lookup(lut.to(F64), "rough_thin_film", pts).numpy()
    np.testing.assert_allclose(got[:, :3], want, rtol=0, atol=_tolerance(lut))


BASES = {"air": (1.0, 0.0), "glass": (1.52, 0.0), "absorbing": (2.0, 0.5), "metal": (0.2, 3.4)}


@pytest.mark.parametrize("base", list(BASES))
def test_thin_film_reflectance_in_the_browser_is_the_library_reflectance(browser, base):
    import torchirid as ti

    g = torch.Generator().manual_seed(8)
    u = torch.rand(512, 4, generator=g, dtype=F64)
    lam, cos, n, d = 380.0 + 400.0 * u[:, 0], u[:, 1], 1.2 + 1.2 * u[:, 2], 800.0 * u[:, 3]
    nr, ni = BASES[base]
    got = _evaluate(browser, "vec4 evaluate(vec4 p) { return vec4(tirid_thin_film_reflectance(p.x, p.y, 1.0, p.z, p.w, "
                             f"vec2({nr}, {ni}))); }}", torch.stack([lam, cos, n, d], -1))
    want = ti.thin_film_reflectance(lam, cos, n, d, complex(nr, ni) if ni else nr).numpy()
    np.testing.assert_allclose(got[:, 0], want, rtol=0, atol=1e-4)  # float32 and the GPU's sin/cos


@pytest.mark.parametrize("n0", [1.0, 1.59])  # lit from air; embedded in n1
def test_bragg_reflectance_in_the_browser_is_the_library_reflectance(browser, n0):
    import torchirid as ti

    g = torch.Generator().manual_seed(9)
    u = torch.rand(512, 4, generator=g, dtype=F64)
    lam, cos, period, delta = 380.0 + 400.0 * u[:, 0], u[:, 1].clamp(min=1e-3), 120.0 + 160.0 * u[:, 2], 0.3 + 0.4 * u[:, 3]
    for cells in (1, 8, 20):
        got = _evaluate(browser, "vec4 evaluate(vec4 p) { return vec4(tirid_bragg_reflectance(p.x, p.y, "
                                 f"{n0}, 1.59, 1.67, p.z * (1.0 - p.w), p.z * p.w, {cells})); }}",
                        torch.stack([lam, cos, period, delta], -1))
        want = ti.bragg_reflectance(lam, cos, 1.59, 1.67, period * (1 - delta), period * delta, cells,
                                    n_incident=n0).numpy()
        np.testing.assert_allclose(got[:, 0], want, rtol=0, atol=1e-4, err_msg=f"N = {cells}")


# the shader is compared with the library's function over its whole input domain, not only where
# the method is accurate (the library warns outside it; its accuracy is measured in tests/spectral)
@pytest.mark.filterwarnings("ignore:bragg_xyz\\(method='envelope'\\)")
def test_bragg_envelope_colour_in_the_browser_is_the_library_envelope_colour(browser):
    import math

    from torchirid.spectral import bragg_xyz_envelope
    from torchirid.spectral.envelope import envelope_weights

    samples = 64
    weights = envelope_weights(samples)
    tex = {"name": "weights", "shape": [1, samples], "values": weights.flatten().tolist(), "linear": False}
    g = torch.Generator().manual_seed(10)
    u = torch.rand(256, 3, generator=g, dtype=F64)
    # Fourneau Fig. 1's mirror (n 1.0 / 1.5) and the jewel beetle's (1.59 / 1.67), N = 6 and 20
    for n1, n2, cells in ((1.0, 1.5, 20), (1.59, 1.67, 6)):
        cos, d1, d2 = 0.05 + 0.95 * u[:, 0], 60.0 + 200.0 * u[:, 1], 60.0 + 200.0 * u[:, 2]
        body = (f"vec4 evaluate(vec4 p) {{ return vec4(tirid_bragg_envelope_xyz(weights, {samples}, "
                f"vec2({2 * math.pi / 780.0:.9g}, {2 * math.pi / 380.0:.9g}), p.x, {n1}, {n2}, p.y, p.z, {cells}), 1.0); }}")
        got = _evaluate(browser, body, torch.stack([cos, d1, d2], -1), [tex])
        want = bragg_xyz_envelope(cos, n1, n2, d1, d2, cells, samples=samples).numpy()
        np.testing.assert_allclose(got[:, :3], want, rtol=0, atol=2e-4, err_msg=f"n1 {n1}, n2 {n2}, N {cells}")
