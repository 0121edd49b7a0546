// torchirid explorer: one material at a time, drawn with WebGL2 from the fitted textures of
// torchirid.realtime and the library's shader functions (torchirid.glsl, carried in data.js).
// Plain JavaScript, no dependencies, nothing fetched: the page works from the file system.
//
// Views (one WebGL2 context each, redrawn on every slider move):
//   sphere        split-sum image-based lighting: A(cos θo, α) · L̄(ω_r, α) · RGB(cos θo), 1 − e^−L, sRGB
//   scatterogram  GGX BRDF × cos θo over the exit hemisphere for a light at θi (× 4πα² cos θi); a yellow
//                 ring (radius 0.035–0.055 of the disc) around wi, the direction towards the light
//   rmap          R(θ, λ), spectral, in the shader (θ 0–90° across, λ 380–780 nm upwards; grey level = √R),
//                 beside its colour scale (rmap-scale: 2-D canvas, row y from the bottom at R = (y + ½)/h)
//   strip         the specular colour RGB(cos θ), θ 0–90° across, sRGB
// Pixel column i of the rmap and the strip is at θ = (i + ½)/width · 90°.
'use strict';

(function () {
  const D = window.TORCHIRID_DATA;
  if (!D) throw new Error('torchirid explorer: data.js did not load (keep it next to index.html)');
  const $ = (id) => document.getElementById(id);

  function floats(b64) {
    const bin = atob(b64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return new Float32Array(bytes.buffer);
  }
  for (const group of [D.bragg, D.film]) for (const t of Object.values(group)) t.data = floats(t.values);
  D.sky.data = floats(D.sky.values);
  D.albedo.data = floats(D.albedo.values);
  const BASES = Object.keys(D.film);

  const state = {
    family: 'bragg', period: 190, delta: 0.5, cells: 8,
    thickness: 320, n_film: 1.33, base: 0, alpha: 0.15, light: 30,
  };

  // --- shaders ------------------------------------------------------------------------------
  const VERTEX = `#version 300 es
in vec2 pos;
void main() { gl_Position = vec4(pos, 0.0, 1.0); }`;

  const PRELUDE = `#version 300 es
precision highp float;
precision highp sampler2D;
precision highp sampler3D;
${D.glsl}
uniform vec2 resolution;
uniform int family;          // 0: Bragg mirror, 1: thin film
uniform sampler3D mat_tex;   // the material's fitted texture
uniform vec3 ax0, ax1, ax2;  // its axes (lo, hi, n)
uniform vec4 mat;            // Bragg: period, delta, n1, n2; film: thickness, n_film, base (n, κ)
uniform float n0;            // incident medium
uniform float alpha;         // GGX roughness
uniform int cells;           // Bragg: N
out vec4 color;
vec3 material_rgb(float c) {
  if (family == 0) return tirid_bragg_rgb(mat_tex, ax0, ax1, ax2, c, mat.x, mat.y, mat.z, mat.w, n0);
  return tirid_thin_film_path_rgb(mat_tex, ax0, ax1, ax2, c, mat.x, mat.y, n0);
}
float column_theta() { return gl_FragCoord.x / resolution.x * 0.5 * TIRID_PI; }
`;

  const STRIP = `
void main() { color = vec4(tirid_linear_to_srgb(material_rgb(cos(column_theta()))), 1.0); }`;

  const RMAP = `
void main() {
  float c = cos(column_theta());
  float lam = 380.0 + gl_FragCoord.y / resolution.y * 400.0;
  float R = family == 0
    ? tirid_bragg_reflectance(lam, c, n0, mat.z, mat.w, mat.x * (1.0 - mat.y), mat.x * mat.y, cells)
    : tirid_thin_film_reflectance(lam, c, n0, mat.y, mat.x, mat.zw);
  color = vec4(vec3(sqrt(clamp(R, 0.0, 1.0))), 1.0);  // grey level = √R (0 black, 1 white)
}`;

  const SPHERE = `
uniform sampler3D sky;       // prefiltered radiance: x = φ, y = θ from the zenith, z = roughness level
uniform vec3 sky_alpha;      // its levels (lo, hi, n)
uniform sampler2D albedo;    // split-sum albedo A: x = α, y = cos θo
uniform vec3 albedo_cos, albedo_alpha;
uniform mat3 camera;         // columns: right, up, towards the viewer (world frame, z up)
vec3 sky_at(vec3 d, float a) {
  float th = acos(clamp(d.z, -1.0, 1.0));
  float ph = atan(d.y, d.x);
  if (ph < 0.0) ph += 2.0 * TIRID_PI;
  return texture(sky, vec3(ph / (2.0 * TIRID_PI), th / TIRID_PI, tirid_texcoord(a, sky_alpha))).rgb;
}
void main() {
  vec2 p = (gl_FragCoord.xy / resolution * 2.0 - 1.0) * 1.1;
  float r2 = dot(p, p);
  vec3 L;
  if (r2 >= 1.0) {
    L = sky_at(normalize(-camera[2] + 0.5 * (p.x * camera[0] + p.y * camera[1])), sky_alpha.x);
  } else {
    vec3 n = normalize(camera * vec3(p, sqrt(1.0 - r2)));
    vec3 v = camera[2];
    float co = clamp(dot(n, v), 1e-4, 1.0);
    vec3 wr = 2.0 * co * n - v;
    float A = texture(albedo, vec2(tirid_texcoord(alpha, albedo_alpha), tirid_texcoord(co, albedo_cos))).r;
    L = A * sky_at(wr, alpha) * material_rgb(co);
  }
  color = vec4(tirid_linear_to_srgb(1.0 - exp(-L)), 1.0);
}`;

  const SCATTEROGRAM = `
uniform float light;         // θi (rad), the light in the x–z plane at φ = 0
void main() {
  vec2 p = (gl_FragCoord.xy / resolution * 2.0 - 1.0) * 1.05;
  float r2 = dot(p, p);
  if (r2 >= 1.0) { color = vec4(vec3(r2 < 1.0036 ? 0.35 : 0.08), 1.0); return; }
  // the marker: a ring around the direction towards the light, wi projected as wo is
  float dl = distance(p, vec2(sin(light), 0.0));
  if (dl > 0.035 && dl < 0.055) { color = vec4(1.0, 0.85, 0.1, 1.0); return; }
  vec3 wo = vec3(p, sqrt(1.0 - r2));
  vec3 wi = vec3(sin(light), 0.0, cos(light));
  vec3 R = material_rgb(tirid_cos_d(wi, wo));
  vec3 f = tirid_microfacet_brdf(vec3(0.0, 0.0, 1.0), wi, wo, alpha, R) * wo.z
           * 4.0 * TIRID_PI * alpha * alpha * max(wi.z, 1e-3);
  color = vec4(tirid_linear_to_srgb(f), 1.0);
}`;

  // --- WebGL helpers --------------------------------------------------------------------------
  function compile(gl, type, src) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error('shader: ' + gl.getShaderInfoLog(s));
    return s;
  }

  function texture3d(gl, unit, shape, data, channels, repeatX) {
    // shape = [depth, height, width] (a LUT's C-order axes: the last is x); RGB16F/R16F filter natively
    gl.activeTexture(gl.TEXTURE0 + unit);
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_3D, t);
    const [internal, format] = channels === 3 ? [gl.RGB16F, gl.RGB] : [gl.R16F, gl.RED];
    gl.texImage3D(gl.TEXTURE_3D, 0, internal, shape[2], shape[1], shape[0], 0, format, gl.FLOAT, data);
    gl.texParameteri(gl.TEXTURE_3D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_3D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_3D, gl.TEXTURE_WRAP_S, repeatX ? gl.REPEAT : gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_3D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_3D, gl.TEXTURE_WRAP_R, gl.CLAMP_TO_EDGE);
    return t;
  }

  function texture2d(gl, unit, shape, data) {
    gl.activeTexture(gl.TEXTURE0 + unit);
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.R16F, shape[1], shape[0], 0, gl.RED, gl.FLOAT, data);
    for (const p of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, p, gl.LINEAR);
    for (const p of [gl.TEXTURE_WRAP_S, gl.TEXTURE_WRAP_T]) gl.texParameteri(gl.TEXTURE_2D, p, gl.CLAMP_TO_EDGE);
    return t;
  }

  function makeView(id, body, setup) {
    const canvas = $(id);
    const gl = canvas.getContext('webgl2', { preserveDrawingBuffer: true, antialias: false });
    if (!gl) throw new Error('torchirid explorer: this browser has no WebGL2');
    const prog = gl.createProgram();
    gl.attachShader(prog, compile(gl, gl.VERTEX_SHADER, VERTEX));
    gl.attachShader(prog, compile(gl, gl.FRAGMENT_SHADER, PRELUDE + body));
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error('program: ' + gl.getProgramInfoLog(prog));
    gl.useProgram(prog);
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 3, -1, -1, 3]), gl.STATIC_DRAW);
    const loc = gl.getAttribLocation(prog, 'pos');
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, 2, gl.FLOAT, false, 0, 0);
    const locations = {};
    const view = {
      canvas, gl, prog, materials: {},
      u(name) { if (!(name in locations)) locations[name] = gl.getUniformLocation(prog, name); return locations[name]; },
    };
    if (setup) setup(view);
    return view;
  }

  const views = {
    sphere: makeView('sphere', SPHERE, (v) => {
      const gl = v.gl;
      texture3d(gl, 1, D.sky.shape, D.sky.data, 3, true);
      gl.uniform1i(v.u('sky'), 1);
      const a = D.sky.alphas;
      gl.uniform3f(v.u('sky_alpha'), a[0], a[a.length - 1], a.length);
      texture2d(gl, 2, D.albedo.shape, D.albedo.data);
      gl.uniform1i(v.u('albedo'), 2);
      const i = D.albedo.axes.indexOf('cos_theta_o'), j = D.albedo.axes.indexOf('alpha');
      gl.uniform3fv(v.u('albedo_cos'), D.albedo.ranges[i]);
      gl.uniform3fv(v.u('albedo_alpha'), D.albedo.ranges[j]);
      // the viewer at azimuth −30°, 15° above the horizon; the sky's sun is at azimuth 31°, 54° up
      const el = 15 * Math.PI / 180, az = -30 * Math.PI / 180;
      const w = [Math.cos(el) * Math.cos(az), Math.cos(el) * Math.sin(az), Math.sin(el)];
      const r = normalize(cross([0, 0, 1], w));
      const up = cross(w, r);
      gl.uniformMatrix3fv(v.u('camera'), false, [...r, ...up, ...w]);
    }),
    scatterogram: makeView('scatterogram', SCATTEROGRAM),
    rmap: makeView('rmap', RMAP),
    strip: makeView('strip', STRIP),
  };

  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function normalize(a) { const l = Math.hypot(...a); return a.map((x) => x / l); }

  // --- the material of the current state ------------------------------------------------------
  function material() {
    if (state.family === 'bragg') {
      const t = D.bragg[String(state.cells)];
      const p = t.parameters;
      return { family: 0, texture: t, mat: [state.period, state.delta, p.n1, p.n2], n0: p.n_incident, cells: state.cells };
    }
    const t = D.film[BASES[state.base]];
    const ns = t.parameters.n_substrate;
    const base = Array.isArray(ns) ? ns : [ns, 0];
    return { family: 1, texture: t, mat: [state.thickness, state.n_film, base[0], base[1]], n0: t.parameters.n_incident,
             cells: 1 };
  }

  function draw(view, m) {
    const gl = view.gl;
    gl.useProgram(view.prog);
    if (!view.materials[m.texture.name]) {
      view.materials[m.texture.name] = texture3d(gl, 0, m.texture.shape, m.texture.data, 3, false);
    }
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_3D, view.materials[m.texture.name]);
    gl.uniform1i(view.u('mat_tex'), 0);
    gl.uniform2f(view.u('resolution'), gl.drawingBufferWidth, gl.drawingBufferHeight);
    gl.uniform1i(view.u('family'), m.family);
    ['ax0', 'ax1', 'ax2'].forEach((name, i) => gl.uniform3fv(view.u(name), m.texture.ranges[i]));
    gl.uniform4fv(view.u('mat'), m.mat);
    gl.uniform1f(view.u('n0'), m.n0);
    gl.uniform1f(view.u('alpha'), state.alpha);
    gl.uniform1i(view.u('cells'), m.cells);
    const light = view.u('light');
    if (light) gl.uniform1f(light, state.light * Math.PI / 180);
    gl.viewport(0, 0, gl.drawingBufferWidth, gl.drawingBufferHeight);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }

  let frameMs = NaN;
  function render() {
    const t0 = performance.now();
    const m = material();
    for (const v of Object.values(views)) draw(v, m);
    const px = new Uint8Array(4);
    for (const v of Object.values(views)) v.gl.readPixels(0, 0, 1, 1, v.gl.RGBA, v.gl.UNSIGNED_BYTE, px);  // wait for the GPU
    frameMs = performance.now() - t0;
    $('status').textContent = `redrawn in ${frameMs.toFixed(1)} ms (${m.texture.name} texture, ` +
      `${m.texture.shape.join(' × ')} texels)`;
    return frameMs;
  }

  let pending = false;
  function schedule() {
    if (pending) return;
    pending = true;
    requestAnimationFrame(() => { pending = false; render(); });
  }

  // --- controls -------------------------------------------------------------------------------
  function label(id) {
    const v = state[id];
    if (id === 'base') return BASES[v];
    if (id === 'delta' || id === 'alpha' || id === 'n_film') return v.toFixed(2);
    return String(v);
  }

  for (const input of document.querySelectorAll('input[type=range]')) {
    const id = input.id;
    const out = document.querySelector(`output[for=${id}]`);
    input.value = state[id];
    out.textContent = label(id);
    input.addEventListener('input', () => {
      state[id] = id === 'base' || id === 'cells' ? parseInt(input.value, 10) : parseFloat(input.value);
      out.textContent = label(id);
      schedule();
    });
  }
  for (const radio of document.querySelectorAll('input[name=family]')) {
    radio.addEventListener('change', () => {
      state.family = radio.value;
      $('bragg-controls').hidden = state.family !== 'bragg';
      $('film-controls').hidden = state.family !== 'film';
      schedule();
    });
  }
  // the reflectance map's colour scale: grey level √R against R, linear in R upwards (ticks in index.html)
  (function drawScale() {
    const c = $('rmap-scale'), ctx = c.getContext('2d');
    const img = ctx.createImageData(c.width, c.height);
    for (let y = 0; y < c.height; y++) {
      const g = Math.round(255 * Math.sqrt((c.height - 1 - y + 0.5) / c.height));  // canvas rows run downwards
      for (let x = 0; x < c.width; x++) img.data.set([g, g, g, 255], 4 * (y * c.width + x));
    }
    ctx.putImageData(img, 0, 0);
  })();

  function indexText(ns) {  // the base's index: a number or [n, κ]
    const [n, k] = Array.isArray(ns) ? ns : [ns, 0];
    return k ? `${n} + ${k}i` : String(n);
  }
  function showBase() { $('base-index').textContent = indexText(D.film[BASES[state.base]].parameters.n_substrate); }
  $('base').addEventListener('input', showBase);
  showBase();

  const bragg = D.bragg[String(state.cells)].parameters;
  $('n1').textContent = bragg.n1;
  $('n2').textContent = bragg.n2;
  $('version').textContent = `torchirid ${D.version}.`;
  render();

  // --- for scripts and tests: the state, a synchronous redraw, pixel read-back -----------------
  window.torchiridExplorer = {
    state, render, material,
    get frameMs() { return frameMs; },
    read(id) {  // redraw the view `id` and return its pixels
      const gl = views[id].gl;
      draw(views[id], material());
      const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
      const px = new Uint8Array(4 * w * h);
      gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
      let bin = '';
      for (let i = 0; i < px.length; i += 0x8000) bin += String.fromCharCode.apply(null, px.subarray(i, i + 0x8000));
      return { width: w, height: h, rgba: btoa(bin) };  // RGBA8, rows bottom-up, base64
    },
  };
})();
