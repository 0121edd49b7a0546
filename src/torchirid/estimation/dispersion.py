r"""Refractive-index models as small differentiable functions of the wavelength (nm).

Three shapes, chosen by name (one registry, :data:`INDEX_MODELS`), each a function of the
vacuum wavelength λ in nm and a parameter vector ``params`` (last axis):

* ``"constant"``: :math:`n(λ) = A` — one parameter.
* ``"cauchy"``: :math:`n(λ) = A + B/λ_{µm}^2` — two parameters (λ in µm inside the formula,
  so A, B, C are all of order one).
* ``"cauchy3"``: :math:`n(λ) = A + B/λ_{µm}^2 + C/λ_{µm}^4` — three parameters.

The Sellmeier form :func:`sellmeier_index` is used for tabulated materials; the ZnS film of
Kobayashi et al. (Sample 3) follows :func:`zns_index`, the two-term Sellmeier fit of cubic
ZnS by M. Debenham, "Refractive indices of zinc sulfide in the 0.405–13-µm wavelength range",
*Appl. Opt.* 23, 2238–2239 (1984) (as tabulated by refractiveindex.info, ``main/ZnS/Debenham``):

.. math:: n^2 = 8.393 + \frac{0.14383}{λ^2 - 0.2421^2} + \frac{4430.99}{λ^2 - 36.71^2},
          \quad λ \text{ in µm},

which gives n = 2.367 at the sodium D line (589.3 nm) — the paper's "2.37" — and rises to
2.55 at 400 nm. The fit is stated for 405 nm–13 µm; at 400 nm it is extrapolated by 5 nm.
"""

from __future__ import annotations

import torch

from .. import _checks

__all__ = [
    "INDEX_MODELS",
    "index_model",
    "fit_index_model",
]

INDEX_MODELS = {"constant": 1, "cauchy": 2, "cauchy3": 3}
REFERENCE_WAVELENGTH = 589.3  # nm, sodium D line: where a dispersive index is reported as "n"

# Debenham (1984), cubic ZnS, n^2 = A + sum_i B_i / (λ^2 - C_i^2), λ in µm
_ZNS_A = 8.393
_ZNS_B = (0.14383, 4430.99)
_ZNS_C = (0.2421, 36.71)


def _check_model(model) -> None:
    _checks.check_choice(model, "index model", INDEX_MODELS)


def index_model_size(model: str) -> int:
    """Number of parameters of an index model (``"constant"`` → 1, ``"cauchy"`` → 2, ``"cauchy3"`` → 3).

    >>> index_model_size("cauchy")
    2
    """
    _check_model(model)
    return INDEX_MODELS[model]


def index_model(wavelength, params, model: str) -> torch.Tensor:
    r"""Real refractive index n(λ) of a Cauchy-type model (see the module docstring).

    Args:
        wavelength: vacuum wavelength in nm (> 0), shape ``(*)``.
        params: ``(*, K)`` parameters, K = ``index_model_size()`` of ``model``
            (A, then B and C in µm² and µm⁴).
        model: ``"constant"``, ``"cauchy"`` or ``"cauchy3"`` — no default: it fixes K, the
            length of ``params`` (as in :func:`fit_index_model`; ``"auto"``, a choice among the
            models by the data, is the film fit's: :func:`~torchirid.estimation.estimate_film`).

    Returns:
        n with the broadcast shape of ``wavelength`` and ``params[..., 0]``; differentiable
        in both.

    Example:
        >>> import torch
        >>> p = torch.tensor([1.5, 0.004], dtype=torch.float64)
        >>> round(float(index_model(torch.tensor(500.0, dtype=torch.float64), p, "cauchy")), 6)
        1.516
    """
    _check_model(model)
    dtype, device = _checks.resolve_dtype_device(wavelength, params)
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    p = _checks.as_real(params, "params", dtype, device)
    k = INDEX_MODELS[model]
    if p.ndim == 0 or p.shape[-1] != k:
        raise ValueError(f"params must have shape (*, {k}) for the {model!r} model; got {tuple(p.shape)}")
    _checks.check_wavelength(lam)
    if k == 1:
        return p[..., 0] + torch.zeros_like(lam)
    inv2 = (1000.0 / lam) ** 2  # 1/λ² with λ in µm
    n = p[..., 0] + p[..., 1] * inv2
    if k == 3:
        n = n + p[..., 2] * inv2 * inv2
    return n


