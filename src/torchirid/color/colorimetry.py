r"""Colour matching functions, illuminants and white points as cached tensors.

The numbers are **never retyped**: every table comes from colour-science's datasets
(``colour.MSDS_CMFS``, ``colour.SDS_ILLUMINANTS``; Mansencal et al., colour-science 0.4)
and is converted to a tensor once per ``(name, dtype, device)``. The registered tables are
shipped as a copy of colour-science's float64 arrays (``data/cie_tables.npz``, built by
``luts/build_cie_tables.py`` and tested equal to colour-science's), so the first colour
does not import colour-science (nor the matplotlib and scipy it imports); a table missing
from that file is read from colour-science itself, imported at that call.

Registries (short name → colour-science dataset):

============================  ================================================
observer                      colour-science key
============================  ================================================
``"CIE 1931 2"``              ``'CIE 1931 2 Degree Standard Observer'``
``"CIE 1964 10"``             ``'CIE 1964 10 Degree Standard Observer'``
``"Stiles & Burch 1959 10"``  ``'Stiles & Burch 1959 10 Degree RGB CMFs'``
                              (RGB CMFs; XYZ via colour's
                              ``RGB_10_degree_cmfs_to_XYZ_10_degree_cmfs``)
============================  ================================================

Illuminants: ``"D65"``, ``"D50"``, ``"A"``, ``"E"`` (``colour.SDS_ILLUMINANTS[name]``).

Data getters versus physics functions
-------------------------------------
The project convention "dtype and device follow the inputs" applies to functions that
take tensors. The getters here take **no** tensor, so they have nothing to follow; they
take ``dtype=`` and ``device=`` keyword arguments instead (default float64 on the CPU).
Physics and conversion functions (``spectrum_to_xyz``, ``xyz_to_lab``, ...) call them
with their inputs' dtype and device.

The returned tensors are fresh copies: modifying them in place never corrupts the cache.
"""

from __future__ import annotations


import numpy as np
import torch

from .. import _autograd
from .._checks import names
from .._cache import cached
from . import _tables

__all__ = [
    "OBSERVERS",
    "ILLUMINANTS",
    "cmfs",
    "illuminant_spd",
    "white_point_xyz",
    "white_point_xy",
]

#: Observer short names → colour-science ``MSDS_CMFS`` keys.
_OBSERVER_KEYS = {
    "CIE 1931 2": "CIE 1931 2 Degree Standard Observer",
    "CIE 1964 10": "CIE 1964 10 Degree Standard Observer",
    "Stiles & Burch 1959 10": "Stiles & Burch 1959 10 Degree RGB CMFs",
}
#: Observers whose native data are RGB colour matching functions.
_RGB_OBSERVERS = ("Stiles & Burch 1959 10",)
#: Illuminant short names → colour-science ``SDS_ILLUMINANTS`` keys.
_ILLUMINANT_KEYS = {"D65": "D65", "D50": "D50", "A": "A", "E": "E"}

OBSERVERS: tuple[str, ...] = tuple(_OBSERVER_KEYS)
ILLUMINANTS: tuple[str, ...] = tuple(_ILLUMINANT_KEYS)
_SPACES = ("XYZ", "RGB")


# ---------------------------------------------------------------------------------------
# validation (before any work)
# ---------------------------------------------------------------------------------------


def check_observer(observer, name: str = "observer") -> None:
    if not isinstance(observer, str) or observer not in _OBSERVER_KEYS:
        raise ValueError(f"{name} must be one of {names(OBSERVERS)}; got {observer!r}")


def check_illuminant(illuminant, name: str = "illuminant") -> None:
    if not isinstance(illuminant, str) or illuminant not in _ILLUMINANT_KEYS:
        raise ValueError(f"{name} must be one of {names(ILLUMINANTS)}; got {illuminant!r}")


def _check_space(observer: str, space) -> None:
    if not isinstance(space, str) or space not in _SPACES:
        raise ValueError(f"space must be one of {names(_SPACES)}; got {space!r}")
    if space == "RGB" and observer not in _RGB_OBSERVERS:
        raise ValueError(
            f"space='RGB' is only available for the RGB colour matching functions "
            f"{names(_RGB_OBSERVERS)}; got observer={observer!r}"
        )


def _check_dtype(dtype) -> None:
    if not isinstance(dtype, torch.dtype) or not dtype.is_floating_point:
        raise ValueError(f"dtype must be a real floating torch.dtype (torch.float64, torch.float32); got {dtype!r}")


def _device(device) -> torch.device:
    return torch.device("cpu") if device is None else torch.device(device)


# ---------------------------------------------------------------------------------------
# float64 numpy tables: shipped copies of colour-science's (loaded once)
# ---------------------------------------------------------------------------------------


