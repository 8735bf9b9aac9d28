"""First-order regression filters, trapezoid integrals, and the pairing of samples with the torque hold.

Filters ([DirectDrivePaper] section 4): the low-pass f(s) = lambda / (s + lambda) and the "filtered
derivative" lambda s / (s + lambda), lambda in rad/s (the paper writes "50 Hz"; the study treats
lambda as a parameter in rad/s, default 50). They are discretised with ``control.c2d``:

- ``"paper"``: the paper's forms (1 - e^{-h lambda}) z^-1 / (1 - e^{-h lambda} z^-1) and
  (1 - z^-1) lambda / (1 - e^{-h lambda} z^-1). Both are exactly the zero-order-hold
  equivalents (c2d method "zoh"), which the tests check against the closed forms. They are
  exact for held (staircase) inputs such as the torque, not for the continuous regressor signals:
  on those the low-pass lags by h/2, and the derivative filter's low-frequency gain is
  lambda h / (1 - e^{-lambda h}) instead of 1 (1.064 for lambda h = 0.125), so derivatives come
  out ~6 % large and the inertia estimates ~6 % low.
- ``"tustin"`` (default): both by the bilinear transform, lambda h / 2 (1 + z^-1) / D(z) and
  lambda (1 - z^-1) / D(z) with D = (1 + lambda h / 2) - (1 - lambda h / 2) z^-1: the two
  branches share the same time base, second-order accurate. Use it with midpoint pairing.

Pairing (docs/models.md, "Align the samples with the zero-order hold"): the torque u[k]
acts on [kh, (k+1)h). :func:`zoh_midpoint` pairs it with the midpoint of that interval
(q = (q[k] + q[k+1]) / 2, qd = (q[k+1] - q[k]) / h, t = (k + 1/2) h), which makes u[k]^T qd h the
exact work of the interval. :func:`paper_pairing` keeps the paper's choice: u[k] with q[k] and the
backward difference (q[k] - q[k-1]) / h, half a sample late on one side, half early on the other.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import control
import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.signal import lfilter

from boundid._validation import as_float_array
from boundid.errors import InputError
from boundid.experiments.preprocessing import backward_difference

#: discretisation name -> python-control c2d method
DISCRETISATIONS = {"tustin": "tustin", "paper": "zoh"}


def _z_inverse_coefficients(sysd) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) in powers of z^-1 (for ``lfilter``) from a discrete SISO transfer function in z."""
    num = np.atleast_1d(np.asarray(sysd.num[0][0], float))
    den = np.atleast_1d(np.asarray(sysd.den[0][0], float))
    num = np.concatenate([np.zeros(len(den) - len(num)), num])   # z-polynomials -> z^-1 polynomials
    return num / den[0], den / den[0]


@dataclass(frozen=True)
class FirstOrderFilters:
    """lambda/(s + lambda) and lambda s/(s + lambda) discretised at period h.

    lam : rad/s (> 0); h : s (> 0); discretisation : "tustin" | "paper" (see module docstring).
    ``lowpass(x)`` and ``derivative(x)`` filter along axis 0 (time) from a zero initial state.
    """

    lam: float = 50.0
    h: float = 2.5e-3
    discretisation: str = "tustin"

    def __post_init__(self):
        if not (np.isfinite(self.lam) and self.lam > 0):
            raise InputError(f"filter bandwidth lam must be finite and > 0 rad/s, got {self.lam}.")
        if not (np.isfinite(self.h) and self.h > 0):
            raise InputError(f"sample period h must be finite and > 0 s, got {self.h}.")
        if self.discretisation not in DISCRETISATIONS:
            raise InputError(f"discretisation must be one of {sorted(DISCRETISATIONS)}, got {self.discretisation!r}.")

    def _c2d(self, sys) -> tuple[np.ndarray, np.ndarray]:
        return _z_inverse_coefficients(control.c2d(sys, self.h, method=DISCRETISATIONS[self.discretisation]))

    @cached_property
    def lowpass_coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """(b, a) in z^-1 of lambda/(s + lambda)."""
        return self._c2d(control.tf([self.lam], [1.0, self.lam]))

    @cached_property
    def derivative_coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """(b, a) in z^-1 of lambda s/(s + lambda) (units: 1/s times the input)."""
        return self._c2d(control.tf([self.lam, 0.0], [1.0, self.lam]))

    def lowpass(self, x) -> np.ndarray:
        b, a = self.lowpass_coefficients
        return lfilter(b, a, as_float_array(x, "x"), axis=0)

    def derivative(self, x) -> np.ndarray:
        b, a = self.derivative_coefficients
        return lfilter(b, a, as_float_array(x, "x"), axis=0)


def cumulative_integral(x, t) -> np.ndarray:
    """int_{t_0}^{t_k} x dt by the trapezoid rule along axis 0, starting at 0 (the paper's rule)."""
    return cumulative_trapezoid(as_float_array(x, "x"), as_float_array(t, "t"), axis=0, initial=0.0)


@dataclass
class AlignedSamples:
    """Samples paired with the held torque: t (M,) s, q (M, n) rad, qd (M, n) rad/s, tau (M, n) N m."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    pairing: str


def _pairing_input(q, tau, h):
    q, tau = as_float_array(q, "q"), as_float_array(tau, "tau")
    if q.ndim != 2 or q.shape != tau.shape or q.shape[0] < 3:
        raise InputError(f"q and tau must both be (N, n) with N >= 3 samples, got {q.shape} and {tau.shape}.")
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(tau))):
        raise InputError("q and tau must be finite; remove or interpolate bad samples first.")
    if not (np.isfinite(h) and h > 0):
        raise InputError(f"sample period h must be finite and > 0 s, got {h}.")
    return q, tau


def zoh_midpoint(q, tau, h: float, t0: float = 0.0) -> AlignedSamples:
    """Pair u[k] (held on [t_k, t_k + h)) with that interval's midpoint state; N samples give N - 1.

    q : (N, n) positions sampled at t_k = t0 + k h; tau : (N, n) torques held from t_k.
    Returns t = t0 + (k + 1/2) h, q = (q[k] + q[k+1]) / 2, qd = (q[k+1] - q[k]) / h, tau = u[k],
    k = 0 .. N - 2.
    """
    q, tau = _pairing_input(q, tau, h)
    t = t0 + (np.arange(q.shape[0] - 1) + 0.5) * h
    return AlignedSamples(t, 0.5 * (q[1:] + q[:-1]), (q[1:] - q[:-1]) / h, tau[:-1].copy(), "zoh_midpoint")


def paper_pairing(q, tau, h: float, t0: float = 0.0) -> AlignedSamples:
    """The paper's pairing: u[k] with q[k] and the backward difference (q[k] - q[k-1]) / h (N samples)."""
    q, tau = _pairing_input(q, tau, h)
    t = t0 + np.arange(q.shape[0]) * h
    return AlignedSamples(t, q.copy(), backward_difference(q, h), tau.copy(), "paper")


PAIRINGS = {"zoh_midpoint": zoh_midpoint, "paper": paper_pairing}


def align(q, tau, h: float, pairing: str = "zoh_midpoint", t0: float = 0.0) -> AlignedSamples:
    """Dispatch to :func:`zoh_midpoint` (default) or :func:`paper_pairing` by name."""
    if pairing not in PAIRINGS:
        raise InputError(f"pairing must be one of {sorted(PAIRINGS)}, got {pairing!r}.")
    return PAIRINGS[pairing](q, tau, h, t0)