def sellmeier_index(wavelength, a, b, c) -> torch.Tensor:
    r"""Sellmeier index :math:`n = \sqrt{a + \sum_i b_i/(λ^2 - c_i^2)}`, λ in µm inside the formula.

    Args:
        wavelength: vacuum wavelength in nm (> 0), shape ``(*)``.
        a: constant term (≥ 1 in practice).
        b, c: sequences of equal length (the oscillator strengths in µm² and resonance
            wavelengths in µm); λ must stay away from every ``c_i``.

    Returns:
        real n, shape of ``wavelength``, its dtype.

    Example (Debenham's ZnS at 589.3 nm):
        >>> import torch
        >>> w = torch.tensor(589.3, dtype=torch.float64)
        >>> round(float(sellmeier_index(w, 8.393, (0.14383, 4430.99), (0.2421, 36.71))), 4)
        2.3669
    """
    if len(b) != len(c):
        raise ValueError(f"b and c must have the same length; got {len(b)} and {len(c)}")
    dtype, device = _checks.resolve_dtype_device(wavelength)
    lam = _checks.as_real(wavelength, "wavelength", dtype, device)
    _checks.check_wavelength(lam)
    l2 = (lam / 1000.0) ** 2
    n2 = torch.as_tensor(float(a), dtype=dtype, device=device) + torch.zeros_like(l2)
    for bi, ci in zip(b, c):
        n2 = n2 + float(bi) / (l2 - float(ci) ** 2)
    return n2.sqrt()


def zns_index(wavelength) -> torch.Tensor:
    """Index of cubic ZnS after Debenham (1984) (see the module docstring); λ in nm.

    Example:
        >>> import torch
        >>> [round(v, 3) for v in zns_index(torch.tensor([400.0, 589.3, 720.0], dtype=torch.float64)).tolist()]
        [2.554, 2.367, 2.327]
    """
    return sellmeier_index(wavelength, _ZNS_A, _ZNS_B, _ZNS_C)


def fit_index_model(wavelength, n, model: str) -> torch.Tensor:
    """Least-squares parameters of ``model`` for tabulated ``n`` at ``wavelength`` (nm).

    ``model``: ``"constant"``, ``"cauchy"`` or ``"cauchy3"``, no default (as in
    :func:`index_model`, which evaluates the parameters returned). The Cauchy models are linear in
    their parameters, so this is one ``lstsq``.

    Example:
        >>> import torch
        >>> w = torch.linspace(400.0, 720.0, 81, dtype=torch.float64)
        >>> p = fit_index_model(w, zns_index(w), "cauchy3")
        >>> bool((index_model(w, p, "cauchy3") - zns_index(w)).abs().max() < 2e-3)
        True
    """
    _check_model(model)
    dtype, device = _checks.resolve_dtype_device(wavelength, n)
    lam = _checks.as_real(wavelength, "wavelength", dtype, device).reshape(-1)
    nn_ = _checks.as_real(n, "n", dtype, device).reshape(-1)
    _checks.check_wavelength(lam)
    inv2 = (1000.0 / lam) ** 2
    cols = [torch.ones_like(lam), inv2, inv2 * inv2][: INDEX_MODELS[model]]
    X = torch.stack(cols, dim=-1)
    if not bool(torch.isfinite(X).all() & torch.isfinite(nn_).all()):  # NaN in, NaN out (LAPACK would fail)
        return torch.full((X.shape[-1],), float("nan"), dtype=dtype, device=device)
    return torch.linalg.lstsq(X, nn_[:, None]).solution[:, 0]