@cached(maxsize=None)
def _cmfs_numpy(observer: str, space: str) -> tuple[np.ndarray, np.ndarray]:
    # data/cie_tables.npz (colour-science's numbers, copied by luts/build_cie_tables.py and
    # tested equal to them); a table not shipped comes from colour-science itself
    table = _tables.shipped(_tables.cmfs_member(observer, space))
    if table is None:
        wl, values, _ = _tables.colour_cmfs(_OBSERVER_KEYS[observer],
                                            rgb_to_xyz=observer in _RGB_OBSERVERS and space == "XYZ")
        table = wl, values
    return table


@cached(maxsize=None)
def _illuminant_numpy(name: str) -> tuple[np.ndarray, np.ndarray]:
    table = _tables.shipped(_tables.illuminant_member(name))
    if table is None:
        wl, values, _ = _tables.colour_illuminant(_ILLUMINANT_KEYS[name])
        table = wl, values
    return table


@cached(maxsize=None)
def weighted_cmfs_numpy(observer: str, illuminant: str) -> tuple[np.ndarray, np.ndarray]:
    """``(wavelength, S(λ) x̄(λ), S(λ) ȳ(λ), S(λ) z̄(λ))`` on the observer's grid (NumPy,
    float64): the CMFs weighted by the illuminant, shared by every spectral integrator.

    The illuminant is interpolated **linearly** onto the observer's wavelengths and held
    constant beyond its tabulated range (colour-science's ``LinearInterpolator`` and
    ``Constant`` extrapolator for these datasets, and the CIE 15:2004 recommendation for
    the daylight illuminants). On a 1 nm grid this is bit-for-bit what
    ``colour.sd_to_XYZ`` integrates.
    """
    wl, xyz = _cmfs_numpy(observer, "XYZ")
    wl_s, s = _illuminant_numpy(illuminant)
    s_on_grid = np.interp(wl, wl_s, s)  # np.interp holds the end values outside
    return wl, xyz * s_on_grid[:, None]


# ---------------------------------------------------------------------------------------
# cached tensors per (name, dtype, device)
# ---------------------------------------------------------------------------------------


def _tensors(wl, v, dtype, device):
    """Numpy tables as (wavelength, values) tensors, converted from float64 (never cast up)."""
    return tuple(torch.as_tensor(a, dtype=torch.float64).to(dtype=dtype, device=device) for a in (wl, v))


@cached(maxsize=None)
@_autograd.normal_tensors
def _cmfs_tensor(observer: str, space: str, dtype: torch.dtype, device: torch.device):
    return _tensors(*_cmfs_numpy(observer, space), dtype, device)


@cached(maxsize=None)
@_autograd.normal_tensors
def _illuminant_tensor(name: str, dtype: torch.dtype, device: torch.device):
    return _tensors(*_illuminant_numpy(name), dtype, device)


@cached(maxsize=None)
@_autograd.normal_tensors
def _product_tensor(observer: str, illuminant: str, dtype: torch.dtype, device: torch.device):
    return _tensors(*weighted_cmfs_numpy(observer, illuminant), dtype, device)


@cached(maxsize=None)
def _white_numpy(illuminant: str, observer: str) -> np.ndarray:
    """XYZ of the perfect reflector, trapezoid rule on the observer's own grid, Y = 1."""
    wl, p = weighted_cmfs_numpy(observer, illuminant)
    dw = np.diff(wl)
    w = np.zeros_like(wl)
    w[:-1] += dw / 2
    w[1:] += dw / 2
    xyz = w @ p
    return xyz / xyz[1]


@cached(maxsize=None)
@_autograd.normal_tensors
def _white_tensor(illuminant: str, observer: str, dtype: torch.dtype, device: torch.device) -> torch.Tensor:
    return torch.as_tensor(_white_numpy(illuminant, observer), dtype=torch.float64).to(dtype=dtype, device=device)


# ---------------------------------------------------------------------------------------
# public getters
# ---------------------------------------------------------------------------------------


def cmfs(
    observer: str = "CIE 1931 2",
    *,
    space: str = "XYZ",
    dtype: torch.dtype = torch.float64,
    device=None,
) -> tuple[torch.Tensor, torch.Tensor]:
    r"""Colour matching functions of a standard observer, from colour-science's datasets.

    Args:
        observer: one of ``"CIE 1931 2"`` (360–830 nm, 1 nm), ``"CIE 1964 10"``
            (360–830 nm, 1 nm), ``"Stiles & Burch 1959 10"`` (390–830 nm, 5 nm).
        space: ``"XYZ"`` (:math:`\bar x, \bar y, \bar z`) or ``"RGB"``
            (:math:`\bar r, \bar g, \bar b`, only for ``"Stiles & Burch 1959 10"``).
            The XYZ functions of Stiles & Burch are colour-science's
            ``colour.colorimetry.RGB_10_degree_cmfs_to_XYZ_10_degree_cmfs`` (the CIE 1964
            3×3 matrix applied to the RGB data); they are *close to* but not equal to
            ``"CIE 1964 10"`` (which CIE also smoothed and extended; max abs. difference
            ≈ 0.066 at a peak :math:`\bar z` ≈ 2).
        dtype: real floating dtype of the result (keyword; these getters take no input
            tensor whose dtype they could follow — see the module docstring).
        device: device of the result (default CPU).

    Returns:
        ``(wavelength_nm, values)`` with shapes ``(K,)`` and ``(K, 3)``; fresh tensors
        (cached per ``(observer, space, dtype, device)`` and copied out).

    Raises:
        ValueError: unknown ``observer`` / ``space`` (the message lists the valid names),
            ``space="RGB"`` for an XYZ observer, or a non-floating ``dtype``.

    Example:
        >>> wl, xyz_bar = cmfs("CIE 1931 2")
        >>> wl.shape, xyz_bar.shape
        (torch.Size([471]), torch.Size([471, 3]))
        >>> round(xyz_bar[wl == 555, 1].item(), 4)  # ȳ(555 nm)
        1.0
    """
    check_observer(observer)
    _check_space(observer, space)
    _check_dtype(dtype)
    wl, v = _cmfs_tensor(observer, space, dtype, _device(device))
    return wl.clone(), v.clone()


