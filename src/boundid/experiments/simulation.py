"""Simulation of a robot model under sampled torques held constant (zero-order hold), and its measurement.

The torque u[k] is computed at t_k = k h and held on [t_k, t_k + h), as a digital controller or a
torque-mode amplifier does. Each hold interval is integrated on its own with
``scipy.integrate.solve_ivp`` (DOP853 by default, rtol 1e-10): the right-hand side is smooth inside
an interval, so the hold is exact and the integrator never steps across a torque jump.

Speed: the right-hand side is called ~13 times per interval, so it is the model's ability
``fast_acceleration(q, qd, u, theta, coulomb_width) -> list`` (one state, plain floats, no input
checks; DirectDriveArm, LinearToy and UrdfRobot override it with closed forms; the default of
:class:`boundid.models.RobotModel` solves ``mass_matrix`` against ``bias_torque``, several times slower).
An open-loop run (:func:`simulate_open_loop`, torques known in advance) of a model that declares
a ``compiled_acceleration`` (numba, :data:`boundid.models.base.ACCELERATION`; DirectDriveArm does)
with DOP853 goes through :func:`boundid.experiments._hold_integrator.simulate_hold` instead: the
same DOP853 steps as solve_ivp's, all intervals in one compiled call, ~100x faster
(``info["engine"]`` says which ran).

Coulomb friction is smoothed as tanh(qd / coulomb_width) (see :func:`boundid.models.coulomb`) so the
dynamics are Lipschitz; with width 0.01 rad/s the smoothing acts only within a few hundredths of a
rad/s of a velocity reversal. Cost: about 13 right-hand-side evaluations per hold interval away from
velocity reversals, more through them (the tanh is stiff there): ~97 000 for a 10 s direct-drive
run at h = 2.5 ms (4000 intervals).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.integrate import solve_ivp

from boundid._validation import as_float_array, as_vector
from boundid.errors import InputError, SolverError
from boundid.experiments._hold_integrator import DIVERGED, simulate_hold
from boundid.experiments.measurement import TorqueNoise, quantize_angle
from boundid.experiments.preprocessing import backward_difference
from boundid.models.base import RobotModel


@dataclass
class Trajectory:
    """Sampled motion of an n-joint robot at N instants t_k = t_0 + k h.

    t : (N,) s
    q : (N, n) rad
    qd : (N, n) rad/s            true velocity (simulated) or backward difference of q (measured)
    qdd : (N, n) rad/s^2 | None  true acceleration just after t_k, from the dynamics with tau[k]
                                 (simulated); None for measured data
    tau : (N, n) N m             torque held on [t_k, t_k + h); the last one is never applied
    h : float                    sample period, s
    info : dict                  how it was made (model, solver settings, noise, encoder ...)
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray | None
    tau: np.ndarray
    h: float
    info: dict = field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        return int(self.t.shape[0])


def _n_intervals(t_end: float, h: float) -> int:
    if not (np.isfinite(h) and h > 0):
        raise InputError(f"sample period h must be finite and > 0 s, got {h}.")
    if not (np.isfinite(t_end) and t_end >= h):
        raise InputError(f"t_end must be finite and at least one sample period h = {h} s, got {t_end}.")
    K = int(round(t_end / h))
    if abs(K * h - t_end) > 1e-9 * max(t_end, 1.0):
        raise InputError(f"t_end = {t_end} s is not a whole number of periods h = {h} s; use {K * h:g} s.")
    return K


def simulate_sampled(model, torque: Callable, t_end: float, h: float, q0=None, qd0=None, theta=None,
                     coulomb_width: float = 0.01, rtol: float = 1e-10, atol: float = 1e-10,
                     method: str = "DOP853") -> Trajectory:
    """Simulate ``model`` from (q0, qd0) with u[k] = torque(t_k, q_k, qd_k) held on [t_k, t_k + h).

    model : a :class:`boundid.models.RobotModel`
    torque : callable (t [s], q (n,), qd (n,)) -> (n,) N m, called once per sample (so it may be a
        sampled feedback law); must return finite values
    t_end : s, a whole number of periods; the result has N = t_end / h + 1 samples (t = 0 .. t_end)
    h : sample (hold) period, s
    q0, qd0 : (n,) initial state, default at rest at q = 0 (hanging down for the arms)
    theta : parameters to simulate with (default ``model.theta_true``)
    coulomb_width : rad/s, Coulomb friction as tanh(qd / width); 0 is the discontinuous sign (slow)
    rtol, atol : solve_ivp tolerances for each interval; ``method`` its integrator
    """
    n = model.n_joints
    K = _n_intervals(t_end, h)
    q = np.zeros(n) if q0 is None else as_vector(q0, "q0", n)
    qd = np.zeros(n) if qd0 is None else as_vector(qd0, "qd0", n)
    theta = model._theta(theta)
    if coulomb_width < 0:
        raise InputError(f"coulomb_width must be >= 0 rad/s, got {coulomb_width}.")

    fast, theta_list = model.fast_acceleration, theta.tolist()

    def rhs(_t, y, u):
        s = y.tolist()
        return np.array(s[n:] + fast(s[:n], s[n:], u, theta_list, coulomb_width))

    t = np.arange(K + 1) * h
    Y = np.empty((K + 1, 2 * n))
    U = np.empty((K + 1, n))
    Y[0] = np.concatenate([q, qd])
    nfev = 0
    for k in range(K + 1):
        u = as_vector(torque(t[k], Y[k, :n].copy(), Y[k, n:].copy()), f"torque at t = {t[k]:g} s", n)
        U[k] = u
        if k == K:
            break
        sol = solve_ivp(rhs, (t[k], t[k + 1]), Y[k], method=method, rtol=rtol, atol=atol, args=(u.tolist(),),
                        first_step=t[k + 1] - t[k])
        if not sol.success:
            raise SolverError(f"solve_ivp ({method}) failed on [{t[k]:g}, {t[k + 1]:g}] s: {sol.message}; "
                              "increase coulomb_width or loosen rtol/atol.")
        nfev += sol.nfev
        Y[k + 1] = sol.y[:, -1]
    q, qd = Y[:, :n], Y[:, n:]
    qdd = model.forward_dynamics(q, qd, U, theta, coulomb_width)
    info = {"model": model.name, "theta": theta.copy(), "coulomb_width": coulomb_width, "rtol": rtol,
            "atol": atol, "method": method, "nfev": nfev, "hold": "zero-order",
            "fast_path": type(model).fast_acceleration is not RobotModel.fast_acceleration,
            "engine": "scipy solve_ivp"}
    return Trajectory(t=t, q=q, qd=qd, qdd=qdd, tau=U, h=float(h), info=info)


