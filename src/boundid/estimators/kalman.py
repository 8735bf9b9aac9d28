"""The parameters as the state of a linear Kalman filter (filterpy), plus a compiled path.

State x = theta (p,), transition F = I, process noise Q (random walk; Q = 0 for constant
parameters), one scalar measurement per regression row: y_k = w_k^T theta + v_k, v_k ~ N(0, r_k),
so H_k = w_k^T (1, p). One step (predict, then update):

    P = P + Q
    S = w^T P w + r,   K = P w / S
    x = x + K (y - w^T x)
    P = (I - K w^T) P (I - K w^T)^T + K r K^T     (filterpy's Joseph form)
      = P - (P w)(P w)^T / S                       (the same for the optimal gain; compiled path)

With Q = 0 and r = 1 this is RLS without forgetting (:class:`boundid.estimators.rls.RLS`), term for
term. The noise variance is known here (r), so P is the covariance itself: the confidence
ellipsoid is {x : (x - theta)^T P^-1 (x - theta) <= chi2_{level, p}} and the intervals
theta_j -+ z_{(1+level)/2} sqrt(P_jj) (normal quantile; ``statistics.dof`` = inf).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from filterpy.kalman import KalmanFilter
from scipy import stats

from boundid._validation import as_float_array
from boundid.errors import InputError, NumericalError
from boundid.estimators.estimate import Estimate
from boundid.estimators.method import Method, Problem, Style, option
from boundid.estimators.protocol import SHAPE_LIMITS, check_p
from boundid.estimators.rls import LinearFilter
from boundid.sets.ellipsoid import log_unit_ball_volume

ENGINES = ("numba", "filterpy")


def _check_r(R, n_rows: int | None, name: str = "R") -> np.ndarray:
    """Measurement variance: a scalar (returned as (1,)) or, when n_rows is given, an (n_rows,) array."""
    r = as_float_array(R, name)
    if r.ndim == 0:
        r = r.reshape(1)
    elif n_rows is None or r.shape != (n_rows,):
        per_row = f" or have shape ({n_rows},), one per row" if n_rows is not None else ""
        raise InputError(f"{name} must be a scalar variance{per_row}; got shape {r.shape}.")
    if not np.all(np.isfinite(r) & (r > 0)):
        raise InputError(f"{name} (measurement noise variance, units of y squared) must be finite and > 0.")
    return r


def _check_q(Q, p: int) -> np.ndarray:
    """Random-walk covariance: scalar q >= 0 (q I) or a symmetric positive semidefinite (p, p) matrix."""
    Q = as_float_array(Q, "Q")
    if Q.ndim == 0:
        Q = Q * np.eye(p)
    if Q.shape != (p, p) or not np.all(np.isfinite(Q)):
        raise InputError(f"Q must be a finite scalar or a {p} x {p} matrix, got shape {Q.shape}.")
    scale = max(float(np.max(np.abs(Q))), np.finfo(float).tiny)
    if np.max(np.abs(Q - Q.T)) > 1e-12 * scale or np.linalg.eigvalsh(Q)[0] < -1e-12 * scale:
        raise InputError("Q must be symmetric positive semidefinite (a covariance); a scalar Q means Q * I >= 0.")
    return 0.5 * (Q + Q.T)


class KalmanEstimator(LinearFilter):
    """Linear Kalman filter on the parameters, built on ``filterpy.kalman.KalmanFilter`` (the
    estimator protocol of :mod:`boundid.estimators.protocol`).

    Parameters
    ----------
    p : int                 number of parameters
    prior : Ellipsoid or Box   the prior: mean = its centre, covariance = its shape; or, without it,
    center0 : (p,) or scalar   prior mean (default 0)
    shape0 : (p, p), (p,) or scalar   prior covariance (scalar s: s I; default 1000 I as in the
                            direct-drive paper)
    R : float               measurement noise variance of each row (units of y squared); ``fit``,
                            ``partial_fit`` and ``update`` accept a per-row override
    Q : float or (p, p)     random-walk covariance added to P before each row (scalar: Q * I); 0 = constant
    record_every, names, level   as in :class:`boundid.estimators.rls.RLS`

    The filterpy object is ``self.kf``; ``theta`` and ``P`` read and write its ``x`` and ``P``.
    ``update`` runs filterpy; ``partial_fit(..., engine="numba")`` (default) runs the compiled loop
    shared with RLS, ``engine="filterpy"`` the filterpy reference loop.
    """

    def __init__(self, p, *, prior=None, center0=None, shape0=None, R=1.0, Q=0.0, record_every=1, names=None,
                 level=0.95):
        self.kf = KalmanFilter(dim_x=check_p(p), dim_z=1)
        self.R = float(_check_r(R, None)[0])
        Q = _check_q(Q, check_p(p))
        self.Q = Q
        self.kf.F = np.eye(int(p))
        self.kf.Q = Q.copy()
        self.kf.R = np.array([[self.R]])
        super().__init__(p, prior, center0, shape0, record_every, names, level)

    @property
    def theta(self) -> np.ndarray:
        return self.kf.x[:, 0]

    @theta.setter
    def theta(self, value):
        self.kf.x = np.array(value, dtype=float).reshape(-1, 1)

    @property
    def P(self) -> np.ndarray:
        return self.kf.P

    @P.setter
    def P(self, value):
        self.kf.P = np.array(value, dtype=float)

    def _filterpy_step(self, w: np.ndarray, y: float, r: float) -> float:
        """One filterpy predict + update; returns the innovation and keeps J, n, n_eff. Raises
        NumericalError, with x and P put back, if the step does not stay finite and definite."""
        x0, P0 = self.kf.x.copy(), self.kf.P.copy()
        try:
            self.kf.predict()
            self.kf.update(np.array([[y]]), R=r, H=w.reshape(1, -1))
            innov, S = float(self.kf.y[0, 0]), float(self.kf.S[0, 0])
        except np.linalg.LinAlgError:  # filterpy inverts S = 0
            innov, S = np.nan, 0.0
        if not (S > 0.0 and np.isfinite(S) and np.isfinite(innov) and self._valid(self.kf.x, self.kf.P)):
            self.kf.x, self.kf.P = x0, P0
            raise self._numerical_error(self.n, S, "the step broke down", w)
        self.J += innov * innov / S
        self.n_eff += 1.0
        self.n += 1
        return innov

    def update(self, w, y, R=None) -> Estimate:
        """One row through filterpy (R: this row's variance, default ``self.R``); returns :meth:`estimate`."""
        t0 = time.perf_counter()
        w, y = self._check_row(w, y)
        r = self.R if R is None else float(_check_r(R, None)[0])
        self._filterpy_step(w, y, r)  # leaves the state unchanged if it raises
        self.logdet = float(np.linalg.slogdet(self.P)[1])
        self._record_one()
        self.time_s += time.perf_counter() - t0
        return self.estimate()

    def partial_fit(self, W, y, R=None, engine: str = "numba") -> Estimate:
        """Process the rows of W (N, p) against y (N,), continuing from the current state; R: scalar
        or (N,) variances (default ``self.R``).

        engine="numba" runs the compiled loop; engine="filterpy" calls filterpy row by row.
        """
        t0 = time.perf_counter()
        if engine not in ENGINES:
            raise InputError(f"engine must be one of {ENGINES}, got {engine!r}.")
        W, y = self._check_batch(W, y)
        r = np.array([self.R]) if R is None else _check_r(R, W.shape[0])
        if engine == "numba":
            Q = self.Q if np.any(self.Q != 0) else np.zeros((0, 0))
            self._run(W, y, r, 1.0, Q)
        else:
            rows = np.broadcast_to(r, (W.shape[0],))
            last = W.shape[0] - 1
            snap = self._snapshot()
            try:
                for k in range(W.shape[0]):
                    self._filterpy_step(W[k], y[k], rows[k])
                    if self.record_every > 0 and (self.n % self.record_every == 0 or k == last):
                        self.logdet = float(np.linalg.slogdet(self.P)[1])
                        self._record_one(last=k == last)
            except NumericalError:
                self._restore(snap)  # the whole call is undone, not just the failing row
                raise
            self.logdet = float(np.linalg.slogdet(self.P)[1])
        self.time_s += time.perf_counter() - t0
        return self.estimate()

    def _log_volumes(self, logdet, J, neff):
        chi2 = stats.chi2.ppf(self.level, self.p)
        return log_unit_ball_volume(self.p) + 0.5 * self.p * np.log(chi2) + 0.5 * logdet

    def estimate(self) -> Estimate:
        """The current state as a statistical Estimate: the noise variance is R (given, so
        ``statistics.sigma`` is NaN and the dof infinite); info["nis"] = mean normalised
        innovation^2 (~1 when R is right)."""
        q_on = bool(np.any(self.Q != 0))
        return self._estimate(
            "Kalman (random walk)" if q_on else "Kalman",
            1.0,  # cov = P symmetrised: filterpy's Joseph form is symmetric only to rounding
            stats.chi2.ppf(self.level, self.p),
            stats.norm.ppf(0.5 * (1.0 + self.level)),
            np.inf,
            float("nan"),
            self.R,
            {"nis": self.J / self.n if self.n else np.nan, "R": self.R, "Q": self.Q},
        )


# ------------------------------------------------------------------------------ registry entry


@dataclass(frozen=True)
class KalmanOptions:
    """What a study file may set for ``method = "kalman"``."""

    center0: float = option(0.0, "x(0), every parameter (parameter units)", renamed_from=("theta0",))
    shape0: float = option(1000.0, "P(0) = shape0 I (parameter units squared)", lo=SHAPE_LIMITS[0],
                           hi=SHAPE_LIMITS[1], renamed_from=("P0",))
    R: float = option(1.0, "measurement noise variance of one row (units of y squared)", lo=0.0, strict_lo=True)
    Q: float = option(0.0, "random-walk variance per sample, Q = Q I (0: constant parameters)", lo=0.0)


def _build(problem: Problem, o: KalmanOptions) -> Estimate:
    return KalmanEstimator(problem.p, center0=o.center0, shape0=o.shape0, R=o.R, Q=o.Q,
                           record_every=problem.record_every, names=problem.names).fit(problem.W, problem.y)


METHOD = Method(name="kalman", summary="Kalman filter with the parameters as state, confidence ellipsoid",
                options=KalmanOptions, build=_build, set_family="ellipsoid", kind="statistical",
                needs_bound=False, style=Style("#882255", "v", "-"))
