"""The shipped GLSL evaluated by a real browser's WebGL2 (headless Chromium through Playwright;
software rendering is fine) agrees with the Python lookup texel for texel (issue 25.2): the
shipped textures are uploaded as float textures with LINEAR filtering, a fragment shader calls
``tirid_thin_film_rgb`` / ``tirid_bragg_rgb`` at query points read from a data texture, and the
float framebuffer is read back. ``bash run.sh test`` installs Debian's chromium and the Python
playwright package where it can; elsewhere these tests skip with their reason."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import torch

from torchirid.realtime import bragg_wavelength, glsl_source, lookup, shipped_texture

playwright = pytest.importorskip("playwright.sync_api", reason="the Python playwright package is not installed")
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no chromium executable (Debian: apt-get install chromium)")

F64 = torch.float64

PAGE = """<!doctype html><canvas id="c"></canvas>"""

JS = r"""
([kind, glsl, shape, values, axes, points, consts]) => {
  const n = points.length / 4;
  const canvas = document.getElementById('c');
  canvas.width = n; canvas.height = 1;
  const gl = canvas.getContext('webgl2');
  if (!gl) throw new Error('no WebGL2');
  if (!gl.getExtension('EXT_color_buffer_float')) throw new Error('no EXT_color_buffer_float');
  if (!gl.getExtension('OES_texture_float_linear')) throw new Error('no OES_texture_float_linear');
  const film = kind === 'thin_film';
  const fs = `#version 300 es
precision highp float;
precision highp sampler3D;
${glsl}
uniform ${film ? 'sampler2D' : 'sampler3D'} tex;
uniform sampler2D points;
uniform vec3 ax0, ax1, ax2;
uniform vec3 mirror;  // n1, n2, n0
out vec4 color;
void main() {
  vec4 p = texelFetch(points, ivec2(gl_FragCoord.xy), 0);
  ${film ? 'color = vec4(tirid_thin_film_rgb(tex, ax0, ax1, p.x, p.y), 1.0);'
         : 'color = vec4(tirid_bragg_rgb(tex, ax0, ax1, ax2, p.x, p.y, p.z, mirror.x, mirror.y, mirror.z), 1.0);'}
}`;
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
  // the colour texture: the LUT's values in C order, last axis = x
  gl.activeTexture(gl.TEXTURE0);
  const target = film ? gl.TEXTURE_2D : gl.TEXTURE_3D;
  const tex = gl.createTexture(); gl.bindTexture(target, tex);
  const data = new Float32Array(values);
  if (film) gl.texImage2D(target, 0, gl.RGB32F, shape[1], shape[0], 0, gl.RGB, gl.FLOAT, data);
  else gl.texImage3D(target, 0, gl.RGB32F, shape[2], shape[1], shape[0], 0, gl.RGB, gl.FLOAT, data);
  for (const p of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(target, p, gl.LINEAR);
  for (const p of [gl.TEXTURE_WRAP_S, gl.TEXTURE_WRAP_T, gl.TEXTURE_WRAP_R]) gl.texParameteri(target, p, gl.CLAMP_TO_EDGE);
  gl.uniform1i(gl.getUniformLocation(prog, 'tex'), 0);
  // the query points: one RGBA32F texel each
  gl.activeTexture(gl.TEXTURE1);
  const pts = gl.createTexture(); gl.bindTexture(gl.TEXTURE_2D, pts);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, n, 1, 0, gl.RGBA, gl.FLOAT, new Float32Array(points));
  for (const p of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, p, gl.NEAREST);
  gl.uniform1i(gl.getUniformLocation(prog, 'points'), 1);
  ['ax0', 'ax1', 'ax2'].forEach((name, i) => { if (axes[i]) gl.uniform3fv(gl.getUniformLocation(prog, name), axes[i]); });
  gl.uniform3fv(gl.getUniformLocation(prog, 'mirror'), consts);
  // render into a float framebuffer, one pixel per point (on its own texture unit: unit 1 keeps the points)
  gl.activeTexture(gl.TEXTURE2);
  const out = gl.createTexture(); gl.bindTexture(gl.TEXTURE_2D, out);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, n, 1, 0, gl.RGBA, gl.FLOAT, null);
  const fb = gl.createFramebuffer(); gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, out, 0);
  gl.viewport(0, 0, n, 1);
  const buf = gl.createBuffer(); gl.bindBuffer(gl.ARRAY_BUFFER, buf);
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


def _axis(lut, name):
    g = lut.axes[name]
    return [float(g[0]), float(g[-1]), float(g.numel())]


def _run(browser, kind, lut, points, consts=(0.0, 0.0, 0.0)):
    page = browser.new_page()
    errors = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.set_content(PAGE)
    axes = [_axis(lut, n) for n in lut.axes]
    pts = np.zeros((points.shape[0], 4), np.float32)
    pts[:, :points.shape[1]] = points.numpy()
    out = page.evaluate(JS, [kind, glsl_source(), list(lut.values.shape[:-1]), lut.values.flatten().tolist(), axes,
                             pts.flatten().tolist(), list(consts)])
    page.close()
    assert not errors, errors
    return np.asarray(out, np.float64).reshape(-1, 4)[:, :3]


def _tolerance(lut):
    # float32 shader arithmetic plus the filtering weights' precision: GPUs quantise them (8 bits of
    # sub-texel position on most hardware); 1/256 of the largest step between neighbouring texels
    v = lut.values.double()
    step = max(float(v.diff(dim=d).abs().max()) for d in range(v.ndim - 1))
    return 1e-5 + step / 256


def test_film_lookup_in_the_browser_is_the_python_lookup(browser):
    lut = shipped_texture("thin_film_soap")
    g = torch.Generator().manual_seed(5)
    pts = torch.rand(256, 2, generator=g, dtype=F64) * torch.tensor([1.0, 800.0], dtype=F64) + torch.tensor(
        [0.0, 50.0], dtype=F64)  # thickness 50–850 nm: some outside the texture's 100–800 (clamped)
    got = _run(browser, "thin_film", lut, pts)
    want = lookup(lut.to(F64), "thin_film", pts).numpy()
    np.testing.assert_allclose(got, want, rtol=0, atol=_tolerance(lut))


def test_bragg_lookup_in_the_browser_is_the_python_lookup(browser):
    lut = shipped_texture("bragg_n8")
    n1, n2, n0 = lut.parameters["n1"], lut.parameters["n2"], lut.parameters["n_incident"]
    g = torch.Generator().manual_seed(6)
    u = torch.rand(256, 3, generator=g, dtype=F64)
    cos, period, delta = u[:, 0], 120.0 + 200.0 * u[:, 1], 0.3 + 0.4 * u[:, 2]
    got = _run(browser, "bragg", lut, torch.stack([cos, period, delta], -1), (n1, n2, n0))
    lam_b = bragg_wavelength(cos, period, delta, n1, n2, n0)
    want = lookup(lut.to(F64), "bragg", torch.stack([cos, lam_b, delta], -1)).numpy()
    np.testing.assert_allclose(got, want, rtol=0, atol=_tolerance(lut))
