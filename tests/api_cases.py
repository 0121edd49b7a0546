"""The table of public per-sample calls that the API-wide tests share.

One entry per function (and per output of functions returning tuples): name → (function, a
builder of its keyword arguments with the per-sample ones on a leading axis of size 2 (two equal
samples), the per-sample arguments, which output to check: ``None`` = the result itself, an int =
that element of a returned tuple, a callable = applied to the result). Used by
contract/test_nan_harness.py (NaN propagation, dtype, broadcasting, gradients, hard cases) and
test_devices.py (every call with its tensors on every available device).
"""

from __future__ import annotations

import torch

import torchirid as ti
from tensors import F64, t64

NAN = float("nan")


def two(x):
    """A batch of two equal samples: ``x`` stacked on a new leading axis (a fresh tensor)."""
    x = torch.as_tensor(x, dtype=torch.complex128 if torch.as_tensor(x).is_complex() else F64)
    return torch.stack([x, x]).clone()


def unit(*v):
    x = t64(v)
    return x / x.norm()


WL = t64([450.0, 550.0, 650.0])


def _layer():
    from torchirid.layered import RoughBraggLayer

    return RoughBraggLayer(1.0, 1.5, 250.0, 250.0, 10, 0.1)


def _structure():
    from torchirid.layered import LayeredBragg

    return LayeredBragg([_layer()])


def _stack():
    from torchirid.optics.film_stack import FilmStack

    return FilmStack([(1.4, 300.0), (2.0, 80.0)], 1.52)


def _table():
    return ti.optics.film_reflectance_lut(_stack(), angles=9, wavelengths=11)


