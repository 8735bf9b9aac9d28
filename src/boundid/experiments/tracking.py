"""The tracking experiment of a serial arm: an exciting trajectory within its joint limits, tracked
at a fixed sample rate by computed-torque feedforward plus joint PID, with measured torques.

This is how an industrial arm is identified [GautierKhalil1992; Swevers1997]: the controller, not
open-loop torques, keeps the arm on a trajectory chosen for its excitation, and the identification
uses the encoder angles and the commanded (motor current) torques.

- Trajectory: a rest-to-rest Fourier series around the middle of the joint ranges, scaled into the
  position, velocity and acceleration limits shrunk by ``margin``
  (:func:`boundid.experiments.limited_trajectories.fourier_within_limits`), optionally optimised
  for the condition number of the regressor (``optimize_evals`` > 0).
- Control at fs_hz (:func:`boundid.experiments.closed_loop.simulate_closed_loop`): the torque of the
  a-priori model along the reference (inverse dynamics with ``robot.theta_prior``, the CAD values)
  plus a decentralised PID placing each joint at ``bandwidth_hz`` (gains from the diagonal of the
  a-priori mass matrix at the rest position), saturated at the joints' effort limits.
- Truth: the robot's own dynamics with its true parameters (``robot.zoh_stepper()``, zero-order hold).
- Measurement: encoder angles quantised at counts_per_rev; torque = commanded torque + noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from boundid.errors import InputError
from boundid.experiments.closed_loop import ClosedLoopRun, JointPID, simulate_closed_loop
from boundid.experiments.limited_trajectories import fourier_within_limits, limit_usage, optimize_within_limits
from boundid.experiments.measurement import TorqueNoise
from boundid.experiments.trajectories import SegmentedTrajectory, condition_number, observation_matrix


@dataclass(frozen=True)
class TrackingConfig:
    """Settings of the tracking experiment (a study's [experiment] keys and experiment.options).

    duration_s, validation_duration_s : s, identification and cross-validation runs (0: none);
    fs_hz : control and sample rate; counts_per_rev : encoder resolution;
    coulomb_width : rad/s, tanh(qd / width) stands for sign(qd) in the simulation;
    torque_noise : added to the recorded torque.
    Options: period_s : s, period of the Fourier series (the run repeats it); harmonics : its
    number of harmonics (>= 3); margin : fraction of each limit kept free; bandwidth_hz : joint
    PID bandwidth; substeps : RK4 steps per sample; optimize_evals : evaluations of the condition
    number optimiser (0: random coefficients only).
    """

    duration_s: float = 20.0
    validation_duration_s: float = 0.0
    fs_hz: float = 1000.0
    counts_per_rev: int = 65536
    coulomb_width: float = 0.05
    torque_noise: TorqueNoise = field(default_factory=TorqueNoise)
    period_s: float = 10.0
    harmonics: int = 5
    margin: float = 0.1
    bandwidth_hz: float = 5.0
    substeps: int = 4
    optimize_evals: int = 0

    def __post_init__(self):
        if not (self.period_s > 0 and self.harmonics >= 3 and 0 <= self.margin < 0.5 and self.bandwidth_hz > 0
                and self.substeps >= 1 and self.optimize_evals >= 0):
            raise InputError("tracking options need period_s > 0, harmonics >= 3, 0 <= margin < 0.5, bandwidth_hz > 0, "
                             f"substeps >= 1 and optimize_evals >= 0; got {self}.")


#: experiment.options a study may set (the other fields come from the study's own keys)
OPTIONS = ("period_s", "harmonics", "margin", "bandwidth_hz", "substeps", "optimize_evals")


@dataclass
class TrackedRecording:
    """One tracking run: the closed-loop run (true states, encoder angles, commanded torque), the
    measured torque (N, n) N m and the trajectory it tracked."""

    run: ClosedLoopRun
    tau_meas: np.ndarray
    trajectory: SegmentedTrajectory


def limited_fourier(robot, rng: np.random.Generator, duration: float, cfg: TrackingConfig,
                        info: dict, name: str) -> SegmentedTrajectory:
    """A Fourier trajectory within the limits, repeated to cover ``duration`` s (optimised if asked)."""
    period = min(cfg.period_s, duration)
    traj = fourier_within_limits(robot, rng, period=period, harmonics=cfg.harmonics,
                                 repeats=math.ceil(duration / period - 1e-9), q0=robot.rest_position(),
                                 margin=cfg.margin)
    if cfg.optimize_evals > 0:
        traj, opt = optimize_within_limits(robot, traj, margin=cfg.margin, max_evals=cfg.optimize_evals)
        info[f"{name}_optimisation"] = {k: opt[k] for k in ("cond_before", "cond_after", "nfev")}
    return traj


def tracking_experiment(robot, rng: np.random.Generator, cfg: TrackingConfig,
                        trajectory: SegmentedTrajectory | None = None) -> tuple[dict[str, TrackedRecording], dict]:
    """Simulate the identification run (and the validation run when validation_duration_s > 0).

    robot : a model with joint limits and the "tracking" experiment (a URDF arm); its true
    parameters drive the simulation, its a-priori ones the feedforward and the gains.
    trajectory : the identification run's trajectory (e.g. designed,
    :mod:`boundid.studies.excitation`); None draws one from ``rng``. Returns the
    recordings by name and facts for the report (condition numbers, limit usage, tracking error,
    saturation).
    """
    if "tracking" not in robot.experiments:
        raise InputError(f"the {robot.name} model does not support the tracking experiment (it needs joint limits "
                         f"and a simulator); its experiments: {', '.join(robot.experiments) or 'none'}.")
    prior = np.asarray(robot.theta_prior, float)
    if np.any(np.isnan(prior)):
        raise InputError(f"the tracking experiment's feedforward needs every a-priori value of {robot.name}; "
                         "theta_prior has NaN.")
    rest = robot.rest_position()
    controller = JointPID.from_bandwidth(np.diag(robot.mass_matrix(rest[None], prior)[0]), cfg.bandwidth_hz)
    effort = robot.limits.effort
    recs, info = {}, {}
    runs = [("identification", cfg.duration_s), ("validation", cfg.validation_duration_s)]
    for name, duration in runs:
        if duration <= 0:
            continue
        traj = trajectory if name == "identification" and trajectory is not None else \
            limited_fourier(robot, rng, duration, cfg, info, name)
        t = np.arange(int(round(duration * cfg.fs_hz))) / cfg.fs_hz
        q_ref, qd_ref, qdd_ref = traj.evaluate(t)
        feedforward = robot.inverse_dynamics(q_ref, qd_ref, qdd_ref, prior)
        run = simulate_closed_loop(robot, traj, duration, controller, cfg.fs_hz, amplifier_gain=1.0,
                                   torque_limit=np.where(np.isfinite(effort), effort, 1e12),
                                   counts_per_rev=cfg.counts_per_rev, substeps=cfg.substeps,
                                   coulomb_width=cfg.coulomb_width, q0=q_ref[0], feedforward=feedforward)
        noise, _ = cfg.torque_noise.sample(run.tau.shape, rng)
        recs[name] = TrackedRecording(run, run.tau + noise, traj)
        W = observation_matrix(robot, traj)
        usage = limit_usage(robot, q_ref, qd_ref, qdd_ref, tau=run.tau)
        info[f"{name}_condition"] = condition_number(W, scaled=False)
        info[f"{name}_condition_scaled"] = condition_number(W, scaled=True)
        info[f"{name}_limit_usage"] = {k: round(v, 3) for k, v in usage.items()}
        info[f"{name}_tracking_error_rms_rad"] = float(np.sqrt(np.mean((run.q - q_ref) ** 2)))
        info[f"{name}_saturated_fraction"] = float(run.saturated.mean())
    return recs, info
