"""Closed-loop joint control at a fixed sample rate (the H4 paper's 1 kHz joint PI experiment).

Each sample k (period h = 1 / fs_hz):
    q_meas   = quantize_angle(q(t_k), counts_per_rev)                       encoder
    v_est    = (q_meas[k] - q_meas[k-1]) / h                                velocity estimate
    u        = kp e + ki sum(e) h + kd (qd_des - v_est),  e = q_des - q_meas    (PID, anti-windup)
    V_T      = clip(u / G_T, +-torque_limit / G_T)                          current reference
    Gamma    = G_T V_T                                                      (paper eq. 36)
and the robot's forward dynamics are integrated over [t_k, t_k+1) with Gamma held constant
(zero-order hold) by ``substeps`` classical RK4 steps: the robot's compiled stepper when it
offers one (:meth:`boundid.models.RobotModel.zoh_stepper`, the H4's warm-started Newton forward
model), else RK4 on its ``forward_dynamics``. A robot may run the whole loop compiled
(:meth:`boundid.models.RobotModel.compiled_closed_loop`, the H4 does): same operations, same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from boundid._validation import as_float_array, as_vector
from boundid.errors import InputError
from boundid.experiments.measurement import quantize_angle
from boundid.models.base import rk4_hold


@dataclass(frozen=True)
class JointPID:
    """Decentralised joint PID gains, (n,) each: kp N m/rad, ki N m/(rad s), kd N m s/rad."""

    kp: np.ndarray
    ki: np.ndarray
    kd: np.ndarray

    def __post_init__(self):
        kp, ki, kd = (as_vector(g, nm) for g, nm in ((self.kp, "kp"), (self.ki, "ki"), (self.kd, "kd")))
        if not (kp.shape == ki.shape == kd.shape) or np.any(kp <= 0) or np.any(ki < 0) or np.any(kd < 0):
            raise InputError("PID gains must have one value per joint, kp > 0 and ki, kd >= 0.")
        object.__setattr__(self, "kp", kp)
        object.__setattr__(self, "ki", ki)
        object.__setattr__(self, "kd", kd)

    @classmethod
    def from_bandwidth(cls, inertia, bandwidth_hz: float = 8.0, damping: float = 1.0,
                       integral_ratio: float = 0.2) -> JointPID:
        """Gains placing each joint (inertia (n,) kg m^2) at natural frequency bandwidth_hz.

        kp = I w^2, kd = 2 zeta I w, ki = kp * integral_ratio * w  (w = 2 pi bandwidth_hz).
        """
        inertia = as_vector(inertia, "inertia")
        if not (bandwidth_hz > 0 and damping > 0 and integral_ratio >= 0) or np.any(inertia <= 0):
            raise InputError("need inertia > 0, bandwidth_hz > 0, damping > 0, integral_ratio >= 0.")
        w = 2 * np.pi * bandwidth_hz
        kp = inertia * w**2
        return cls(kp, kp * integral_ratio * w, 2 * damping * inertia * w)


@dataclass
class ClosedLoopRun:
    """One closed-loop experiment, all arrays (N, n) sampled at t (N,) s.

    q, qd : true motor angles / velocities at the sample instants (rad, rad/s)
    q_meas : encoder readings (rad); q_des, qd_des : reference
    v_ref : current reference V_T; tau : Gamma = G_T V_T applied during [t_k, t_k+1) (N m)
    saturated : where |u| reached the torque limit; info : settings
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    q_meas: np.ndarray
    q_des: np.ndarray
    qd_des: np.ndarray
    v_ref: np.ndarray
    tau: np.ndarray
    saturated: np.ndarray
    info: dict = field(default_factory=dict)


def _rk4_generic(robot, q, qd, tau, dt, substeps, coulomb_width):
    return rk4_hold(lambda q_, qd_: robot.forward_dynamics(q_, qd_, tau, coulomb_width=coulomb_width),
                    q, qd, dt, substeps)


def zoh_step(robot, q, qd, tau, dt: float, substeps: int = 4, coulomb_width: float = 0.0, hint=None):
    """Advance one state (q, qd) (n,) by dt s under constant torque tau (n,); returns (q, qd, hint).

    The robot's compiled stepper when it offers one (:meth:`~boundid.models.RobotModel.zoh_stepper`; ``hint`` is
    its warm start, e.g. the H4's pose), else ``substeps`` RK4 steps of its forward dynamics.
    """
    stepper = robot.zoh_stepper()
    if stepper is not None:
        return stepper(q, qd, tau, dt, substeps, coulomb_width, hint)
    q1, qd1 = _rk4_generic(robot, q, qd, tau, dt, substeps, coulomb_width)
    return q1, qd1, None


