"""The search space of scatterogram matching: the bounded parametrisation that L-BFGS runs on
(:class:`_Space`) and the problem shared by the stages of :func:`~torchirid.fitting.match_scatterogram`
(:class:`_Problem`: target, renderer, start values)."""

from __future__ import annotations

import math

import torch

from ..color import xyz_to_lab

from .targets import _lsq_scale, bragg_structure, render_targets, scatterogram_loss

__all__ = []


class _Space:
    """The unconstrained coordinates ``x = [u_Λ, u_δ, u_Δn, u_α, log s, (u_n1)]`` of L-BFGS and
    the bounded parameters they map to.

    A parameter with a range ``(lo, hi)`` is ``lo + (hi − lo)·σ(u/c)`` (Λ, δ) or
    ``exp(log lo + (log hi − log lo)·σ(u/c))`` (Δn, α, n1): it cannot leave its range, whatever
    step the line search tries. Without a range Λ is ``10u`` (nm) and Δn, α, n1 are ``exp(u)``;
    δ always has one (by default (0, 1), the plain logistic). Encoding a value puts it at least
    ``_EDGE`` of the range (in σ) inside, where the gradient has not vanished.
    """

    _KIND = {"period": "lin", "delta": "lin", "dn": "log", "alpha": "log", "n1": "log"}

    def __init__(self, ranges: dict, fit_n1: bool):
        self.ranges = dict(ranges)
        self.fit_n1 = fit_n1

    def with_period(self, period_range):
        out = _Space(self.ranges, self.fit_n1)
        out.ranges["period"] = period_range
        return out

    def _bounds(self, name):
        """(kind, lo, hi, c) of a bounded parameter in its linear or logarithmic coordinate, c the
        scale of u (``σ(u / c)``) that keeps the slope at the middle of the range that of the
        unbounded form: 10 nm per unit for Λ, 1 for log Δn, log α and log n1; δ keeps the plain
        logistic (c = 1)."""
        kind, r = self._KIND[name], self.ranges[name]
        lo, hi = (r[0], r[1]) if kind == "lin" else (math.log(r[0]), math.log(r[1]))
        c = (hi - lo) / 40.0 if name == "period" else 1.0 if name == "delta" else (hi - lo) / 4.0
        return kind, lo, hi, c

    def forward(self, name, u):
        if self.ranges.get(name) is None:
            return 10.0 * u if self._KIND[name] == "lin" else torch.exp(u)
        kind, lo, hi, c = self._bounds(name)
        v = lo + (hi - lo) * torch.sigmoid(u / c)
        return v if kind == "lin" else torch.exp(v)

    def inverse(self, name, value: float) -> float:
        if self.ranges.get(name) is None:
            return value / 10.0 if self._KIND[name] == "lin" else math.log(value)
        kind, lo, hi, c = self._bounds(name)
        t = ((value if kind == "lin" else math.log(value)) - lo) / (hi - lo)
        t = min(max(t, _EDGE), 1.0 - _EDGE)
        return c * math.log(t / (1.0 - t))


#: how far inside its range (in σ) a bounded parameter is encoded
_EDGE = 0.005
#: a harmonic k·Λ is refitted with Λ in [k·Λ / _WINDOW, k·Λ · _WINDOW] (∩ period_range)
_WINDOW = 1.08
#: δ tried (no gradients) to start a harmonic's refit: the maxima of |sin(mπδ)| for orders m = 1, 2, 3
_HARMONIC_DELTAS = (1.0 / 6.0, 0.25, 0.5, 0.75, 5.0 / 6.0)
#: the most harmonic refits that may replace the fit (each then re-enumerates N and polishes)
_MAX_SWAPS = 2


