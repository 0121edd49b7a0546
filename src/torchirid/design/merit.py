r"""The merit of many candidate stacks in one tensor call, and its gradient.

``Evaluator`` compiles a checked :class:`~torchirid.design.Problem`: the indices
of every material (every candidate of a layer with a choice) at every target's wavelengths are
read once; for a stack whose materials are fixed, so are the interface amplitudes and the
normal wavenumbers of every film at every (λ, θ, polarization), so that a candidate costs only
its film phases :math:`φ_j = 2π q_j d_j / λ` and Hirayama's recursion (the kernel of
:func:`torchirid.multilayer`, ``optics._transfer_fast``) — for a whole population ``[B, L]`` at
once, with autograd through it when a gradient is wanted.

The merit (module ``torchirid.design.problem``) is

.. math:: M = \sum_t s_t M_t + 100\,\frac{\max(0, \sum_j d_j − D_{max})}{D_{max}},

the last term only with ``max_total_thickness`` (:math:`D_{max}`): any excess costs more than
any target can gain. Under :class:`~torchirid.design.Robust` errors every candidate is
evaluated at ``samples`` perturbed stacks (the same draws for every candidate) and its merit is
the mean, or the mean of the worst ``alpha`` fraction (CVaR).
"""

from __future__ import annotations

import copy
import math

import numpy as np
import torch

from .._checks import complex_dtype
from ..optics.transfer import stack_fluxes, stack_pieces, stack_response
from .problem import ColourTarget, Problem, SpectralTarget

#: the penalty per relative excess over ``max_total_thickness``
THICKNESS_PENALTY = 100.0

_PLANCK_C = 6.62607015e-34 * 299792458.0  # h c, J m


def index_table(material, wavelength: torch.Tensor) -> torch.Tensor:
    """Complex index of a checked material at ``wavelength`` (nm), same shape."""
    cdt = complex_dtype(wavelength.dtype)
    if isinstance(material, tuple) and material and material[0] == "table":
        lam = wavelength.detach().cpu().numpy()
        n = np.interp(lam, material[1], material[2]) + 1j * np.interp(lam, material[1], material[3])
        return torch.as_tensor(n, dtype=cdt, device=wavelength.device)
    if isinstance(material, (int, float, complex)):
        return torch.full(wavelength.shape, complex(material), dtype=cdt, device=wavelength.device)
    from ..materials import refractive_index

    return refractive_index(material, wavelength).to(cdt)


def named_weight(name: str, wavelength: np.ndarray) -> np.ndarray:
    """A named spectral weighting on ``wavelength`` (nm): the ASTM G173-03 global tilt AM1.5
    spectrum (pvlib's copy) as irradiance (W m⁻² nm⁻¹) or as photon flux (E λ / (h c),
    photons s⁻¹ m⁻² nm⁻¹), linearly interpolated."""
    try:
        import pvlib
    except ImportError:  # pragma: no cover - pvlib is in the design and dev extras
        raise ValueError(f"the weighting {name!r} needs pvlib: pip install 'torchirid[design]'") from None
    spectra = pvlib.spectrum.get_reference_spectra()
    e = np.interp(wavelength, spectra.index.to_numpy(dtype=float), spectra["global"].to_numpy(dtype=float))
    if name == "AM1.5G irradiance":
        return e
    return e * (wavelength * 1e-9) / _PLANCK_C


class _Condition:
    """One target's optics: wavelengths ``(W,)``, cosines ``(A,)``, polarization, and the indices
    of every stack position ``[K_j, W]`` (K_j candidates); with fixed materials the interface
    amplitudes and film wavenumbers are computed once."""

    def __init__(self, tables: list[torch.Tensor], lam: torch.Tensor, c: torch.Tensor, polarization: str):
        self.tables = tables
        self.lam, self.c, self.polarization = lam, c, polarization
        self.u = (1 / lam)[:, None]
        self.fixed = all(t.shape[0] == 1 for t in tables)
        if self.fixed:
            self.n = torch.stack([t[0] for t in tables], dim=-1)[None]  # [1, W, L+2]
            self.pieces = stack_pieces(c, self.n[0, :, None, :], polarization)  # [P, W, A, L+1], [W, A, L]

    def indices(self, B: int, choice):
        """The indices ``[B or 1, W, L+2]`` of every stack position."""
        if self.fixed:
            return self.n
        return torch.stack([t[ch] if t.shape[0] > 1 else t[0].expand(B, -1)
                            for t, ch in zip(self.tables, choice)], dim=-1)

    def absorptance(self, d: torch.Tensor, choice, layer: int) -> torch.Tensor:
        """The power absorbed in film ``layer`` ``[B, W, A]`` (``stack_fluxes``)."""
        n = self.indices(d.shape[0], choice)[:, :, None, :]  # [B, W, 1, L+2]
        F = stack_fluxes(self.c, n, d[:, None, None, :], self.u, self.polarization)
        return (F[..., layer] - F[..., layer + 1]).clamp(0, 1)

    def response(self, d: torch.Tensor, choice: list[torch.Tensor] | None):
        """(R, T) ``[B, W, A]`` of thicknesses ``d [B, L]`` (materials ``choice``: one ``[B]`` index
        per stack position, or None when they are fixed)."""
        B = d.shape[0]
        if self.fixed:
            r, t2, kq = self.pieces
        else:
            r, t2, kq = stack_pieces(self.c, self.indices(B, choice)[:, :, None, :], self.polarization)
        batch = (B, self.lam.shape[0], self.c.shape[0])
        return stack_response(r, t2, kq, d[:, None, None, :], self.u, batch)