# name → (function, builder of its keyword arguments (per-sample ones with the leading axis 2),
#         the per-sample arguments to poison, outputs to check: None = the result itself,
#         an int = that element of a returned tuple)
CASES = {
    "thin_film_reflectance": (ti.thin_film_reflectance, lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), n_film=two([1.4]), thickness=two([300.0]),
        n_substrate=two([1.5]), n_incident=two([1.0])),
        ["cos_theta", "n_film", "thickness", "n_substrate", "n_incident"], None),
    **{f"multilayer {k}": (ti.multilayer, (lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), indices=two([[1.0, 1.4, 2.0, 1.5]]), thicknesses=two([[100.0, 50.0]]))),
        ["cos_theta", "indices", "thicknesses"], i) for i, k in enumerate(("r", "t"))},
    "bragg_reflectance": (ti.bragg_reflectance, lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), n1=two([1.0]), n2=two([1.5]), d1=two([125.0]), d2=two([375.0]),
        cells=5), ["cos_theta", "n1", "n2", "d1", "d2"], None),
    "bragg_reflectance with n_incident": (ti.bragg_reflectance, lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), n1=1.3, n2=1.5, d1=125.0, d2=375.0, cells=5, n_incident=two([1.0])),
        ["cos_theta", "n_incident"], None),
    "bragg_dispersion": (ti.optics.bragg_dispersion, lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), n1=two([1.0]), n2=two([1.5]), d1=two([125.0]), d2=two([375.0])),
        ["cos_theta", "n1", "n2", "d1", "d2"], None),
    "bragg_envelope": (ti.optics.bragg_envelope, lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), n1=two([1.0]), n2=two([1.5]), d1=two([125.0]), d2=two([375.0])),
        ["cos_theta", "n1", "n2", "d1", "d2"], None),
    "fresnel_reflectance": (ti.optics.fresnel_reflectance, lambda: dict(
        cos_theta=two(0.8), n_incident=two(1.0), n_substrate=two(1.5)), ["cos_theta", "n_incident", "n_substrate"], None),
    **{f"bragg_xyz {m}": (ti.bragg_xyz, (lambda m=m, extra=extra: dict(
        cos_theta=two(0.7), n1=two(1.0), n2=two(1.5), d1=two(120.0), d2=two(130.0), cells=12, method=m, **extra)),
        ["cos_theta", "n1", "n2", "d1", "d2"], None)
       for m, extra in (("spectral", {}), ("sampled", {"samples": 64}), ("piecewise", {}),
                        ("envelope", {"samples": 32}), ("auto", {}))},
    # colour
    "spectrum_to_xyz": (ti.spectrum_to_xyz, lambda: dict(spectrum=two([0.2, 0.5, 0.7]), wavelength=WL),
                        ["spectrum"], None),
    "xyz_to_lab": (ti.xyz_to_lab, lambda: dict(xyz=two([0.3, 0.4, 0.2])), ["xyz"], None),
    "lab_to_xyz": (ti.color.lab_to_xyz, lambda: dict(lab=two([50.0, 10.0, -20.0])), ["lab"], None),
    "xyz_to_linear_srgb": (ti.color.xyz_to_linear_srgb, lambda: dict(xyz=two([0.3, 0.4, 0.2])), ["xyz"], None),
    "xyz_to_srgb": (ti.xyz_to_srgb, lambda: dict(xyz=two([0.3, 0.4, 0.2])), ["xyz"], None),
    "linear_srgb_to_srgb": (ti.color.linear_srgb_to_srgb, lambda: dict(rgb=two([0.3, 0.002, 0.8])), ["rgb"], None),
    "delta_e_2000": (ti.color.delta_e_2000, lambda: dict(lab1=two([50.0, 10.0, -20.0]), lab2=two([52.0, 8.0, -18.0])),
                     ["lab1", "lab2"], None),
    "delta_e_1976": (ti.color.delta_e_1976, lambda: dict(lab1=two([50.0, 10.0, -20.0]), lab2=two([52.0, 8.0, -18.0])),
                     ["lab1", "lab2"], None),
    # microfacets
    "absorption": (ti.layered.transmission.absorption, lambda: dict(cos_theta=two(0.5), alpha=two(0.2)), ["cos_theta", "alpha"], None),
    "filter_quadrature nodes": (ti.layered.filter.filter_quadrature, lambda: dict(cos_theta_i=two(0.5), alpha=two(0.2), nodes=8),
                                ["cos_theta_i", "alpha"], 0),
    "filter_quadrature weights": (ti.layered.filter.filter_quadrature, lambda: dict(cos_theta_i=two(0.5), alpha=two(0.2), nodes=8),
                                  ["cos_theta_i", "alpha"], 1),
    "ggx_d": (ti.microfacet.ggx_d, lambda: dict(cos_theta_m=two(0.9), alpha=two(0.2)), ["cos_theta_m", "alpha"], None),
    "smith_g1": (ti.microfacet.smith_g1, lambda: dict(cos_theta=two(0.4), alpha=two(0.2)), ["cos_theta", "alpha"], None),
    "smith_g": (ti.microfacet.smith_g, lambda: dict(wi=two(unit(0.3, 0.0, 1.0)), wo=two(unit(-0.2, 0.1, 1.0)),
                                         m=two(unit(0.05, 0.05, 1.0)), alpha=two(0.2)),
                ["wi", "wo", "m", "alpha"], None),
    "ggx_vndf_pdf": (ti.microfacet.ggx_vndf_pdf, lambda: dict(wi=two(unit(0.3, 0.0, 1.0)), m=two(unit(0.05, 0.05, 1.0)),
                                                   alpha=two(0.2)), ["wi", "m", "alpha"], None),
    "microfacet_brdf": (ti.microfacet.microfacet_brdf, lambda: dict(wi=two(unit(0.3, 0.0, 1.0)), wo=two(unit(-0.2, 0.1, 1.0)),
                                                         alpha=two(0.2), reflectance=two(0.6)),
                        ["wi", "wo", "alpha", "reflectance"], None),
    "sample_ggx_vndf": (ti.microfacet.sample_ggx_vndf, lambda: dict(wi=two(unit(0.3, 0.0, 1.0)), alpha=two(0.2),
                                                         u=two([0.3, 0.7])), ["wi", "alpha", "u"], None),
    # rough Bragg layers
    "transmission_filter": (ti.layered.transmission_filter, lambda: dict(theta_i_rad=two(0.5), theta_d_rad=two(0.3),
                                                                 alpha=two(0.2)),
                            ["theta_i_rad", "theta_d_rad", "alpha"], None),
    "transmission_probability": (ti.layered.transmission.transmission_probability, lambda: dict(
        tau=two([0.4, 0.6]), cos_theta=two(0.8), alpha=two(0.1)), ["tau", "cos_theta", "alpha"], None),
    "transmission_weight": (ti.layered.transmission.transmission_weight, lambda: dict(
        tau=two([0.4, 0.6]), cos_theta=two(0.8), alpha=two(0.1)), ["tau", "cos_theta", "alpha"], None),
    "integrated_transmissivity": (ti.layered.integrated_transmissivity, lambda: dict(
        layer=_layer(), cos_theta=two([0.8]), wavelength=WL, nodes=32), ["cos_theta"], None),
    "single_reflection_brdf": (ti.single_reflection_brdf, lambda: dict(
        structure=_structure(), wi=two(unit(0.3, 0.0, 1.0)), wo=two(unit(-0.2, 0.1, 1.0)), wavelength=WL,
        transmissivity_angles=33), ["wi", "wo"], None),
    # thin-film colour for renderers
    **{f"thin_film_xyz_fourier {s}": (ti.ibl.thin_film_xyz_fourier, (lambda s=s: dict(
        cos_theta=two(0.8), n_film=two(1.33), thickness=two(300.0), n_substrate=two(1.5), sensitivity=s)),
        ["cos_theta", "n_film", "thickness", "n_substrate"], None) for s in ("lut", "exact")},
    "thin_film_xyz": (ti.thin_film_xyz, lambda: dict(
        cos_theta=two(0.8), n_film=two(1.33), thickness=two(300.0), n_substrate=two(1.5)),
        ["cos_theta", "n_film", "thickness", "n_substrate"], None),
    "thin_film_xyz fitted": (ti.thin_film_xyz, lambda: dict(
        cos_theta=two(0.8), alpha=two(0.25), n_film=two(1.3), thickness=two(600.0), n_substrate=two(1.5),
        method="fitted", sensitivity="exact"), ["cos_theta", "alpha", "n_film", "thickness", "n_substrate"], None),
    "thin_film_xyz_filtered": (ti.ibl.thin_film_xyz_filtered, lambda: dict(
        wo=two([0.0, 0.0, 1.0]), light_mean=two([0.1, 0.0, 0.9]), light_cov=two(0.01 * torch.eye(3, dtype=F64)),
        n_film=two(1.33), thickness=two(300.0), n_substrate=two(1.5), sensitivity="exact"),
        ["wo", "light_mean", "light_cov", "n_film", "thickness", "n_substrate"], None),
    "thin_film_xyz_fitted": (ti.ibl.thin_film_xyz_fitted, lambda: dict(
        cos_theta_o=two(0.8), alpha=two(0.25), n_film=two(1.3), thickness=two(600.0), n_substrate=two(1.5),
        sensitivity="exact"),
        ["cos_theta_o", "alpha", "n_film", "thickness", "n_substrate"], None),
    "thin_film_xyz_uniform": (ti.ibl.thin_film_xyz_uniform, lambda: dict(
        cos_theta_o=two(0.8), alpha=two(0.25), n_film=two(1.3), thickness=two(600.0), n_substrate=two(1.5),
        bins=64, nodes=8), ["cos_theta_o", "alpha", "n_film", "thickness", "n_substrate"], None),
    # Hirayama's films
    **{f"film_reflectance k_{k}": (ti.optics.film_reflectance, (lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), stack=_stack(), thicknesses=two([[300.0, 80.0]]))),
        ["cos_theta", "thicknesses"], i) for i, k in enumerate("rt")},
    "rough_multilayer_reflectance": (ti.optics.rough_multilayer_reflectance, lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), indices=two([[1.0, 1.4, 1.5]]), thicknesses=two([[300.0]]),
        sigma=two([20.0]), tau=two([300.0])), ["cos_theta", "indices", "thicknesses", "sigma", "tau"], None),
    "rough_multilayer_diffuse": (ti.optics.rough_multilayer_diffuse, lambda: dict(
        wavelength=WL, cos_theta_i=two([0.9]), cos_theta_o=two([0.8]), cos_phi=two([-0.5]),
        indices=two([[1.0, 1.4, 1.5]]), thicknesses=two([[300.0]]), sigma=two([20.0]), tau=two([300.0])),
        ["cos_theta_i", "cos_theta_o", "cos_phi", "indices", "thicknesses", "sigma", "tau"], None),
    "smooth_radiance": (ti.optics.film_stack.smooth_radiance, lambda: dict(
        wavelength=WL, normal=two([0.0, 0.0, 1.0]), view=two(unit(0.3, 0.0, 1.0)), stack=_stack(),
        reflected=two([1.0, 0.8, 0.5])), ["normal", "view", "reflected"], None),
    **{f"lookup_film_reflectance k_{k}": (ti.optics.lookup_film_reflectance, (lambda: dict(
        lut=_table(), wavelength=two([515.0]), cos_theta=two([0.7]))), ["wavelength", "cos_theta"], i)  # (off the nodes)
       for i, k in enumerate("rt")},
    "refractive_index": (ti.refractive_index, lambda: dict(material="SiO2", wavelength=two(550.0)),
                         ["wavelength"], None),
    "refractive_index tabulated": (ti.refractive_index, lambda: dict(material="Ag", wavelength=two(553.3)),
                                   ["wavelength"], None),
}


