r"""The optics of the plugins in Dr.Jit arithmetic: complex numbers over any real Dr.Jit type (or
Python floats in the scalar variants), the Airy recursion of a stack and Abelès' matrix of a
Bragg cell raised to the number of cells.

Everything here is written on *admittances*. With :math:`s^2 = n_0^2\sin^2\theta_0` (the
invariant of Snell's law, :math:`n_0` the real index of the incident medium) every medium
:math:`j` of complex index :math:`N_j = n_j + i\kappa_j` has

.. math::

    q_j = N_j\cos\theta_j = \sqrt{N_j^2 - s^2}\quad(\text{principal root: } \operatorname{Im} q_j \ge 0),
    \qquad Y_j = q_j\ (s),\quad Y_j = q_j / N_j^2\ (p),

the phase thickness of a layer of thickness :math:`d` is :math:`\delta_j = 2\pi d\,q_j/\lambda`, and
an interface :math:`i\,|\,j` has :math:`r_{ij} = (Y_i - Y_j)/(Y_i + Y_j)`,
:math:`t_{ij} = 2Y_i/(Y_i + Y_j)` (the tangential E field for s, H for p). Working on
:math:`q_j` instead of :math:`\cos\theta_j` needs no special case for total internal reflection
(an imaginary :math:`q`) or absorbing media.

The kernels trust their inputs: the plugins' constructors check them.
"""

from __future__ import annotations

import math

import drjit as dr

TWO_PI = 2.0 * math.pi


def _is_zero(x) -> bool:
    """A literal zero (a Python number): an imaginary part known to vanish when the kernel is traced."""
    return isinstance(x, (int, float)) and x == 0


def _mul(a, b):
    return 0.0 if _is_zero(a) or _is_zero(b) else a * b


def _add(a, b):
    if _is_zero(a):
        return b
    return a if _is_zero(b) else a + b


def _sub(a, b):
    if _is_zero(b):
        return a
    return -b if _is_zero(a) else a - b


def _div(a, b):
    return 0.0 if _is_zero(a) else a / b


class Complex:
    """A complex number over a real Dr.Jit array type (or Python floats): ``re + i·im``.

    Dr.Jit's own complex types exist per backend and precision; this small class works on any
    real type the variant hands out (``Float``, ``Float64``, Python ``float``), so the same
    kernel runs in scalar and JIT variants and keeps Dr.Jit's automatic differentiation. An
    imaginary part that is a literal Python zero stays one through the arithmetic: a lossless
    medium above the critical angle traces real Fresnel coefficients, not complex ones."""

    __slots__ = ("re", "im")

    def __init__(self, re, im=0.0):
        self.re = re
        self.im = im

    def __add__(self, o):
        if isinstance(o, Complex):
            return Complex(_add(self.re, o.re), _add(self.im, o.im))
        return Complex(_add(self.re, o), self.im)

    __radd__ = __add__

    def __sub__(self, o):
        if isinstance(o, Complex):
            return Complex(_sub(self.re, o.re), _sub(self.im, o.im))
        return Complex(_sub(self.re, o), self.im)

    def __rsub__(self, o):
        return Complex(_sub(o, self.re), _sub(0.0, self.im))

    def __neg__(self):
        return Complex(-self.re, _sub(0.0, self.im))

    def __mul__(self, o):
        if isinstance(o, Complex):
            return Complex(_sub(_mul(self.re, o.re), _mul(self.im, o.im)), _add(_mul(self.re, o.im), _mul(self.im, o.re)))
        return Complex(_mul(self.re, o), _mul(self.im, o))

    __rmul__ = __mul__

    def __truediv__(self, o):
        if isinstance(o, Complex):
            if _is_zero(o.im):
                inv = 1.0 / o.re
                return Complex(_mul(self.re, inv), _mul(self.im, inv))
            den = o.re * o.re + o.im * o.im
            return Complex(_div(_add(_mul(self.re, o.re), _mul(self.im, o.im)), den),
                           _div(_sub(_mul(self.im, o.re), _mul(self.re, o.im)), den))
        return Complex(_div(self.re, o), _div(self.im, o))

    def __rtruediv__(self, o):
        if _is_zero(self.im):
            return Complex(o / self.re, 0.0)
        den = self.re * self.re + self.im * self.im
        return Complex(o * self.re / den, -o * self.im / den)

    def abs2(self):
        """``|z|²``."""
        return _add(self.re * self.re, _mul(self.im, self.im))