def illuminant_spd(
    name: str = "D65",
    *,
    dtype: torch.dtype = torch.float64,
    device=None,
) -> tuple[torch.Tensor, torch.Tensor]:
    r"""Relative spectral power distribution of a CIE illuminant, from colour-science.

    ``"D65"``, ``"D50"``, ``"A"`` are tabulated 300–780 nm at 5 nm (normalised to 100 at
    560 nm); ``"E"`` (equal energy) is flat 100 on 360–830 nm at 5 nm. Only relative
    values matter: :func:`spectrum_to_xyz` divides by :math:`\int S \bar y`. Where these
    tables end, :func:`spectrum_to_xyz` holds the end value constant, as colour-science
    does (this touches only 780–830 nm, where the CMFs are below 5e-5).

    Args:
        name: one of ``"D65"``, ``"D50"``, ``"A"``, ``"E"``.
        dtype: real floating dtype of the result (keyword: no input tensor to follow).
        device: device of the result (default CPU).

    Returns:
        ``(wavelength_nm, values)`` of shapes ``(K,)`` and ``(K,)`` (fresh tensors).

    Raises:
        ValueError: unknown ``name`` (listing the valid ones) or a non-floating ``dtype``.

    Example:
        >>> wl, s = illuminant_spd("D65")
        >>> s[wl == 560].item()
        100.0
    """
    check_illuminant(name, "name")
    _check_dtype(dtype)
    wl, v = _illuminant_tensor(name, dtype, _device(device))
    return wl.clone(), v.clone()


def white_point_xyz(
    illuminant: str = "D65",
    observer: str = "CIE 1931 2",
    *,
    dtype: torch.dtype = torch.float64,
    device=None,
) -> torch.Tensor:
    r"""Tristimulus values of the perfect reflector (:math:`R \equiv 1`), ``Y = 1``.

    .. math:: X_n = \frac{\int S \bar x \, d\lambda}{\int S \bar y \, d\lambda}, \quad
              Y_n = 1, \quad
              Z_n = \frac{\int S \bar z \, d\lambda}{\int S \bar y \, d\lambda}

    with the trapezoid rule on the observer's own grid — the normalisation of
    :func:`spectrum_to_xyz` (whose output for ``R ≡ 1`` on that grid is exactly this).
    It is the reference white of :func:`xyz_to_lab`.

    Args:
        illuminant: one of ``"D65"``, ``"D50"``, ``"A"``, ``"E"``.
        observer: one of :data:`OBSERVERS`.
        dtype, device: of the result (keywords; see the module docstring).

    Returns:
        ``(3,)`` tensor ``(X_n, 1, Z_n)``.

    Example:
        >>> [round(v, 5) for v in white_point_xyz("D65").tolist()]
        [0.95047, 1.0, 1.08883]
    """
    check_illuminant(illuminant)
    check_observer(observer)
    _check_dtype(dtype)
    return _white_tensor(illuminant, observer, dtype, _device(device)).clone()


def white_point_xy(
    illuminant: str = "D65",
    observer: str = "CIE 1931 2",
    *,
    dtype: torch.dtype = torch.float64,
    device=None,
) -> torch.Tensor:
    r"""CIE xy chromaticity of :func:`white_point_xyz`: :math:`x = X/(X+Y+Z)`, :math:`y = Y/(X+Y+Z)`.

    Computed from the spectral data (not the rounded tabulated values, e.g. D65 /
    CIE 1931 2° gives (0.31271, 0.32902) where CIE tabulates (0.3127, 0.3290)).

    Returns:
        ``(2,)`` tensor.

    Example:
        >>> [round(v, 4) for v in white_point_xy("D65", "CIE 1931 2").tolist()]
        [0.3127, 0.329]
    """
    check_illuminant(illuminant)
    check_observer(observer)
    _check_dtype(dtype)
    xyz = _white_numpy(illuminant, observer)
    xy = xyz[:2] / xyz.sum()
    return torch.as_tensor(xy, dtype=torch.float64).to(dtype=dtype, device=_device(device))