def simulate_open_loop(model, torque, t_end: float, h: float, q0=None, qd0=None, theta=None,
                       coulomb_width: float = 0.01, rtol: float = 1e-10, atol: float = 1e-10,
                       method: str = "DOP853") -> Trajectory:
    """Open-loop simulation under sampled-and-held torques (see :func:`simulate_sampled`).

    torque : a vectorised function of time, (N,) s -> (N, n) N m (e.g.
        :meth:`boundid.experiments.excitation.RampedMultisine.direct_drive_paper`), sampled at
        t_k = k h; or an array (t_end / h + 1, n) of the samples themselves.
    """
    K = _n_intervals(t_end, h)
    t = np.arange(K + 1) * h
    U = as_float_array(torque(t) if callable(torque) else torque, "torque")
    if U.shape != (K + 1, model.n_joints) or not np.all(np.isfinite(U)):
        raise InputError(f"the torque samples must be finite with shape ({K + 1}, {model.n_joints}) "
                         f"(one row per instant 0, h, ..., t_end), got {U.shape}.")
    compiled = model.compiled_acceleration
    if compiled is not None and method == "DOP853":
        traj = _simulate_compiled(model, compiled, U, t, h, q0, qd0, theta, coulomb_width, rtol, atol)
    else:
        traj = simulate_sampled(model, lambda tk, _q, _qd: U[int(round(tk / h))], t_end, h, q0, qd0, theta,
                                coulomb_width, rtol, atol, method)
    traj.info["excitation"] = repr(torque) if callable(torque) else "samples"
    return traj


def _simulate_compiled(model, acceleration, U, t, h, q0, qd0, theta, coulomb_width, rtol, atol) -> Trajectory:
    """:func:`simulate_open_loop` through the compiled DOP853 hold integrator (same steps as solve_ivp)."""
    n = model.n_joints
    q = np.zeros(n) if q0 is None else as_vector(q0, "q0", n)
    qd = np.zeros(n) if qd0 is None else as_vector(qd0, "qd0", n)
    theta = model._theta(theta)
    if coulomb_width < 0:
        raise InputError(f"coulomb_width must be >= 0 rad/s, got {coulomb_width}.")
    Y, nfev, failed, status = simulate_hold(acceleration, np.concatenate([q, qd]), U, t, theta, coulomb_width,
                                            rtol, atol)
    if status == DIVERGED:
        raise SolverError(f"DOP853 (compiled): the state became infinite or NaN on [{t[failed]:g}, "
                          f"{t[failed + 1]:g}] s: these dynamics diverge (check theta: a physical robot's do not).")
    if failed >= 0:
        raise SolverError(f"DOP853 (compiled) failed on [{t[failed]:g}, {t[failed + 1]:g}] s: required step size "
                          "is less than spacing between numbers; increase coulomb_width or loosen rtol/atol.")
    q, qd = Y[:, :n], Y[:, n:]
    qdd = model.forward_dynamics(q, qd, U, theta, coulomb_width)
    info = {"model": model.name, "theta": theta.copy(), "coulomb_width": coulomb_width, "rtol": rtol,
            "atol": atol, "method": "DOP853", "nfev": nfev, "hold": "zero-order", "fast_path": True,
            "engine": "compiled DOP853 (boundid.experiments._hold_integrator)"}
    return Trajectory(t=t, q=q, qd=qd, qdd=qdd, tau=U, h=float(h), info=info)


def measure(traj: Trajectory, counts_per_rev: int | None = None, noise: TorqueNoise | None = None,
            rng: np.random.Generator | None = None) -> Trajectory:
    """What the paper's controller records: quantised angles, noisy torques, backward-difference velocity.

    counts_per_rev : encoder resolution (e.g. 2**16 for 16 bits); None keeps q exact
    noise : additive torque noise (N m) on the recorded torque; None for none
    rng : numpy Generator (required when the noise is random)

    Returns a :class:`Trajectory` with qdd = None and ``info["outliers"]`` (N, n) bool.
    """
    noise = TorqueNoise() if noise is None else noise
    if noise.kind != "none" and rng is None:
        raise InputError("measure() needs rng=np.random.default_rng(seed) to draw torque noise.")
    q = traj.q if counts_per_rev is None else quantize_angle(traj.q, counts_per_rev)
    e, outliers = noise.sample(traj.tau.shape, rng)
    info = {**traj.info, "counts_per_rev": counts_per_rev, "noise": noise, "outliers": outliers,
            "velocity": "backward difference"}
    return replace(traj, q=q, qd=backward_difference(q, traj.h), qdd=None, tau=traj.tau + e, info=info)
