r"""The forward model and the loss of scatterogram matching: a rough Bragg layer from its
parameters (:func:`bragg_structure`), its rendered targets (:func:`render_targets`) and the
loss in CIE L*a*b* with a free exposure (:func:`scatterogram_loss`).

The loss lives in CIE L*a*b* (D65): the target is normalised once so that its brightest Y
is 1, the model is multiplied by a free exposure ``s`` (started at the closed-form
least-squares scale in XYZ), and the loss is the mean over the disc of
``|Lab(s · model) − Lab(target)|²`` (ΔE*ab², smooth: L-BFGS friendly), or the mean CIEDE2000.
"""

from __future__ import annotations

import numbers

import torch

from .. import _checks
from ..color import delta_e_2000, xyz_to_lab
from ..layered.structure import LayeredBragg, RoughBraggLayer
from ..layered.scatterograms import (
    scatterogram,
)


__all__ = ["bragg_structure", "render_targets", "scatterogram_loss"]

#: default wavelengths of the fit: 380–780 nm in 10 nm steps
DEFAULT_FIT_WAVELENGTHS = (380.0, 780.0, 41)
_LOSSES = ("lab", "de2000")


# ----------------------------------------------------------------------------------------
# the model
# ----------------------------------------------------------------------------------------
def bragg_structure(n1, n2, period, delta, cells: int, alpha, *, n_incident: float = 1.0,
                    base_albedo: float = 0.0) -> LayeredBragg:
    """One rough Bragg layer ``d2 = δΛ``, ``d1 = (1 − δ)Λ`` (the preset convention) as a
    :class:`~torchirid.layered.structure.LayeredBragg`; tensor parameters keep their graph.

    >>> s = bragg_structure(1.59, 1.67, 160.0, 0.51, 8, 0.05)
    >>> l = s.layers[0]
    >>> round(l.d1, 6), round(l.d2, 6), l.n_incident
    (78.4, 81.6, 1.0)
    """
    layer = RoughBraggLayer(n1, n2, (1.0 - delta) * period, delta * period, cells, alpha, n_incident=n_incident)
    return LayeredBragg([layer], base_albedo=base_albedo)


def _check_incident(incident_deg) -> list:
    """``incident_deg``: one illumination (None or (θ, φ)) or a list of them → list."""
    if incident_deg is None or (isinstance(incident_deg, (tuple, list)) and len(incident_deg) == 2
                            and all(isinstance(v, numbers.Real) for v in incident_deg)):
        return [incident_deg]
    if not isinstance(incident_deg, (tuple, list)) or not incident_deg:
        raise ValueError(f"incident_deg must be None, (theta_deg, phi_deg) or a non-empty list of them; got {incident_deg!r}")
    out = []
    for inc in incident_deg:
        if inc is not None and not (isinstance(inc, (tuple, list)) and len(inc) == 2
                                    and all(isinstance(v, numbers.Real) for v in inc)):
            raise ValueError(f"incident_deg must be None, (theta_deg, phi_deg) or a list of them; got item {inc!r}")
        out.append(None if inc is None else (float(inc[0]), float(inc[1])))
    return out


def render_targets(structure, incident_deg, *, resolution: int, wavelength=None, projection: str = "equidistant",
                   reflectance: str = "exact") -> torch.Tensor:
    """The scatterograms of ``structure`` under each illumination of ``incident_deg`` stacked:
    ``(K, H, W, 3)`` XYZ (differentiable, see :func:`~torchirid.layered.scatterograms.scatterogram`).

    Args:
        structure: a :class:`~torchirid.layered.structure.LayeredBragg` (or one rough layer).
        incident_deg: one illumination — ``None`` (the white environment) or ``(θ, φ)`` in
            degrees (a narrow beam) — or a list of them (K).
        resolution, wavelength, projection, reflectance: as
            :func:`~torchirid.layered.scatterograms.scatterogram` (wavelength in nm).

    Example (a green jewel beetle under two beams, 12 × 12 pixels each):
        >>> import torch
        >>> from torchirid.presets import jewel_beetle
        >>> t = render_targets(jewel_beetle("green"), [(0.0, 0.0), (40.0, 0.0)], resolution=12,
        ...                    wavelength=torch.linspace(380.0, 780.0, 41, dtype=torch.float64))
        >>> tuple(t.shape), bool(t[..., 1].max() > 0)  # (K, H, W, XYZ)
        ((2, 12, 12, 3), True)
    """
    incs = _check_incident(incident_deg)
    return torch.stack([scatterogram(structure, incident_deg=inc, resolution=resolution, wavelength=wavelength,
                                     projection=projection, reflectance=reflectance).xyz for inc in incs])


# ----------------------------------------------------------------------------------------
# the loss
# ----------------------------------------------------------------------------------------
def _lsq_scale(model: torch.Tensor, target: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Closed-form least-squares exposure argmin_s Σ_mask |s·model − target|² (XYZ)."""
    m, t = model[mask], target[mask]
    den = (m * m).sum()
    tiny = torch.finfo(m.dtype).tiny
    return (m * t).sum() / den.clamp_min(tiny)  # guard: an all-black model gets a finite scale


def scatterogram_loss(model_xyz, target_xyz, mask=None, *, scale=None, loss: str = "lab") -> torch.Tensor:
    r"""Exposure-robust perceptual loss between two stacks of scatterograms.

    Args:
        model_xyz, target_xyz: ``(*, H, W, 3)`` XYZ (same shape; the target normalised so
            that its white has Y = 1 — :func:`match_scatterogram` divides by its peak Y).
        mask: ``(H, W)`` (or broadcastable to ``(*, H, W)``) bool, the pixels compared;
            default all.
        scale: the exposure applied to the model (number or tensor); ``None``: the
            closed-form least-squares scale in XYZ, so the loss does not change when the
            model (or, with a matching target, the target) is multiplied by a constant.
        loss: ``"lab"`` — mean ΔE*ab² (squared Euclidean distance in CIE L*a*b*, D65) — or
            ``"de2000"`` — mean CIEDE2000.

    Returns:
        a 0-dim tensor (differentiable in both inputs and ``scale``).

    >>> t = torch.rand(2, 5, 5, 3, dtype=torch.float64, generator=torch.Generator().manual_seed(0))
    >>> float(scatterogram_loss(3.7 * t, t)) < 1e-20  # exposure invariance
    True
    """
    _checks.check_choice(loss, "loss", _LOSSES)
    model_xyz = torch.as_tensor(model_xyz)
    target_xyz = torch.as_tensor(target_xyz)
    if model_xyz.shape != target_xyz.shape or model_xyz.dim() < 3 or model_xyz.shape[-1] != 3:
        raise ValueError(f"model_xyz and target_xyz must share a shape (*, H, W, 3); got {tuple(model_xyz.shape)} "
                         f"and {tuple(target_xyz.shape)}")
    if mask is None:
        mask = torch.ones(model_xyz.shape[:-1], dtype=torch.bool, device=model_xyz.device)
    mask = torch.as_tensor(mask, dtype=torch.bool, device=model_xyz.device).expand(model_xyz.shape[:-1])
    if scale is None:
        scale = _lsq_scale(model_xyz, target_xyz, mask)
    lab_m = xyz_to_lab(scale * model_xyz[mask])
    lab_t = xyz_to_lab(target_xyz[mask])
    if loss == "lab":
        return ((lab_m - lab_t) ** 2).sum(-1).mean()
    return delta_e_2000(lab_m, lab_t).mean()


