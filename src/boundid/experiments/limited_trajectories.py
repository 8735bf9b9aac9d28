"""Exciting Fourier trajectories within a robot's joint limits (position, velocity, acceleration, effort).

For robots that carry :class:`boundid.models.limits.JointLimits` (URDF arms: positions, velocities
and efforts from the file, accelerations by the rule of :mod:`boundid.models.urdf`). A trajectory
is one rest-to-rest :class:`FourierTrajectory` [GautierKhalil1992] around the middle of the joint
ranges, run ``repeats`` times. Positions, velocities and accelerations scale linearly with the
coefficients (q - q0, qd, qdd all proportional to them), so the largest admissible scale has a
closed form; the torque is checked with the robot's true parameters.

:func:`optimize_within_limits` lowers the condition number of the observation matrix with the
suite's optimiser :func:`boundid.experiments.trajectories.optimize_trajectory`: the robot is
wrapped so that a trajectory leaving the limits raises :class:`UnreachablePoseError`, which that
optimiser treats as a barrier. Pass the robot in base parameters
(:class:`boundid.models.base_parameters.BaseParameterModel`): the standard regressor is rank
deficient and its condition number infinite.

Limits shrunk by ``margin``: positions stay ``margin`` x range away from each end, speeds,
accelerations and torques within (1 - margin) x their limit.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from boundid._validation import as_vector
from boundid.errors import InputError, UnreachablePoseError
from boundid.experiments.trajectories import (
    FourierTrajectory,
    SegmentedTrajectory,
    condition_number,
    observation_matrix,
    optimize_trajectory,
)


def _limits(robot):
    limits = robot.limits
    if limits is None:
        raise InputError(f"robot {robot.name} declares no joint limits; build it from a URDF (UrdfRobot) or set its "
                         "`limits` (boundid.models.limits.JointLimits).")
    if not (np.all(np.isfinite(limits.velocity)) and np.all(np.isfinite(limits.acceleration))):
        raise InputError(f"robot {robot.name} needs finite velocity and acceleration limits to bound an exciting "
                         f"trajectory, got {limits.velocity} and {limits.acceleration}; pass velocity_limit= and "
                         "acceleration_limit= to its constructor (in a study: robot.options velocity_limit).")
    return limits


def _shrunk_range(limits, margin: float) -> tuple[np.ndarray, np.ndarray]:
    pad = np.where(np.isfinite(limits.upper - limits.lower), margin * (limits.upper - limits.lower), 0.0)
    return limits.lower + pad, limits.upper - pad


def limit_usage(robot, q, qd, qdd, margin: float = 0.0, tau=None) -> dict[str, float]:
    """Largest fraction of each limit (shrunk by ``margin``) used by samples (N, n); <= 1 inside.

    Position: the largest excursion beyond the shrunk range, as a fraction of the range
    (0 inside); velocity, acceleration, effort: max |x| / ((1 - margin) limit), the effort from
    ``tau`` (N, n) or else the robot's true parameters.
    """
    limits = _limits(robot)
    lo, hi = _shrunk_range(limits, margin)
    width = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    out = np.maximum(q - hi, 0.0) + np.maximum(lo - q, 0.0)
    tau = robot.inverse_dynamics(q, qd, qdd) if tau is None else tau
    keep = 1.0 - margin
    return {
        "position": float(np.max(out / width)),
        "velocity": float(np.max(np.abs(qd) / (keep * limits.velocity))),
        "acceleration": float(np.max(np.abs(qdd) / (keep * limits.acceleration))),
        "effort": float(np.max(np.abs(tau) / (keep * limits.effort))),
    }


def _inside(usage: dict[str, float]) -> bool:
    return usage["position"] == 0.0 and all(usage[k] <= 1.0 for k in ("velocity", "acceleration", "effort"))


def _kinematic_scale(seg: FourierTrajectory, limits, margin: float, fs_hz: float) -> float:
    """Largest f with q0 + f (q - q0), f qd, f qdd inside the shrunk limits (closed form)."""
    t = np.arange(0.0, seg.period, 1.0 / fs_hz)
    q, qd, qdd = seg.evaluate(t)
    lo, hi = _shrunk_range(limits, margin)
    if np.any(seg.q0 < lo) or np.any(seg.q0 > hi):
        raise InputError(f"the rest position q0 = {np.round(seg.q0, 4)} is outside the joint ranges shrunk by "
                         f"margin = {margin}; move it inside or lower the margin.")
    dq = q - seg.q0
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.concatenate([
            np.where(dq > 0, (hi - seg.q0) / dq, np.inf).ravel(),
            np.where(dq < 0, (lo - seg.q0) / dq, np.inf).ravel(),
            ((1.0 - margin) * limits.velocity / np.abs(qd)).ravel(),
            ((1.0 - margin) * limits.acceleration / np.abs(qdd)).ravel(),
        ])
    return float(np.min(f)) * (1.0 - 1e-9)  # on the limit up to rounding


def fit_to_limits(robot, traj: SegmentedTrajectory, margin: float = 0.1, max_scale: float = 1.0,
                  fs_hz: float = 1000.0, shrink: float = 0.95, max_shrinks: int = 60) -> SegmentedTrajectory:
    """Scale each segment by the largest factor <= max_scale that keeps it inside the shrunk limits.

    Position, velocity and acceleration give the factor in closed form (sampled at fs_hz, the
    controller's rate by default: between samples the peaks may exceed it by ~(pi f / fs_hz)^2 / 2
    relative, f the highest harmonic in Hz); then
    the factor is multiplied by ``shrink`` until the torque also fits (it is not proportional to
    the factor: gravity does not scale). Raises InputError if even the rest pose needs more torque.
    """
    if not 0 <= margin < 0.5:
        raise InputError(f"margin must be in [0, 0.5), got {margin}.")
    limits = _limits(robot)
    segs = []
    for seg in traj.segments:
        f = min(max_scale, _kinematic_scale(seg, limits, margin, fs_hz))
        t = np.arange(0.0, seg.period, 1.0 / fs_hz)
        for _ in range(max_shrinks):
            if _inside(limit_usage(robot, *seg.scaled(f).evaluate(t), margin)):
                break
            f *= shrink
        else:
            raise InputError(f"no scaling of this trajectory keeps the torques of {robot.name} within "
                             f"{1 - margin:.0%} of the effort limits {limits.effort}; choose another rest pose q0.")
        segs.append(seg.scaled(f))
    return replace(traj, segments=tuple(segs))


def fourier_within_limits(robot, rng: np.random.Generator, period: float = 10.0, harmonics: int = 5,
                          repeats: int = 1, q0=None, margin: float = 0.1) -> SegmentedTrajectory:
    """A random rest-to-rest Fourier trajectory, as large as the shrunk limits allow.

    period : s (fundamental 1 / period Hz); harmonics : K >= 3; repeats : periods run; q0 : rest
    position (default the middle of each joint range); random coefficients from ``rng``.
    """
    n = robot.n_joints
    limits = _limits(robot)
    q0 = limits.middle() if q0 is None else as_vector(q0, "q0", n)
    seg = FourierTrajectory(period, q0, rng.normal(size=(n, harmonics)), rng.normal(size=(n, harmonics))).at_rest()
    return fit_to_limits(robot, SegmentedTrajectory((seg,), (int(repeats),)), margin=margin, max_scale=np.inf)


class _LimitBarrier:
    """``robot`` whose regressor raises UnreachablePoseError outside the shrunk limits (the optimiser's barrier)."""

    def __init__(self, robot, margin: float):
        self.robot, self.margin = robot, margin
        self.name, self.n_joints, self.p = robot.name, robot.n_joints, robot.p

    def regressor(self, q, qd, qdd) -> np.ndarray:
        Y = self.robot.regressor(q, qd, qdd)
        if not _inside(limit_usage(self.robot, q, qd, qdd, self.margin, Y @ self.robot.theta_true)):
            raise UnreachablePoseError("trajectory outside the joint limits")
        return Y

    def workspace_excursion(self, q, margin: float = 0.0) -> float:
        return self.robot.workspace_excursion(q, margin)


def optimize_within_limits(robot, traj: SegmentedTrajectory, margin: float = 0.1, fs_hz: float = 10.0,
                           max_evals: int = 400, scaled: bool = True) -> tuple[SegmentedTrajectory, dict]:
    """Lower cond(W) of ``robot``'s regressor over the Fourier coefficients, within its joint limits.

    Runs :func:`optimize_trajectory` (Powell, at most ``max_evals`` evaluations, W sampled at
    fs_hz) with the limits shrunk by margin / 2 as a barrier, then scales the result back inside
    the limits shrunk by ``margin`` (checked at 1 kHz, :func:`fit_to_limits`). ``scaled`` uses the
    column-scaled condition number (default: base parameters mix kg m^2, kg m and friction units).
    Returns the trajectory and {cond_before, cond_after, usage (limit_usage of the result), nfev,
    message, scaled}.
    """
    start = fit_to_limits(robot, traj, margin=margin)
    W0 = observation_matrix(robot, start, fs_hz)
    if not np.isfinite(condition_number(W0, scaled)):
        raise InputError(f"the regressor of {robot.name} is rank deficient on this trajectory (infinite condition "
                         "number); optimise the robot in base parameters (BaseParameterModel).")
    best, info = optimize_trajectory(_LimitBarrier(robot, 0.5 * margin), start, fs_hz=fs_hz, margin=margin,
                                     max_evals=max_evals, scaled=scaled)
    best = fit_to_limits(robot, best, margin=margin)
    t = np.arange(0.0, best.duration, 1e-3)
    return best, {
        "cond_before": condition_number(W0, scaled),
        "cond_after": condition_number(observation_matrix(robot, best, fs_hz), scaled),
        "usage": limit_usage(robot, *best.evaluate(t), margin),
        "nfev": info["nfev"], "message": info["message"], "scaled": scaled,
    }