def real_root(eps: Complex, s2) -> Complex:
    """:math:`q = \\sqrt{\\varepsilon - s^2}` of a lossless medium whose index is at least the
    incident one (``s² ≤ ε``: never evanescent), traced as a real number."""
    return Complex(dr.sqrt(dr.maximum(eps.re - s2, 0.0)), 0.0)


def csqrt(z: Complex) -> Complex:
    """Principal square root (``Re ≥ 0``; ``Im`` takes the sign of ``z.im``, + for ``z.im = 0``)."""
    if _is_zero(z.im):  # a real argument: real root, or +i·root of a negative one
        r = dr.sqrt(dr.abs(z.re))
        return Complex(dr.select(z.re >= 0, r, 0.0), dr.select(z.re >= 0, 0.0, r))
    r = dr.sqrt(z.re * z.re + z.im * z.im)
    re = dr.sqrt(dr.maximum((r + z.re) * 0.5, 0.0))
    im = dr.sqrt(dr.maximum((r - z.re) * 0.5, 0.0))
    return Complex(re, dr.select(z.im < 0, -im, im))


def cexp_i(z: Complex) -> Complex:
    """``exp(i·z)``."""
    s, c = dr.sincos(z.re)
    if _is_zero(z.im):
        return Complex(c, s)
    e = dr.exp(-z.im)
    return Complex(e * c, e * s)


def ccos_sin(z: Complex):
    """``(cos z, sin z)`` of a complex angle."""
    if _is_zero(z.im):
        s, c = dr.sincos(z.re)
        return Complex(c, 0.0), Complex(s, 0.0)
    ch, sh = dr.cosh(z.im), dr.sinh(z.im)
    c, s = dr.cos(z.re), dr.sin(z.re)
    return Complex(c * ch, -s * sh), Complex(s * ch, c * sh)


def square(n) -> Complex:
    """``N²`` of an index given as a :class:`Complex`."""
    return n * n


def admittances(eps: Complex, s2):
    """``(q, Y_s, Y_p)`` of a medium of permittivity ``eps = N²`` at Snell invariant ``s2``."""
    q = csqrt(eps - s2)
    return q, q, q / eps


def _narrowed(z: Complex, narrow) -> Complex:
    """``z`` with its array parts cast by ``narrow`` (literals kept)."""
    cast = (lambda x: x if isinstance(x, (int, float)) else narrow(x))
    return Complex(cast(z.re), cast(z.im))


def stack_amplitudes(lam, s2, eps, thicknesses, transmission: bool = False, real=None, narrow=None):
    """Reflection (and transmission) amplitudes of a stack by the Airy recursion, s and p in
    one pass (the roots :math:`q_j` and the phase factors are shared).

    Args:
        lam: vacuum wavelength in nm (real array).
        s2: Snell invariant :math:`n_0^2\\sin^2\\theta_0` (real array).
        eps: permittivities ``N²`` (:class:`Complex`) of every medium, incident first, exit
            last (length ``L + 2``).
        thicknesses: the ``L`` film thicknesses in nm (real arrays or floats).
        transmission: also return the transmission amplitudes.
        real: per medium, whether its root :math:`q` is known to be real (lossless, index ≥ the
            incident one): :func:`real_root`, real arithmetic downstream.
        narrow: a cast to a narrower real type (Dr.Jit ``Float32``) for the recursion: the roots
            and the phase thicknesses are computed in the inputs' precision (float64), the phase
            reduced modulo 2π there, and the rest — Fresnel coefficients, the recursion,
            |r|² — in the narrow type. ``None``: everything in the inputs' type.

    Returns ``{"s": (r, t, Y_0, Y_exit), "p": (...)}`` with ``t`` the amplitude of the field
    that is continuous at the interfaces (E for s, H for p), so that
    ``T = Re(Y_exit)/Y_0 · |t|²`` (``t`` is None without ``transmission``).
    """
    real = real or [False] * len(eps)
    q = [real_root(e, s2) if r else csqrt(e - s2) for e, r in zip(eps, real)]
    ys = q
    yp = [qj / e if not _is_zero(e.im) else qj * (1.0 / e.re) for qj, e in zip(q, eps)]
    last = len(eps) - 1
    phases = []
    for j in range(last - 1, 0, -1):
        delta = q[j] * (TWO_PI * thicknesses[j - 1] / lam)
        if narrow is not None:  # reduce modulo 2π in float64, then narrow
            delta = _narrowed(Complex(delta.re - TWO_PI * dr.round(delta.re * (1.0 / TWO_PI)), delta.im), narrow)
        e1 = cexp_i(delta)
        phases.append((j, e1, e1 * e1))
    if narrow is not None:
        ys = [_narrowed(y, narrow) for y in ys]
        yp = [_narrowed(y, narrow) for y in yp]
    out = {}
    for pol, y in (("s", ys), ("p", yp)):
        den = y[last - 1] + y[last]
        r = (y[last - 1] - y[last]) / den
        t = 2.0 * y[last - 1] / den if transmission else None
        for j, e1, e2 in phases:
            den = y[j - 1] + y[j]
            rij = (y[j - 1] - y[j]) / den
            re2 = r * e2
            inv = 1.0 / (1.0 + rij * re2)
            if transmission:
                t = (2.0 * y[j - 1] / den) * t * e1 * inv
            r = (rij + re2) * inv
        out[pol] = (r, t, y[0], y[last])
    return out


