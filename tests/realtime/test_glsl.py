"""The shipped GLSL (torchirid/realtime/glsl/torchirid.glsl) compiles as a GLSL ES 3.00 fragment
shader (Khronos' reference compiler, glslangValidator: `bash run.sh` installs Debian's
glslang-tools where it can) and names the functions and conventions the textures need."""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from torchirid.realtime import glsl_source

FRAGMENT = """#version 300 es
precision highp float;
precision highp sampler3D;
{library}
uniform sampler2D film;
uniform sampler3D bragg;
uniform sampler3D films;
uniform sampler3D rough;
uniform sampler2D weights;
out vec4 color;
void main() {{
    vec3 n = vec3(0.0, 0.0, 1.0), wi = normalize(vec3(0.3, 0.0, 1.0)), wo = normalize(vec3(-0.3, 0.1, 1.0));
    float cd = tirid_cos_d(wi, wo);
    vec3 r = tirid_thin_film_rgb(film, vec3(0.0, 1.0, 16.0), vec3(100.0, 800.0, 64.0), cd, 300.0)
           + tirid_bragg_rgb(bragg, vec3(0.0, 1.0, 8.0), vec3(300.0, 1100.0, 64.0), vec3(0.3, 0.7, 4.0), cd,
                             170.0, 0.5, 1.59, 1.67, 1.0)
           + tirid_thin_film_path_rgb(films, vec3(0.0, 1.0, 16.0), vec3(0.0, 3000.0, 96.0), vec3(1.2, 2.4, 8.0), cd,
                                      300.0, 1.5, 1.0)
           + tirid_rough_thin_film_rgb(rough, vec3(0.14, 1.0, 8.0), vec3(0.05, 0.5, 8.0), vec3(100.0, 800.0, 64.0), cd,
                                       0.2, 300.0)
           + tirid_xyz_to_linear_srgb(tirid_bragg_envelope_xyz(weights, 64, vec2(0.008055, 0.016535), cd, 1.59, 1.67,
                                                               85.0, 85.0, 20))
           + vec3(tirid_thin_film_reflectance(550.0, cd, 1.0, 1.33, 300.0, vec2(2.0, 0.5))
                  + tirid_bragg_reflectance(550.0, cd, 1.0, 1.59, 1.67, 85.0, 85.0, 8));
    color = vec4(tirid_linear_to_srgb(tirid_microfacet_brdf(n, wi, wo, 0.2, r)), 1.0);
}}
"""


def test_the_library_names_its_functions_and_has_no_version_line():
    src = glsl_source()
    assert "#version" not in src  # the including shader's first line
    names = set(re.findall(r"^\w+\s+(tirid_\w+)\(", src, flags=re.M))
    assert {"tirid_texcoord", "tirid_thin_film_rgb", "tirid_bragg_wavelength", "tirid_bragg_rgb", "tirid_ggx_d",
            "tirid_g1_over_cos", "tirid_microfacet_brdf", "tirid_cos_d", "tirid_linear_to_srgb", "tirid_path_difference",
            "tirid_thin_film_path_rgb", "tirid_rough_thin_film_rgb", "tirid_sincos", "tirid_thin_film_reflectance",
            "tirid_bragg_reflectance", "tirid_bragg_envelope_xyz", "tirid_xyz_to_linear_srgb"} <= names


@pytest.mark.integration  # the GLSL reference compiler
@pytest.mark.skipif(shutil.which("glslangValidator") is None,
                    reason="glslangValidator not installed (Debian: apt-get install glslang-tools)")
def test_compiles_as_glsl_es_300(tmp_path):
    frag = tmp_path / "t.frag"
    frag.write_text(FRAGMENT.format(library=glsl_source()))
    run = subprocess.run(["glslangValidator", str(frag)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stdout + run.stderr
    broken = tmp_path / "broken.frag"  # a positive control: the compiler does reject errors
    broken.write_text(FRAGMENT.format(library=glsl_source()).replace("tirid_cos_d(wi, wo)", "tirid_cos_d(wi)"))
    assert subprocess.run(["glslangValidator", str(broken)], capture_output=True, timeout=60).returncode != 0
