"""Regression builders: stacked observation matrices (W, y) from sampled robot data.

Four models, generic over any :class:`boundid.models.RobotModel`:

- inverse dynamic   tau = Y(q, qd, qdd) theta                         (needs qdd)
- filtered dynamic  f*tau = (lambda s/(s+lambda)) (Ya - Ya(0)) theta + f*(Yb theta), f = lambda/(s+lambda)
- supplied energy   int tau^T qd = [H(t) - H(0)] + int qd^T f(qd)
- filtered power    f*(tau^T qd) = (lambda s/(s+lambda)) (H - H(0)) + f*(qd^T f(qd))

Rows are stacked sample-major: for a model with n joints, rows k*n .. k*n + n - 1 are the joints
of sample k. Energy and power models give one row per sample (``joint = -1``).

The filtered models start the filters from rest at the first sample, so the signal entering the
derivative filter must start at zero too: that is why it is Ya - Ya(0) and H - H(0). Filtering
H itself injects lambda H(0) e^{-lambda t}, a transient that exists nowhere in the robot
(docs/models.md, pitfalls). Pass samples paired with the torque hold
(:func:`boundid.experiments.filters.zoh_midpoint`, with the default Tustin filters) to avoid the
half-sample skew of the paper's pairing.

Why the supplied energy model fails with noise ([DirectDrivePaper] section 6.2). Its output is the running
integral of the power, y_k = h sum_{j<=k} tau_j^T qd_j. Torque noise e_j enters as
h sum_j e_j^T qd_j: a random walk whose standard deviation grows like sigma h sqrt(sum_j |qd_j|^2)
(sigma = 2 N m, |qd|_rms = 3.9 rad/s on the paper's experiment: 0.42 J after 1 s, 1.2 J after
10 s), while the regressor rows are themselves running integrals, strongly correlated from row to
row. Least squares assumes independent errors of constant variance; here the error is cumulative
and grows with time like the friction-work columns, so it is absorbed mostly by the friction
parameters and, through the correlations, by the gravity and inertia terms. Filtering instead of
integrating (filtered power, filtered dynamic) keeps the noise stationary: nothing accumulates.

Measured on the simulated arm (torques (31)-(32), 10 s, h = 2.5 ms, RLS with theta0 = 0,
P0 = 1000 I, lam = 50 rad/s, midpoint pairing + Tustin; tests/test_regressions.py):
noise-free, all three models converge (largest error 0.1 % on th1..th5; friction 2.2 % filtered
dynamic, 0.3 % supplied energy, 0.06 % filtered power). With Gaussian torque noise sigma = 2 N m
and a 16-bit encoder (mean |error| over 20 noise draws), filtered dynamic: 0.8 % on th1..th5, 3.5 %
on friction; filtered power: 1.5 % and 8.6 %; supplied energy: 5.9 % (th5 16 %) and 37 %
(viscous b1, b2 ~45 %). The paper's pairing and filter forms bias even noise-free data: inertia
terms ~5-7 % low in both filtered models, friction off by 15-45 %.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from boundid._validation import as_float_array, as_regression
from boundid.errors import InputError
from boundid.experiments.filters import FirstOrderFilters, cumulative_integral


@dataclass(frozen=True)
class DroppedRows:
    """Rows a regression builder left out, and why (e.g. the low-speed rows of the inverse dynamic model).

    rows : int                  rows dropped
    of : int                    rows before dropping them
    per_joint : tuple of int    (n,) rows dropped per joint
    window_s : float            s, half-width of the window dropped around each offending sample
    reason : str                why, in words
    """

    rows: int
    of: int
    per_joint: tuple[int, ...]
    window_s: float
    reason: str

    @property
    def share(self) -> float:
        """rows / of, the fraction of the rows dropped (0 when there were none)."""
        return self.rows / self.of if self.of else 0.0


@dataclass
class Regression:
    """A linear regression y = W theta + e built from robot data.

    W : (N, p)          observation matrix
    y : (N,)            measured side (torques in N m, energies in J, powers in W)
    joint : (N,) int    joint of each row (0-based), -1 for scalar (energy/power) rows
    sample : (N,) int   index of the sample the row comes from
    t : (N,)            time of the row [s]
    model : str         "inverse_dynamic" | "filtered_dynamic" | "supplied_energy" | "filtered_power"
    param_names : tuple names of the p parameters (from the robot model)
    unit : str          unit of y ("N m", "J", "W")
    info : dict         how it was built (filter lambda [rad/s], discretisation, decimation ...)
    dropped : DroppedRows or None   the rows the builder left out and why (None: none left out)
    """

    W: np.ndarray
    y: np.ndarray
    joint: np.ndarray
    sample: np.ndarray
    t: np.ndarray
    model: str
    param_names: tuple[str, ...]
    unit: str = "N m"
    info: dict = field(default_factory=dict)
    dropped: DroppedRows | None = None

    def __post_init__(self):
        self.W, self.y = as_regression(self.W, self.y)
        n = self.W.shape[0]
        for name in ("joint", "sample", "t"):
            a = np.asarray(getattr(self, name))
            if a.shape != (n,):
                raise InputError(f"Regression.{name} must have shape ({n},), got {a.shape}.")
            setattr(self, name, a)
        if len(self.param_names) != self.W.shape[1]:
            raise InputError(
                f"{len(self.param_names)} parameter names for {self.W.shape[1]} columns of W."
            )

    @property
    def n_rows(self) -> int:
        return int(self.W.shape[0])

    def rows_of_joint(self, j: int) -> Regression:
        """The sub-regression of joint ``j`` (rows in time order)."""
        return self.subset(self.joint == j)

    def subset(self, mask) -> Regression:
        """The rows selected by a boolean mask or an index array."""
        return Regression(self.W[mask], self.y[mask], self.joint[mask], self.sample[mask],
                          self.t[mask], self.model, self.param_names, self.unit, dict(self.info), self.dropped)


def stack_joint_rows(Y: np.ndarray, tau: np.ndarray, t: np.ndarray, model: str,
                     param_names: tuple[str, ...], unit: str = "N m", info: dict | None = None
                     ) -> Regression:
    """Stack per-sample regressors Y (N, n, p) and targets tau (N, n) sample-major into rows."""
    Y = np.asarray(Y, float)
    tau = np.asarray(tau, float)
    if Y.ndim != 3 or tau.shape != Y.shape[:2]:
        raise InputError(f"Y must be (N, n, p) and tau (N, n); got {Y.shape} and {tau.shape}.")
    N, n, p = Y.shape
    return Regression(
        W=Y.reshape(N * n, p),
        y=tau.reshape(N * n),
        joint=np.tile(np.arange(n), N),
        sample=np.repeat(np.arange(N), n),
        t=np.repeat(np.asarray(t, float), n),
        model=model,
        param_names=tuple(param_names),
        unit=unit,
        info=dict(info or {}),
    )


def inverse_dynamic(model, q, qd, qdd, tau, t) -> Regression:
    """tau = Y(q, qd, qdd) theta, one row per joint per sample (the IDIM baseline for WLS/OBE)."""
    Y = model.regressor(q, qd, qdd)
    return stack_joint_rows(Y, tau, t, "inverse_dynamic", model.param_names)


def _signals(model, q, qd, tau, t, uniform: bool):
    """Check (N, n) q, qd, tau and (N,) increasing t; return them and the period h (uniform t only)."""
    n = model.n_joints
    arrs = []
    for name, a in (("q", q), ("qd", qd), ("tau", tau)):
        a = as_float_array(a, name)
        if a.ndim == 1 and n == 1:
            a = a[:, None]
        if a.ndim != 2 or a.shape[1] != n or not np.all(np.isfinite(a)):
            raise InputError(f"{name} must be a finite (N, {n}) array for the {model.name} model, got {a.shape}.")
        arrs.append(a)
    t = as_float_array(t, "t")
    N = arrs[0].shape[0]
    if any(a.shape[0] != N for a in arrs) or t.shape != (N,) or N < 2:
        raise InputError(f"q, qd, tau need the same N >= 2 samples and t shape (N,); got "
                         f"{[a.shape for a in arrs]} and {t.shape}.")
    dt = np.diff(t)
    if not (np.all(np.isfinite(t)) and np.all(dt > 0)):
        raise InputError("t must be finite and strictly increasing.")
    h = float(np.mean(dt))
    if uniform and np.max(np.abs(dt - h)) > 1e-6 * h:
        raise InputError(f"the filtered models need uniform sampling; t steps range over [{dt.min():g}, "
                         f"{dt.max():g}] s. Resample the data first.")
    return (*arrs, t, h)


def filtered_dynamic(model, q, qd, tau, t, lam: float = 50.0, discretisation: str = "tustin") -> Regression:
    """f*tau = (lambda s/(s+lambda)) (Ya - Ya(0)) theta + f*(Yb theta), f = lambda/(s+lambda); no qdd.

    q, qd, tau : (N, n) samples at the uniformly spaced times t (N,) [s] (pair them with the torque
    hold first, see :func:`boundid.experiments.filters.zoh_midpoint`); lam [rad/s]; discretisation
    "tustin" | "paper". One row per joint per sample, in N m.
    """
    q, qd, tau, t, h = _signals(model, q, qd, tau, t, uniform=True)
    flt = FirstOrderFilters(lam, h, discretisation)
    Ya = model.momentum_regressor(q, qd)
    W = flt.derivative(Ya - Ya[0]) + flt.lowpass(model.remainder_regressor(q, qd))
    return stack_joint_rows(W, flt.lowpass(tau), t, "filtered_dynamic", model.param_names,
                            info={"lam_rad_s": lam, "discretisation": discretisation, "h": h})


def supplied_energy(model, q, qd, tau, t) -> Regression:
    """int_0^t tau^T qd = phi_H(t) theta - phi_H(0) theta + int_0^t phi_f theta (trapezoid rule, in J).

    One row per sample after the first (the first row would be the identity 0 = 0); ``joint = -1``.
    """
    q, qd, tau, t, h = _signals(model, q, qd, tau, t, uniform=False)
    phi_H = model.energy_regressor(q, qd)
    W = phi_H - phi_H[0] + cumulative_integral(model.friction_power_regressor(qd), t)
    y = cumulative_integral(np.sum(tau * qd, axis=1), t)
    N = q.shape[0]
    return Regression(W[1:], y[1:], np.full(N - 1, -1), np.arange(1, N), t[1:], "supplied_energy",
                      tuple(model.param_names), unit="J", info={"integration": "trapezoid", "h": h})


def filtered_power(model, q, qd, tau, t, lam: float = 50.0, discretisation: str = "tustin") -> Regression:
    """f*(tau^T qd) = (lambda s/(s+lambda)) (phi_H - phi_H(0)) theta + f*(phi_f theta) (in W).

    Same inputs as :func:`filtered_dynamic`; one row per sample, ``joint = -1``.
    """
    q, qd, tau, t, h = _signals(model, q, qd, tau, t, uniform=True)
    flt = FirstOrderFilters(lam, h, discretisation)
    phi_H = model.energy_regressor(q, qd)
    W = flt.derivative(phi_H - phi_H[0]) + flt.lowpass(model.friction_power_regressor(qd))
    y = flt.lowpass(np.sum(tau * qd, axis=1))
    N = q.shape[0]
    return Regression(W, y, np.full(N, -1), np.arange(N), t, "filtered_power", tuple(model.param_names),
                      unit="W", info={"lam_rad_s": lam, "discretisation": discretisation, "h": h})