def simulate_closed_loop(robot, reference, duration: float, controller: JointPID, fs_hz: float = 1000.0,
                         amplifier_gain=1.5, torque_limit=15.0, counts_per_rev: int = 65536,
                         substeps: int = 4, coulomb_width: float = 0.01, q0=None,
                         feedforward=None) -> ClosedLoopRun:
    """Track ``reference`` (an object with ``evaluate(t) -> (q, qd, qdd)``) for ``duration`` s.

    amplifier_gain : G_T, N m per unit of current reference; torque_limit : N m (+-15 for the H4);
    each a scalar (every joint) or one value per joint (n,);
    counts_per_rev : encoder resolution; substeps : RK4 steps per sample (4 keeps the tanh Coulomb
    friction of width ``coulomb_width`` rad/s stable and the angle error below 1e-7 rad after 40
    samples against solve_ivp, see tests/test_h4_experiment.py); q0 : initial angles (default:
    the reference at t = 0, at rest); feedforward : (N, n) N m added to the PID torque before the
    saturation at each sample (e.g. the computed torque of the reference), default none.
    """
    n = robot.n_joints
    gain, limit = (np.broadcast_to(np.asarray(v, float), (n,)) if np.ndim(v) == 0 else as_vector(v, name, n)
                   for v, name in ((amplifier_gain, "amplifier_gain"), (torque_limit, "torque_limit")))
    if not (duration > 0 and fs_hz > 0 and np.all(gain > 0) and np.all(limit > 0)):
        raise InputError("duration, fs_hz, amplifier_gain and torque_limit must be > 0.")
    if int(substeps) != substeps or substeps < 1:
        raise InputError(f"substeps must be a positive integer, got {substeps}.")
    if controller.kp.shape != (n,):
        raise InputError(f"controller has {controller.kp.shape[0]} joints, robot {n}.")
    h = 1.0 / fs_hz
    t = np.arange(int(round(duration * fs_hz))) * h
    q_des, qd_des, _ = reference.evaluate(t)
    ff = np.zeros((len(t), n)) if feedforward is None else as_float_array(feedforward, "feedforward")
    if ff.shape != (len(t), n):
        raise InputError(f"feedforward must have shape ({len(t)}, {n}) (one torque per sample and joint), got "
                         f"{ff.shape}.")
    q = np.array(q_des[0] if q0 is None else as_vector(q0, "q0", n), float)
    info = {"fs_hz": fs_hz, "amplifier_gain": amplifier_gain, "torque_limit": torque_limit,
            "counts_per_rev": counts_per_rev, "substeps": int(substeps), "coulomb_width": coulomb_width}
    v_max = limit / gain
    compiled = robot.compiled_closed_loop()
    if compiled is not None:  # the loop below, compiled by the robot (same operations, same numbers)
        quantize_angle(q, counts_per_rev)  # checks counts_per_rev
        Q, QD, QM, V, SAT = compiled(q, q_des, qd_des, ff, controller.kp, controller.ki,
                                     controller.kd, h, gain, v_max, 2.0 * np.pi / counts_per_rev, int(substeps),
                                     coulomb_width)
        return ClosedLoopRun(t, Q, QD, QM, q_des, qd_des, V, gain * V, SAT, info)
    qd = np.zeros(n)
    Q, QD, QM, V, SAT = (np.empty((len(t), n)) for _ in range(5))
    integ = np.zeros(n)
    q_prev = quantize_angle(q, counts_per_rev)
    hint = None
    stepper = robot.zoh_stepper()
    for k in range(len(t)):
        qm = quantize_angle(q, counts_per_rev)
        v_est = (qm - q_prev) / h
        q_prev = qm
        e = q_des[k] - qm
        u = ff[k] + controller.kp * e + controller.ki * integ + controller.kd * (qd_des[k] - v_est)
        v = u / gain
        sat = np.abs(v) >= v_max
        integ += np.where(sat, 0.0, e * h)  # conditional integration (anti-windup)
        v = np.clip(v, -v_max, v_max)
        Q[k], QD[k], QM[k], V[k], SAT[k] = q, qd, qm, v, sat
        if stepper is not None:
            q, qd, hint = stepper(q, qd, gain * v, h, int(substeps), coulomb_width, hint)
        else:
            q, qd = _rk4_generic(robot, q, qd, gain * v, h, int(substeps), coulomb_width)
    return ClosedLoopRun(t, Q, QD, QM, q_des, qd_des, V, gain * V, SAT.astype(bool), info)
