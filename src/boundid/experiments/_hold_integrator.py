"""Compiled (numba) zero-order-hold simulation: scipy's DOP853 step by step, every hold interval in one call.

``solve_ivp`` spends ~0.7 ms of Python per hold interval (validation, solver objects, small-array
``np.dot``), which is 90 % of a 4000-interval direct-drive run. :func:`simulate_hold` runs the SAME
algorithm as ``solve_ivp(method="DOP853", first_step=h)`` on each interval [t_k, t_k + h) -- the
Butcher tableau and error estimators are scipy's own (``scipy.integrate.DOP853.A, B, C, E3, E5``), the
step-size control is that of ``scipy.integrate._ivp.rk.RungeKutta._step_impl`` (SAFETY 0.9, factors
in [0.2, 10], exponent -1/8, smallest step 10 ulp of t), the error norm that of
``DOP853._estimate_error_norm`` [HairerNorsettWanner1993] -- so the trajectory equals solve_ivp's up
to the rounding of the sums (tests/test_experiments.py compares them), at ~100x the speed.

The model supplies its acceleration as a compiled function of type :data:`boundid.models.base.ACCELERATION`,
``acc(y, u, theta, coulomb_width, out)``: y (2n,) = [q, qd], u (n,) N m, theta (p,), writes qdd (n,)
into ``out`` (the ``compiled_acceleration`` attribute of a model, e.g.
:class:`boundid.models.direct_drive.DirectDriveArm`). It is passed as a first-class function, so the
integrator is compiled once and cached on disk (``cache=True``) for every model.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from scipy.integrate import DOP853

from boundid.models.base import ACCELERATION

_N_STAGES = DOP853.n_stages  # 12
_A = np.ascontiguousarray(DOP853.A, dtype=np.float64)
_B = np.ascontiguousarray(DOP853.B, dtype=np.float64)
_C = np.ascontiguousarray(DOP853.C, dtype=np.float64)
_E3 = np.ascontiguousarray(DOP853.E3, dtype=np.float64)
_E5 = np.ascontiguousarray(DOP853.E5, dtype=np.float64)
_EXPONENT = -1.0 / (DOP853.error_estimator_order + 1)
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0  # scipy.integrate._ivp.rk
#: status of an interval: done; the step size fell below 10 ulp of t (solve_ivp's failure); the state
#: or its derivative became inf/NaN (the dynamics diverge; solve_ivp would shrink the step until it failed)
OK, TOO_SMALL_STEP, DIVERGED = 0, 1, 2


@njit(cache=True)
def _rhs(acc, y, u, theta, width, out):
    """out = [qd, qdd] for the state y = [q, qd] under the held torque u."""
    n = u.shape[0]
    for i in range(n):
        out[i] = y[n + i]
    acc(y, u, theta, width, out[n:])


@njit(cache=True)
def _interval(acc, y0, u, t0, t1, theta, width, rtol, atol, A, B, C, E3, E5, exponent, K):
    """One hold interval [t0, t1] from y0, as solve_ivp(DOP853, first_step=t1 - t0); returns
    (y(t1), number of right-hand-side evaluations, status). K: (13, 2n) stage storage."""
    m = y0.shape[0]
    y = y0.copy()
    f = np.empty(m)
    _rhs(acc, y, u, theta, width, f)
    nfev = 1
    t, h_abs = t0, t1 - t0
    y_new, f_new, ys = np.empty(m), np.empty(m), np.empty(m)
    if t == t1:
        return y, nfev, OK
    while True:
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            h_abs = min_step
        accepted, rejected = False, False
        while not accepted:
            if h_abs < min_step:
                return y, nfev, TOO_SMALL_STEP
            t_new = t + h_abs
            if t_new - t1 > 0:
                t_new = t1
            h = t_new - t
            h_abs = abs(h)
            # rk_step: K[s] = f(t + c_s h, y + h sum_j a_sj K[j])
            K[0, :] = f
            for s in range(1, _N_STAGES):
                for i in range(m):
                    acc_i = 0.0
                    for j in range(s):
                        acc_i += K[j, i] * A[s, j]
                    ys[i] = y[i] + acc_i * h
                _rhs(acc, ys, u, theta, width, K[s])
            for i in range(m):
                acc_i = 0.0
                for j in range(_N_STAGES):
                    acc_i += K[j, i] * B[j]
                y_new[i] = y[i] + h * acc_i
            _rhs(acc, y_new, u, theta, width, f_new)
            K[_N_STAGES, :] = f_new
            nfev += _N_STAGES
            if not (np.all(np.isfinite(y_new)) and np.all(np.isfinite(f_new))):
                return y, nfev, DIVERGED
            # DOP853._estimate_error_norm
            e5, e3 = 0.0, 0.0
            for i in range(m):
                scale = atol + max(abs(y[i]), abs(y_new[i])) * rtol
                s5, s3 = 0.0, 0.0
                for j in range(_N_STAGES + 1):
                    s5 += K[j, i] * E5[j]
                    s3 += K[j, i] * E3[j]
                e5 += (s5 / scale) ** 2
                e3 += (s3 / scale) ** 2
            e5, e3 = np.sqrt(e5) ** 2, np.sqrt(e3) ** 2
            if e5 == 0 and e3 == 0:
                error_norm = 0.0
            else:
                error_norm = abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * m)
            if error_norm < 1:
                factor = MAX_FACTOR if error_norm == 0 else min(MAX_FACTOR, SAFETY * error_norm ** exponent)
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                accepted = True
            else:
                h_abs *= max(MIN_FACTOR, SAFETY * error_norm ** exponent)
                rejected = True
        t = t_new
        y[:] = y_new
        f[:] = f_new
        if t - t1 >= 0:
            return y, nfev, OK


_V, _M = types.float64[::1], types.float64[:, ::1]


_I = types.int64


@njit(types.Tuple((_M, _I, _I, _I))(types.FunctionType(ACCELERATION), _V, _M, _V, _V, types.float64, types.float64,
                                    types.float64, _M, _V, _V, _V, _V, types.float64), cache=True)
def _hold_loop(acc, y0, U, t, theta, width, rtol, atol, A, B, C, E3, E5, exponent):
    K = np.empty((_N_STAGES + 1, y0.shape[0]))
    Y = np.empty((t.shape[0], y0.shape[0]))
    Y[0] = y0
    nfev = 0
    for k in range(t.shape[0] - 1):
        y, nf, status = _interval(acc, Y[k], U[k], t[k], t[k + 1], theta, width, rtol, atol, A, B, C, E3, E5,
                                  exponent, K)
        nfev += nf
        if status != OK:
            return Y, nfev, k, status
        Y[k + 1] = y
    return Y, nfev, -1, OK


def simulate_hold(acceleration, y0: np.ndarray, U: np.ndarray, t: np.ndarray, theta: np.ndarray,
                  coulomb_width: float, rtol: float, atol: float) -> tuple[np.ndarray, int, int]:
    """States Y (N, 2n) at the instants t (N,) s under the torques U (N, n) N m held on [t_k, t_k+1).

    acceleration : compiled function of type :data:`ACCELERATION`; y0 : (2n,) [q0, qd0];
    theta : (p,); rtol, atol : scalar tolerances as in solve_ivp (rtol raised to 100 eps like it).
    Returns (Y, nfev, failed, status): failed = the index k of the interval that failed (Y[k + 1:]
    undefined), -1 when every interval succeeded; status :data:`OK`, :data:`TOO_SMALL_STEP` or
    :data:`DIVERGED`.
    """
    rtol = max(float(rtol), 100 * np.finfo(float).eps)
    as64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    return _hold_loop(acceleration, as64(y0), as64(U), as64(t), as64(theta), float(coulomb_width), rtol,
                      float(atol), _A, _B, _C, _E3, _E5, _EXPONENT)