def _sub(module, name):
    """``torchirid.<module>.<name>``, or the internal function of that name in one of the
    package's modules (kernels that are not public API keep their contract checks here)."""
    import importlib
    import pkgutil

    package = importlib.import_module(f"torchirid.{module}")
    if hasattr(package, name):
        return getattr(package, name)
    for info in pkgutil.iter_modules(package.__path__):
        sub = importlib.import_module(f"torchirid.{module}.{info.name}")
        if hasattr(sub, name):
            return getattr(sub, name)
    raise AttributeError(f"torchirid.{module} has no {name}")


# the per-sample functions of the subpackages that the flat namespace does not re-export
SUBPACKAGE_CASES = {
    "optics.he_torrance.coherent_attenuation": (_sub("optics", "coherent_attenuation"), lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), sigma=two([20.0])), ["cos_theta", "sigma"], None),
    "optics.he_torrance.effective_roughness": (_sub("optics", "effective_roughness"), lambda: dict(
        cos_theta_i=two(0.9), cos_theta_o=two(0.8), sigma=two(20.0), tau=two(300.0)),
        ["cos_theta_i", "cos_theta_o", "sigma", "tau"], None),
    "optics.he_directional_diffuse": (_sub("optics", "he_directional_diffuse"), lambda: dict(
        wavelength=WL, cos_theta_i=two([0.9]), cos_theta_o=two([0.8]), cos_phi=two([-0.5]), sigma=two([20.0]),
        tau=two([300.0]), n_substrate=two([1.5])),
        ["cos_theta_i", "cos_theta_o", "cos_phi", "sigma", "tau", "n_substrate"], None),
    "optics.he_torrance.he_shadowing": (_sub("optics", "he_shadowing"), lambda: dict(
        cos_theta=two(0.5), sigma=two(20.0), tau=two(300.0)), ["cos_theta", "sigma", "tau"], None),
    "optics.he_torrance.roughness_factor": (_sub("optics", "roughness_factor"), lambda: dict(
        wavelength=WL, cos_theta_i=two([0.9]), cos_theta_o=two([0.8]), sigma=two([20.0])),
        ["cos_theta_i", "cos_theta_o", "sigma"], None),
    "spectral.angular_correction": (_sub("spectral", "angular_correction"), lambda: dict(
        cos_theta=two(0.6), n1=two(1.0), n2=two(1.5)), ["cos_theta", "n1", "n2"], None),
    "spectral.correction.angular_correction_reference": (_sub("spectral", "angular_correction_reference"), lambda: dict(
        cos_theta=two(0.6), n1=two(1.0), n2=two(1.5), samples=16), ["cos_theta", "n1", "n2"], None),
    "spectral.correction.angular_correction_limit": (_sub("spectral", "angular_correction_limit"), lambda: dict(
        cos_theta=two(0.6), n1=two(1.0), n2=two(1.5)), ["cos_theta", "n1", "n2"], None),
    "spectral.bragg_xyz_piecewise paper weights": (_sub("spectral", "bragg_xyz_piecewise"), lambda: dict(
        cos_theta=two(0.7), n1=two(1.0), n2=two(1.5), d1=two(120.0), d2=two(130.0), cells=12, subdivisions=3,
        weights="paper", correction="paper"), ["cos_theta", "n1", "n2", "d1", "d2"], None),
    "spectral.bragg_xyz_envelope": (_sub("spectral", "bragg_xyz_envelope"), lambda: dict(
        cos_theta=two(0.7), n1=two(1.0), n2=two(1.5), d1=two(120.0), d2=two(130.0), cells=12, samples=24),
        ["cos_theta", "n1", "n2", "d1", "d2"], None),
    "spectral.envelope.fringe_averaged_reflectance": (_sub("spectral", "fringe_averaged_reflectance"), lambda: dict(
        wavelength=WL, cos_theta=two([0.7]), n1=two([1.0]), n2=two([1.5]), d1=two([120.0]), d2=two([130.0]),
        cells=12), ["cos_theta", "n1", "n2", "d1", "d2"], None),
    "microfacet.reflect": (_sub("microfacet", "reflect"), lambda: dict(
        wi=two(unit(0.3, 0.0, 1.0)), m=two(unit(0.05, 0.05, 1.0))), ["wi", "m"], None),
    "microfacet.smith_lambda": (_sub("microfacet", "smith_lambda"), lambda: dict(
        cos_theta=two(0.4), alpha=two(0.2)), ["cos_theta", "alpha"], None),
    "layered.tables.coating_reflectance": (_sub("layered", "coating_reflectance"), lambda: dict(
        cos_theta=two(0.6), n_incident=1.4), ["cos_theta"], None),  # (n_incident: one coating, a scalar)
    "layered.single_reflection_pdf": (_sub("layered", "single_reflection_pdf"), lambda: dict(
        structure=_structure(), wi=two(unit(0.3, 0.0, 1.0)), wo=two(unit(-0.2, 0.1, 1.0)), wavelength=WL,
        transmissivity_angles=33), ["wi", "wo"], None),
    "layered.importance_sampling.layer_reflection_probabilities": (_sub("layered", "layer_reflection_probabilities"), lambda: dict(
        structure=_structure(), cos_theta=two([0.8]), wavelength=WL, transmissivity_angles=33),
        ["cos_theta"], None),
    "ibl.fourier_sensitivity": (_sub("ibl", "fourier_sensitivity"), lambda: dict(D=two(903.37)), ["D"], None),  # (off the table nodes)
    "ibl.sensitivity.fourier_sensitivity_exact": (_sub("ibl", "fourier_sensitivity_exact"), lambda: dict(D=two(900.0)),
                                      ["D"], None),
    "ibl.sensitivity.prefiltered_fourier_sensitivity": (_sub("ibl", "prefiltered_fourier_sensitivity"), lambda: dict(
        mu=two(900.0), sigma2=two(50.0**2)), ["mu", "sigma2"], None),
    **{f"ibl.path_difference_moments {i}": (_sub("ibl", "path_difference_moments"), (lambda: dict(
        cos_theta_o=two(0.8), alpha=two(0.25), n_film=two(1.3), thickness=two(600.0), bins=64, nodes=8)),
        ["cos_theta_o", "alpha", "n_film", "thickness"][: 4 if i < 2 else 3], i) for i in range(4)},
    # (outputs 2, 3 are the moments of cos θ2, which do not depend on the thickness)
    **{f"ibl.uniform_light_moments {i}": (_sub("ibl", "uniform_light_moments"), (lambda: dict(
        cos_theta_o=two(0.8), alpha=two(0.25), nodes=8)), ["cos_theta_o", "alpha"], i) for i in range(3)},
    "ibl.light_mixture": (_sub("ibl", "light_mixture"), lambda: dict(
        cos_theta_o=two(0.8), alpha=two(0.25), bins=64, nodes=8), ["cos_theta_o", "alpha"], None),
    **{f"ibl.uniform.cos_theta1_distribution {i}": (_sub("ibl", "cos_theta1_distribution"), (lambda: dict(
        cos_theta_o=two(0.8), alpha=two(0.25), bins=64, nodes=8)), ["cos_theta_o", "alpha"], i) for i in (1, 2)},
    "ibl.thin_film_xyz_gaussian_path": (_sub("ibl", "thin_film_xyz_gaussian_path"), lambda: dict(
        cos_theta=two(0.8), n_film=two(1.3), thickness=two(600.0), n_substrate=two(1.5), path_mean=two(1500.0),
        path_var=two(40.0**2), sensitivity="exact"), ["cos_theta", "n_film", "thickness", "n_substrate", "path_mean", "path_var"], None),
    **{f"estimation.measurement.airy_terms {i}": (_sub("estimation", "airy_terms"), (lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), n_film=two([1.4]), n_substrate=two([1.6]))),
        ["cos_theta", "n_film", "n_substrate"][: 3 if i < 3 else 2], (lambda o, i=i: o[i][0])) for i in range(4)},
    # (term 3 is the phase rate k = 4π η₂ cos θ₂ / λ, which does not depend on the substrate)
    "estimation.measurement.band_reflectance": (_sub("estimation", "band_reflectance"), lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), n_film=two([1.4]), thickness=two([400.0]), n_substrate=two([1.6])),
        ["cos_theta", "n_film", "thickness", "n_substrate"], None),
    "estimation.dispersion.sellmeier_index": (_sub("estimation", "sellmeier_index"), lambda: dict(
        wavelength=two(550.0), a=1.0, b=(0.5,), c=(0.1,)), ["wavelength"], None),  # (a, b, c: one material)
    "estimation.dispersion.zns_index": (_sub("estimation", "zns_index"), lambda: dict(wavelength=two(550.0)),
                             ["wavelength"], None),
    "estimation.index_model": (_sub("estimation", "index_model"), lambda: dict(
        wavelength=two(550.0), params=two([1.5, 4000.0]), model="cauchy"), ["wavelength", "params"], None),
}
# complex indices n + iκ (absorbing films, metal substrates): the complex paths of the same functions
ABSORBING_CASES = {
    "thin_film_reflectance metal substrate": (ti.thin_film_reflectance, lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), n_film=two([1.4]), thickness=two([300.0]),
        n_substrate=two([complex(0.2, 3.0)])), ["cos_theta", "n_film", "thickness", "n_substrate"], None),
    "thin_film_reflectance absorbing film": (ti.thin_film_reflectance, lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), n_film=two([complex(1.4, 0.05)]), thickness=two([300.0]),
        n_substrate=two([1.5])), ["n_film", "thickness"], None),
    "multilayer absorbing": (lambda **k: ti.multilayer(**k)[0], lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), indices=two([[complex(1.0, 0.0), complex(1.4, 0.02), complex(2.0, 0.01),
                                                          complex(0.1, 3.0)]]), thicknesses=two([[100.0, 50.0]])),
        ["cos_theta", "indices", "thicknesses"], None),
    "fresnel_reflectance metal": (ti.optics.fresnel_reflectance, lambda: dict(
        cos_theta=two(0.8), n_incident=two(1.0), n_substrate=two(complex(0.2, 3.0))), ["cos_theta", "n_substrate"], None),
    "bragg_reflectance absorbing": (ti.bragg_reflectance, lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), n1=two([1.0]), n2=two([complex(1.5, 0.01)]), d1=two([125.0]),
        d2=two([375.0]), cells=5), ["cos_theta", "n2", "d1", "d2"], None),
    "thin_film_xyz_fourier metal": (ti.ibl.thin_film_xyz_fourier, lambda: dict(
        cos_theta=two(0.8), n_film=two(1.33), thickness=two(300.0), n_substrate=two(complex(0.2, 3.0))),
        ["cos_theta", "thickness", "n_substrate"], None),
    "thin_film_xyz_filtered metal": (ti.ibl.thin_film_xyz_filtered, lambda: dict(
        wo=two([0.0, 0.0, 1.0]), light_mean=two([0.1, 0.0, 0.9]), light_cov=two(0.01 * torch.eye(3, dtype=F64)),
        n_film=two(1.33), thickness=two(300.0), n_substrate=two(complex(0.2, 3.0)), sensitivity="exact"),
        ["thickness", "n_substrate"], None),
    "optics.he_directional_diffuse metal": (_sub("optics", "he_directional_diffuse"), lambda: dict(
        wavelength=WL, cos_theta_i=two([0.9]), cos_theta_o=two([0.8]), cos_phi=two([-0.5]), sigma=two([20.0]),
        tau=two([300.0]), n_substrate=two([complex(0.5, 2.0)])), ["cos_theta_i", "n_substrate"], None),
    "rough_multilayer_reflectance absorbing": (ti.optics.rough_multilayer_reflectance, lambda: dict(
        wavelength=WL, cos_theta=two([0.8]), indices=two([[complex(1.0, 0.0), complex(1.4, 0.0), complex(0.2, 3.0)]]),
        thicknesses=two([[300.0]]), sigma=two([20.0]), tau=two([300.0])), ["cos_theta", "indices", "sigma"], None),
}
CASES = {**CASES, **SUBPACKAGE_CASES, **ABSORBING_CASES}