def stack_reflectance(lam, s2, eps, thicknesses, real=None, narrow=None):
    """Unpolarized reflectance ``R`` (mean of s and p) of a stack."""
    amp = stack_amplitudes(lam, s2, eps, thicknesses, real=real, narrow=narrow)
    return 0.5 * (amp["s"][0].abs2() + amp["p"][0].abs2())


def stack_reflectance_transmittance(lam, s2, eps, thicknesses, real=None, narrow=None):
    """Unpolarized ``(R, T)`` of a stack whose incident and exit media are lossless."""
    amp = stack_amplitudes(lam, s2, eps, thicknesses, transmission=True, real=real, narrow=narrow)
    out_r, out_t = 0.0, 0.0
    for r, t, y0, ye in amp.values():
        out_r = out_r + 0.5 * r.abs2()
        out_t = out_t + 0.5 * dr.maximum(ye.re, 0.0) / y0.re * t.abs2()
    return out_r, out_t


def _layer_matrix(q: Complex, y: Complex, thickness, lam):
    """Abelès' characteristic matrix of one layer: ``[[cos δ, -i sin δ / Y], [-i Y sin δ, cos δ]]``."""
    c, s = ccos_sin(q * (TWO_PI * thickness / lam))
    mi_s = Complex(s.im, -s.re)  # -i·sin δ
    return (c, mi_s / y, mi_s * y, c)


def _matmul(a, b):
    return (a[0] * b[0] + a[1] * b[2], a[0] * b[1] + a[1] * b[3],
            a[2] * b[0] + a[3] * b[2], a[2] * b[1] + a[3] * b[3])


def _matpow(m, n: int):
    """``m**n`` by squaring (``n ≥ 1`` is known when the kernel is traced: ⌈log₂ n⌉ squarings)."""
    out = None
    while n:
        if n & 1:
            out = m if out is None else _matmul(out, m)
        n >>= 1
        if n:
            m = _matmul(m, m)
    return out


def bragg_reflectance(lam, s2, eps_incident: Complex, eps1: Complex, eps2: Complex, eps_exit: Complex, d1, d2,
                      cells: int, real=(False, False, False, False)):
    r"""Unpolarized reflectance of ``incident | (n2, d2), (n1, d1) × cells | exit``: Abelès' cell
    matrix :math:`M = M_2 M_1` raised to ``cells`` by squaring, then
    :math:`r = (Y_0 B - C)/(Y_0 B + C)` with :math:`(B, C)^T = M^N (1, Y_e)^T`. In float64 the
    entries of :math:`M^N` stay finite for any practical mirror (they grow at most as
    :math:`e^{N\operatorname{Im}K\Lambda}` inside a stop band)."""
    q0, q1, q2, qe = (real_root(e, s2) if r else csqrt(e - s2)
                      for e, r in zip((eps_incident, eps1, eps2, eps_exit), real))
    total = 0.0
    for pol in ("s", "p"):
        if pol == "s":
            y0, y1, y2, ye = q0, q1, q2, qe
        else:
            y0, y1, y2, ye = q0 / eps_incident, q1 / eps1, q2 / eps2, qe / eps_exit
        cell = _matmul(_layer_matrix(q2, y2, d2, lam), _layer_matrix(q1, y1, d1, lam))
        m = _matpow(cell, cells)
        b = m[0] + m[1] * ye
        c = m[2] + m[3] * ye
        r = (y0 * b - c) / (y0 * b + c)
        total = total + 0.5 * r.abs2()
    return total
