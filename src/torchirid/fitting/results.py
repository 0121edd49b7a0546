"""The results of scatterogram matching: :class:`ScatterogramFit` and its near-degenerate
alternatives, :class:`ScatterogramAlternative` (the fit refitted at a harmonic of its period)."""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction


from ..layered.structure import LayeredBragg

from .targets import bragg_structure

__all__ = ["ScatterogramAlternative", "ScatterogramFit"]


# ----------------------------------------------------------------------------------------
# the fit
# ----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ScatterogramAlternative:
    """One near-degenerate alternative of a :class:`ScatterogramFit`: the fit refitted at a
    harmonic ``k·Λ`` of its period (listed in :attr:`ScatterogramFit.alternatives`).

    Attributes:
        label: the harmonic, e.g. ``"2Λ"``, ``"Λ/2"``, ``"3Λ/2"``.
        factor: ``k`` (the alternative's period over the fit's, before the refit).
        period: the refitted Λ (nm); ``k·Λ`` when not refitted.
        refitted: False when ``k·Λ`` lies outside ``period_range`` (then every field below is None).
        note: ``"refitted"`` or why not (``"outside period_range (a, b) nm"``).
        delta, n1, n2, cells, alpha, exposure: the refitted layer, as in :class:`ScatterogramFit`.
        loss: its loss (same units as :attr:`ScatterogramFit.loss`).
        delta_e2000: mean CIEDE2000 between its render and the target over the disc
            (compare with :attr:`ScatterogramFit.delta_e2000`).
        delta_e2000_lit: the same over the target's lit pixels (L* > 5).
        delta_e2000_vs_fit: mean CIEDE2000 between its render and the best fit's render over the
            target's lit pixels (the whole mask if none is lit): how far apart the two
            explanations look.
        near_degenerate: ``delta_e2000_vs_fit < ambiguity_de2000`` (see :func:`match_scatterogram`).

    Example (the 2Λ refit of a quick fit to an 8-pixel render of a 160 nm layer; a short fit, for speed):
        >>> from torchirid.fitting import match_scatterogram, render_targets
        >>> from torchirid.presets import jewel_beetle
        >>> t = render_targets(jewel_beetle("green"), [(20.0, 0.0)], resolution=8)  # Λ = 160 nm, N = 8
        >>> fit = match_scatterogram(t, incident_deg=[(20.0, 0.0)], n1=1.59, cells=(8,), period_range=None,
        ...                          init={"period": 164.0, "delta": 0.51, "dn": 0.08, "alpha": 0.05},
        ...                          short_iter=2, max_iter=3, harmonics=(2.0,))
        >>> alt = fit.alternatives[0]
        >>> alt.label, alt.refitted, round(alt.period / fit.period, 1), alt.loss > fit.loss
        ('2Λ', True, 2.0, True)
    """

    label: str
    factor: float
    period: float
    refitted: bool
    note: str
    delta: float | None = None
    n1: float | None = None
    n2: float | None = None
    cells: int | None = None
    alpha: float | None = None
    exposure: float | None = None
    loss: float | None = None
    delta_e2000: float | None = None
    delta_e2000_lit: float | None = None
    delta_e2000_vs_fit: float | None = None
    near_degenerate: bool = False

    def numbers(self) -> dict:
        """JSON-ready fields (None where not refitted)."""
        return {f: getattr(self, f) for f in self.__dataclass_fields__}


@dataclass(frozen=True)
class ScatterogramFit:
    """The result of :func:`match_scatterogram`.

    Attributes:
        period, delta, n1, n2, alpha: the recovered layer (nm, fraction, indices, roughness).
        cells: the recovered number of cells N.
        exposure: the scale ``s`` that maps the model onto the target *as given*
            (``target ≈ s · model``).
        loss: the final loss (mean ΔE*ab², or mean ΔE00 with ``loss="de2000"``).
        delta_e2000: mean CIEDE2000 over the disc between the fitted and the target images.
        delta_e2000_lit: the same over the lit pixels (target L* > 5 after normalisation).
        iterations: L-BFGS iterations in all stages; evaluations: renders (with and without gradients).
        seconds: wall time of the fit.
        alternatives: the harmonics ``k·Λ`` of the period refitted (one
            :class:`ScatterogramAlternative` per factor of ``harmonics``, in that order; those
            outside ``period_range`` listed as not refitted).
        ambiguous: True when an alternative is near-degenerate (its render within
            ``ambiguity_de2000`` mean CIEDE2000 of the fit's): the target does not decide
            between them (see "What a visible-only scatterogram identifies" in the module docstring).
        stages: a JSON-ready log of the stages: ``ranges``; ``grid`` (the Λ grid and its minima,
            ``[Λ, loss]``); ``starts`` (``[Λ, loss]`` per refined start, best first); ``cells``
            (``{N: loss}`` of the N enumeration; ``cells_after_swap_<i>`` after a harmonic
            replaced the fit); ``polish`` (``{"cells", "loss"}`` per polish, in order);
            ``harmonics`` (the swaps and the alternatives).

    Example (a quick fit to an 8-pixel render of a 160 nm layer, from 164 nm, N known, no harmonics):
        >>> from torchirid.fitting import match_scatterogram, render_targets
        >>> from torchirid.presets import jewel_beetle
        >>> t = render_targets(jewel_beetle("green"), [(20.0, 0.0)], resolution=8)  # Λ = 160 nm, N = 8
        >>> fit = match_scatterogram(2.5 * t, incident_deg=[(20.0, 0.0)], n1=1.59, cells=(8,), period_range=None,
        ...                          init={"period": 164.0, "delta": 0.51, "dn": 0.08, "alpha": 0.05},
        ...                          short_iter=3, max_iter=5, harmonics=())
        >>> abs(fit.period - 160.0) < 3, fit.cells, fit.alternatives  # Λ in nm
        (True, 8, ())
        >>> round(fit.structure().layers[0].d1 + fit.structure().layers[0].d2, 6) == round(fit.period, 6)
        True
    """

    period: float
    delta: float
    n1: float
    n2: float
    cells: int
    alpha: float
    exposure: float
    loss: float
    delta_e2000: float
    delta_e2000_lit: float
    iterations: int
    evaluations: int
    seconds: float
    alternatives: tuple = field(default=(), repr=False)
    ambiguous: bool = False
    stages: dict = field(default_factory=dict, repr=False)

    def structure(self, *, n_incident: float = 1.0, base_albedo: float = 0.0) -> LayeredBragg:
        """The recovered layer as a structure (float parameters)."""
        return bragg_structure(self.n1, self.n2, self.period, self.delta, self.cells, self.alpha,
                               n_incident=n_incident, base_albedo=base_albedo)

    def numbers(self) -> dict:
        """JSON-ready parameters and figures, the alternatives included (no stage log)."""
        keys = ("period", "delta", "n1", "n2", "cells", "alpha", "exposure", "loss", "delta_e2000",
                "delta_e2000_lit", "iterations", "evaluations", "seconds", "ambiguous")
        out = {k: getattr(self, k) for k in keys}
        out["alternatives"] = [a.numbers() for a in self.alternatives]
        return out


def _harmonic_label(k: float) -> str:
    """``2`` → ``"2Λ"``, ``0.5`` → ``"Λ/2"``, ``1.5`` → ``"3Λ/2"``, ``0.37`` → ``"0.37Λ"``."""
    f = Fraction(k).limit_denominator(12)
    if abs(float(f) - k) > 1e-9 * k:
        return f"{k:g}Λ"
    return ("Λ" if f.numerator == 1 else f"{f.numerator}Λ") + ("" if f.denominator == 1 else f"/{f.denominator}")