class Evaluator:
    """The merit of batches of candidate stacks for one checked problem.

    A candidate is its free thicknesses ``x [B, F]`` (nm, the free layers in stack order) and,
    when layers choose among materials, ``choice [B, C]`` (the index of each such layer's
    candidate). ``merit`` returns ``[B]``; ``evaluations`` counts candidates.
    """

    def __init__(self, problem: Problem, *, dtype: torch.dtype = torch.float64, device=None):
        self.problem = problem
        self.dtype, self.device = dtype, torch.device(device or "cpu")
        layers = problem.layers
        self.L = len(layers)
        self.free = [j for j, layer in enumerate(layers) if layer.free]
        self.lower = np.array([layers[j].thickness[0] for j in self.free], dtype=float)
        self.upper = np.array([layers[j].thickness[1] for j in self.free], dtype=float)
        self.base = torch.tensor([0.0 if layer.free else layer.thickness for layer in layers],
                                 dtype=dtype, device=self.device)
        self.choosing = [j for j, layer in enumerate(layers) if len(layer.candidates) > 1]
        self.counts = [len(layers[j].candidates) for j in self.choosing]
        positions = [(problem.n_incident,)] + [layer.candidates for layer in layers] + [(problem.n_substrate,)]
        self.conditions = []
        self.targets = problem.targets
        for t in problem.targets:
            lam = torch.tensor(t.wavelength, dtype=dtype, device=self.device)
            c = torch.tensor(t.cos_theta, dtype=dtype, device=self.device)
            tables = [torch.stack([index_table(m, lam) for m in cands]) for cands in positions]
            self.conditions.append(_Condition(tables, lam, c, t.polarization))
        self._weights = [self._target_weights(t) for t in problem.targets]
        self.robust = problem.robust
        if self.robust is not None:
            g = torch.Generator(device="cpu").manual_seed(self.robust.seed)
            self.errors = torch.randn(self.robust.samples, self.L, generator=g, dtype=dtype).to(self.device)
            self.errors *= torch.tensor(self.robust.sigma, dtype=dtype, device=self.device)
        self._count = [0]
        self.use_robust = True

    @property
    def evaluations(self) -> int:
        """Candidates evaluated (shared with ``nominal``'s view)."""
        return self._count[0]

    @evaluations.setter
    def evaluations(self, value: int) -> None:
        self._count[0] = value

    def nominal(self) -> Evaluator:
        """A view that evaluates without the robust errors (counting into the same total)."""
        view = copy.copy(self)
        view.use_robust = False
        return view

    def _target_weights(self, t):
        dt, dev = self.dtype, self.device
        if isinstance(t, SpectralTarget):
            lam = np.asarray(t.wavelength)
            w = named_weight(t.weight, lam) if isinstance(t.weight, str) else np.asarray(t.weight, dtype=float)
            w = torch.tensor(w / w.sum(), dtype=dt, device=dev)
            return w, torch.tensor(t.value, dtype=dt, device=dev)
        from ..color.convert import xyz_weights_kernel

        lam = torch.tensor(t.wavelength, dtype=dt, device=dev)
        return xyz_weights_kernel(lam, t.observer, t.illuminant), torch.tensor(t.lab, dtype=dt, device=dev)

    # -- the stack of a candidate ------------------------------------------------------------
    def thicknesses(self, x: torch.Tensor) -> torch.Tensor:
        """All thicknesses ``[B, L]`` from the free ones ``x [B, F]``."""
        d = self.base.expand(x.shape[0], -1).clone()
        if self.free:
            d[:, self.free] = x
        return d

    def positions(self, choice: torch.Tensor | None, B: int) -> list[torch.Tensor] | None:
        """One candidate index ``[B]`` per stack position (incident, layers, exit)."""
        if not self.choosing:
            return None
        zero = torch.zeros(B, dtype=torch.long, device=self.device)
        out = [zero] * (self.L + 2)
        for i, j in enumerate(self.choosing):
            out[j + 1] = choice[:, i].long()
        return out

    # -- responses and merits ---------------------------------------------------------------
    def responses(self, d: torch.Tensor, choice=None) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """(R, T) ``[B, W, A]`` per target for full thicknesses ``d [B, L]``."""
        pos = self.positions(choice, d.shape[0])
        return [cond.response(d, pos) for cond in self.conditions]

    def target_merits(self, d: torch.Tensor, choice=None, responses=None) -> torch.Tensor:
        """Each target's merit ``[B, targets]`` (before ``importance``) for thicknesses ``d [B, L]``
        (``responses``: those of :meth:`responses` for ``d`` when the caller has them)."""
        pos = self.positions(choice, d.shape[0])
        out = []
        for i, (t, (w, v), cond) in enumerate(zip(self.targets, self._weights, self.conditions)):
            if isinstance(t, SpectralTarget) and t.layer is not None:
                X = cond.absorptance(d, pos, t.layer)  # R and T not needed
            else:
                R, T = responses[i] if responses is not None else cond.response(d, pos)
                if isinstance(t, ColourTarget):
                    out.append(self.colour_differences(t, R, w, v).pow(t.p).mean(-1).pow(1 / t.p))
                    continue
                X = R if t.quantity == "R" else T if t.quantity == "T" else 1 - R - T
            dev = (X - v[:, None]).abs()  # [B, W, A]
            dev = dev ** t.p if t.p != 1 else dev
            m = (dev * w[:, None]).sum(1).mean(-1)
            out.append(m if t.p == 1 else m ** (1 / t.p))
        return torch.stack(out, dim=-1)

    @staticmethod
    def colour_differences(t: ColourTarget, R: torch.Tensor, w: torch.Tensor, lab: torch.Tensor) -> torch.Tensor:
        """ΔE2000 ``[B, A]`` between the reflected colours of ``R [B, W, A]`` and the target."""
        from ..color.convert import xyz_to_lab
        from ..color.difference import delta_e_2000

        xyz = torch.einsum("bwa,wk->bak", R, w)
        return delta_e_2000(xyz_to_lab(xyz, illuminant=t.illuminant, observer=t.observer), lab)

    def colours(self, d: torch.Tensor, choice=None) -> list[torch.Tensor | None]:
        """CIELAB ``[B, A, 3]`` per colour target (None for spectral targets)."""
        from ..color.convert import xyz_to_lab

        out = []
        for t, (R, _), (w, _) in zip(self.targets, self.responses(d, choice), self._weights):
            out.append(xyz_to_lab(torch.einsum("bwa,wk->bak", R, w), illuminant=t.illuminant,
                                  observer=t.observer) if isinstance(t, ColourTarget) else None)
        return out

    def plain_merit(self, d: torch.Tensor, choice=None, responses=None) -> torch.Tensor:
        """The merit ``[B]`` of thicknesses ``d [B, L]``, without thickness errors."""
        s = torch.tensor([t.importance for t in self.targets], dtype=self.dtype, device=self.device)
        m = (self.target_merits(d, choice, responses) * s).sum(-1)
        dmax = self.problem.max_total_thickness
        if dmax is not None:
            m = m + THICKNESS_PENALTY * torch.relu(d.sum(-1) - dmax) / dmax
        return m

    def perturbed(self, d: torch.Tensor, errors: torch.Tensor, relative: bool) -> torch.Tensor:
        """Thicknesses ``[B, S, L]`` under errors ``[S, L]`` (nm, or fractions when ``relative``),
        clipped at 0."""
        e = errors[None] * d[:, None] if relative else errors[None]
        return (d[:, None] + e).clamp_min(0)

    def merit(self, x: torch.Tensor, choice=None, *, robust: bool = True) -> torch.Tensor:
        """The merit ``[B]`` of free thicknesses ``x [B, F]`` (and choices ``[B, C]``); under the
        problem's :class:`Robust` errors (unless ``robust=False``) the mean or CVaR over draws."""
        B = x.shape[0]
        self.evaluations += B
        d = self.thicknesses(x)
        if self.robust is None or not robust or not self.use_robust:
            return self.plain_merit(d, choice)
        S = self.errors.shape[0]
        dd = self.perturbed(d, self.errors, self.robust.relative).reshape(B * S, self.L)
        ch = None if choice is None else choice.repeat_interleave(S, dim=0)
        m = self.plain_merit(dd, ch).reshape(B, S)
        if self.robust.objective == "mean":
            return m.mean(-1)
        worst = max(1, math.ceil(self.robust.alpha * S))
        return m.topk(worst, dim=-1).values.mean(-1)