def pick(out, which):
    """The checked output of a call: the result itself, one element of a tuple, or ``which(out)``."""
    if which is None:
        return out
    return which(out) if callable(which) else out[which]


def subpackage(name):
    """The subpackage (or top-level module) of the function that case ``name`` calls, from the
    function's ``__module__`` (``torchirid.optics.bragg`` → ``"optics"``); a wrapper lambda is
    resolved by the public function its name starts with."""
    import pkgutil

    def part(obj):
        parts = (getattr(obj, "__module__", None) or "").split(".")
        return parts[1] if parts[0] == "torchirid" and len(parts) > 1 and not parts[1].startswith("_") else None

    found = part(CASES[name][0])
    if found:
        return found
    head = name.split()[0]
    if "." in head:  # "optics.name ...": the subpackage the key names
        return head.split(".")[0]
    places = [ti] + [getattr(ti, m.name) for m in pkgutil.iter_modules(ti.__path__)
                     if not m.name.startswith("_") and m.name != "app" and hasattr(ti, m.name)]
    return next((p for p in (part(getattr(place, head, None)) for place in places) if p), "torchirid")


def case_id(name):
    """The test id of case ``name``: ``<subpackage>.<case>``, so that ``pytest -k spectral`` selects the
    cases of ``torchirid.spectral`` (``"bragg_xyz auto"`` → ``"spectral.bragg_xyz auto"``)."""
    head, space, rest = name.partition(" ")
    return f"{subpackage(name)}.{head.rpartition('.')[2]}{space}{rest}"