class _Problem:
    """Target, renderer and the parametrisation shared by the stages."""

    def __init__(self, target, mask, incs, lam, projection, reflectance, n_incident, base_albedo, fit_n1, n1_fixed, loss):
        self.target, self.mask, self.incs, self.lam = target, mask, incs, lam
        self.projection, self.reflectance, self.n_incident, self.base_albedo = projection, reflectance, n_incident, base_albedo
        self.fit_n1, self.n1_fixed, self.loss_name = fit_n1, n1_fixed, loss
        self.resolution = target.shape[-2]
        self.full_mask = mask.expand(target.shape[:-1])
        self.evaluations = 0
        self.iterations = 0

    def params(self, x, space: _Space):
        """x → (Λ, δ, n1, n2, α, s) tensors (differentiable)."""
        period = space.forward("period", x[0])
        delta = space.forward("delta", x[1])
        dn = space.forward("dn", x[2])
        alpha = space.forward("alpha", x[3])
        n1 = space.forward("n1", x[5]) if self.fit_n1 else torch.as_tensor(self.n1_fixed, dtype=x.dtype)
        return period, delta, n1, n1 + dn, alpha, torch.exp(x[4])

    def values(self, x, space: _Space) -> dict:
        """x → the parameters as floats: period, delta, n1, dn, alpha, scale."""
        with torch.no_grad():
            period, delta, n1, n2, alpha, scale = self.params(x.detach(), space)
        return {"period": float(period), "delta": float(delta), "n1": float(n1), "dn": float(n2 - n1),
                "alpha": float(alpha), "scale": float(scale)}

    def encode(self, space: _Space, v: dict) -> torch.Tensor:
        u = [space.inverse("period", v["period"]), space.inverse("delta", v["delta"]), space.inverse("dn", v["dn"]),
             space.inverse("alpha", v["alpha"]), math.log(v["scale"])]
        if self.fit_n1:
            u.append(space.inverse("n1", v["n1"]))
        return torch.tensor(u, dtype=self.target.dtype)

    def render(self, period, delta, n1, n2, cells, alpha):
        self.evaluations += 1
        s = bragg_structure(n1, n2, period, delta, cells, alpha, n_incident=self.n_incident, base_albedo=self.base_albedo)
        return render_targets(s, self.incs, resolution=self.resolution, wavelength=self.lam,
                              projection=self.projection, reflectance=self.reflectance)

    def loss(self, model, scale=None):
        return scatterogram_loss(model, self.target, self.full_mask, scale=scale, loss=self.loss_name)

    def start(self, space: _Space, v: dict, cells: int):
        """Encode ``v`` (period, delta, n1, dn, alpha) with the closed-form exposure → (x, its loss)."""
        with torch.no_grad():
            model = self.render(v["period"], v["delta"], v["n1"], v["n1"] + v["dn"], cells, v["alpha"])
            s = float(_lsq_scale(model, self.target, self.full_mask))
            value = float(self.loss(model, s if s > 0 else 1.0))
        return self.encode(space, {**v, "scale": s if s > 0 else 1.0}), value

    def objective(self, x, cells, space):
        period, delta, n1, n2, alpha, scale = self.params(x, space)
        return self.loss(self.render(period, delta, n1, n2, cells, alpha), scale)

    def refine(self, x0, cells, space, iterations):
        """L-BFGS from ``x0`` for up to ``iterations`` iterations → (x, loss)."""
        x = x0.clone().requires_grad_(True)
        opt = torch.optim.LBFGS([x], lr=1.0, max_iter=iterations, history_size=20, line_search_fn="strong_wolfe",
                                tolerance_grad=1e-9, tolerance_change=1e-12)
        best = {"loss": math.inf, "x": x0.clone()}

        def closure():
            opt.zero_grad()
            value = self.objective(x, cells, space)
            if not torch.isfinite(value):  # guard: a step into an invalid region is rejected by the line search
                return value
            value.backward()
            if float(value.detach()) < best["loss"]:
                best["loss"], best["x"] = float(value.detach()), x.detach().clone()
            return value

        try:
            opt.step(closure)
        except ValueError:  # a line-search trial left the layer's valid range (e.g. δ rounding to 0 or 1)
            pass
        self.iterations += opt.state[opt._params[0]].get("n_iter", 0)
        if best["loss"] == math.inf:  # not one finite evaluation (0 iterations): the start's loss
            with torch.no_grad():
                best["loss"] = float(self.objective(x0, cells, space))
        return best["x"], best["loss"]

    def lab(self, x, cells, space):
        """Lab of the scaled render over the mask (no gradients)."""
        with torch.no_grad():
            period, delta, n1, n2, alpha, scale = self.params(x, space)
            model = self.render(period, delta, n1, n2, cells, alpha)
            return xyz_to_lab(scale * model[self.full_mask])


