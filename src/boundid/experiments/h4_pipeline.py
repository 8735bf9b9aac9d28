"""The H4 paper's data pipeline ([H4Paper] section IV.A): from measured q and Gamma to the regression.

1. velocities and accelerations: zero-phase Butterworth low-pass of q (forward and backward) then
   central differences. The cut-off keeps the closed-loop position band [0, w_dyn] undistorted:
   :func:`cutoff_from_bandwidth`.
2. regressor Y(q, qd, qdd) of eq. (14), with Jdot by central differences of J along the
   trajectory (the paper, after eq. 19) or analytically.
3. "parallel filtering": the torques and every regressor column are low-passed and decimated
   together (linear, so the model stays exact), then edge samples are dropped.
4. optionally, low speed: the rows of a joint near the samples where its estimated speed is below a
   threshold are dropped (:func:`low_speed_window`).

:func:`run_h4_experiment` runs the whole simulated experiment: exciting trajectory, closed loop
on the "truth" robot (structural error), noisy torque measurement, identification regression and
a cross-validation regression on a different trajectory.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from boundid._validation import as_float_array
from boundid.errors import InputError
from boundid.experiments.closed_loop import ClosedLoopRun, JointPID, simulate_closed_loop
from boundid.experiments.measurement import TorqueNoise
from boundid.experiments.preprocessing import (
    DECIMATION_ORDER,
    TORQUE_TIMINGS,
    decimate,
    differentiate,
    main_lobe,
    torque_at_samples,
)
from boundid.experiments.regression import DroppedRows, Regression, stack_joint_rows
from boundid.experiments.trajectories import (
    SegmentedTrajectory,
    check_in_workspace,
    condition_number,
    exciting_trajectory,
    observation_matrix,
    optimize_trajectory,
)


def cutoff_from_bandwidth(bandwidth_hz: float, order: int = 4, max_distortion: float = 1e-3) -> float:
    """Cut-off (Hz) of the zero-phase Butterworth low-pass keeping [0, bandwidth_hz] undistorted.

    filtfilt of an order-n Butterworth has gain 1 / (1 + (f/fc)^(2n)); it stays above
    1 - max_distortion up to the position bandwidth when fc = f_b ((1 - eps) / eps)^(1 / (2n))
    (about 2.4 f_b for n = 4, eps = 1e-3).
    """
    if not (bandwidth_hz > 0 and 0 < max_distortion < 1 and order >= 1):
        raise InputError("need bandwidth_hz > 0, 0 < max_distortion < 1 and order >= 1.")
    return float(bandwidth_hz * ((1 - max_distortion) / max_distortion) ** (1.0 / (2 * order)))


@dataclass(frozen=True)
class IdentificationDesign:
    """The torque-free half of :func:`identification_regression`: what the motor angles fix.

    rows : the regression with the torque side left at zero (W, joint, sample, t, info, dropped
    final); shape : (N, n), that of the angles (and of the torques); keep : (N_d,) bool, the
    decimated samples kept (edges dropped); fast : (R,) bool over the kept rows (sample-major), the
    rows kept by the low-speed rule (``min_speed``), or None; decimation, fc [Hz], fs [Hz] : the
    torque's low-pass and decimation (the regressor columns'); torque_timing : how the recorded
    torque is timed against the samples, "sample" or "hold"
    (:func:`boundid.experiments.preprocessing.torque_at_samples`, applied before the low-pass).
    :meth:`regression` then costs one low-pass of the torque.
    """

    rows: Regression
    shape: tuple[int, int]
    keep: np.ndarray
    fast: np.ndarray | None
    decimation: int
    fc: float
    fs: float
    torque_timing: str = "sample"

    def regression(self, tau) -> Regression:
        """The identification regression of the measured torque tau (N, n) N m on these angles."""
        tau = np.asarray(tau, float)
        if tau.shape != self.shape:
            raise InputError(f"tau must have the angles' shape {self.shape}, got {tau.shape}.")
        taud = decimate(torque_at_samples(tau, self.torque_timing), self.decimation, self.fc, self.fs)
        y = taud[self.keep].reshape(-1)
        if self.fast is not None:
            y = y[self.fast]
        r = self.rows
        return Regression(r.W, y, r.joint, r.sample, r.t, r.model, r.param_names, r.unit, dict(r.info), r.dropped)


#: samples on either side of a sample that its qdd depends on: central differences of central differences
DIFFERENCE_STENCIL = 2


def low_speed_window(fs: float, cutoff_hz: float | None, order: int, decimation: int, decimation_cutoff_hz: float
                     ) -> int:
    """Half-width [samples] of the rows that a slow sample spoils: the main lobe of the angles'
    low-pass (cutoff_hz, order; None: none) followed by the decimation low-pass (decimation_cutoff_hz,
    :data:`DECIMATION_ORDER`; none when decimation = 1), :func:`boundid.experiments.preprocessing.main_lobe`,
    plus the :data:`DIFFERENCE_STENCIL` of qdd; fs [Hz].

    Why: where a joint sticks or reverses, its torque departs from the model's fc sign(qd) (stiction,
    creep) and its estimated acceleration misses the stick-slip transients. The zero-phase filters
    spread that error of one sample k over the rows around k, weighted by their combined impulse
    response: positive over its main lobe (about 1 / (2 f_c) each side for one filter; 54 ms for the
    10 Hz low-pass of the angles then of the torque, where it holds ~75 % of the response's absolute
    sum), then ringing in side lobes of alternating sign, in which an error lasting longer than a lobe
    largely cancels. The main lobe, not the response's support: to 1e-3 of its peak that support is
    0.74 s each side at 10 Hz (order 4 then 8), and dropping it removed 97 % of the rows of a MuJoCo
    UR5 recording (tests/test_mujoco_recording.py).
    """
    filters = [(cutoff_hz, order)] if cutoff_hz is not None else []
    if decimation > 1:
        filters.append((decimation_cutoff_hz, DECIMATION_ORDER))
    return main_lobe(fs, filters) + DIFFERENCE_STENCIL


def _speed_thresholds(min_speed, n: int) -> np.ndarray:
    """(n,) rad/s thresholds from one number or one per joint (each finite, >= 0)."""
    v = as_float_array(min_speed, "min_speed")
    if v.ndim == 0:
        v = np.full(n, float(v))
    if v.shape != (n,) or not np.all(np.isfinite(v) & (v >= 0)):
        raise InputError(f"min_speed must be one number >= 0 (rad/s) or one per joint ({n}), got {min_speed!r}.")
    return v


def identification_design(robot, t, q, cutoff_hz: float, decimation: int = 10,
                          decimation_cutoff_hz: float | None = None, jdot: str = "central",
                          edge_s: float = 0.2, min_speed=0.0, order: int = 4,
                          slow_window_s: float | None = 0.0, torque_timing: str = "sample") -> IdentificationDesign:
    """Steps 1-4 of the pipeline on the angles alone (arguments of :func:`identification_regression`)."""
    t = np.asarray(t, float)
    q = np.asarray(q, float)
    if t.ndim != 1 or q.shape != (len(t), robot.n_joints):
        raise InputError(f"need t (N,) and q (N, {robot.n_joints}); got {t.shape}, {q.shape}.")
    if jdot not in ("central", "analytic"):
        raise InputError(f"jdot must be 'central' or 'analytic', got {jdot!r}.")
    if torque_timing not in TORQUE_TIMINGS:
        raise InputError(f"torque_timing must be one of {', '.join(map(repr, TORQUE_TIMINGS))}, got {torque_timing!r}.")
    h = float(np.mean(np.diff(t)))
    if np.max(np.abs(np.diff(t) - h)) > 1e-6 * h:
        raise InputError("t must be uniformly sampled (the filters and differences assume it).")
    fs = 1.0 / h
    qf, qd, qdd = differentiate(q, h, cutoff_hz, order)
    if jdot == "analytic":
        Y = robot.regressor(qf, qd, qdd)
    else:
        J = robot.chains(robot.pose(qf), qf).J
        Jd = np.gradient(J, h, axis=0, edge_order=2)
        Y = robot.regressor_from_jacobians(qd, qdd, J, np.einsum("nij,nj->ni", Jd, qd))
    fc = cutoff_hz if decimation_cutoff_hz is None else decimation_cutoff_hz
    if decimation > 1 and fc >= 0.5 * fs / decimation:
        raise InputError(f"decimation cut-off {fc:g} Hz must be below the new Nyquist {0.5 * fs / decimation:g} Hz;"
                         " lower the cut-off or the decimation factor.")
    N, n, p = Y.shape
    Yd = decimate(Y.reshape(N, n * p), decimation, fc, fs).reshape(-1, n, p)
    td = t[::decimation]
    keep = (td >= t[0] + edge_s) & (td <= t[-1] - edge_s)
    speeds = _speed_thresholds(min_speed, n)
    info = {"cutoff_hz": cutoff_hz, "decimation": decimation, "decimation_cutoff_hz": fc, "jdot": jdot,
            "edge_s": edge_s, "min_speed": min_speed, "fs_hz": fs, "torque_timing": torque_timing}
    rows = stack_joint_rows(Yd[keep], np.zeros((int(keep.sum()), n)), td[keep], "inverse_dynamic",
                            robot.param_names, info=info)
    fast = None
    if np.any(speeds > 0):
        if slow_window_s is None:
            window = low_speed_window(fs, cutoff_hz, order, decimation, fc)
        elif np.isfinite(slow_window_s) and slow_window_s >= 0:
            window = int(round(slow_window_s * fs))
        else:
            raise InputError(f"slow_window_s must be None or a finite number >= 0 (s), got {slow_window_s!r}.")
        slow = np.abs(qd) < speeds  # (N, n), per joint
        if window > 0:  # every sample within +-window of a slow one of the same joint
            slow = ndimage.binary_dilation(slow, structure=np.ones((2 * window + 1, 1), bool))
        fast = ~slow[::decimation][keep].reshape(-1)  # sample-major, like the rows
        if not fast.any():
            raise InputError(f"min_speed {min_speed!r} rad/s drops every inverse-dynamic row (a joint slower than "
                             f"it within {window / fs:g} s of each); lower the threshold(s).")
        per_joint = np.bincount(rows.joint[~fast], minlength=n)
        rows = rows.subset(fast)
        limit = f"{speeds[0]:g}" if np.all(speeds == speeds[0]) else f"({', '.join(f'{v:g}' for v in speeds)})"
        rows.dropped = DroppedRows(
            int(per_joint.sum()), int(fast.size), tuple(int(c) for c in per_joint), window / fs,
            f"a joint slower than {limit} rad/s within {window / fs:g} s: there its friction is not fc sign(qd) "
            "(stiction, creep) and the zero-phase filters spread that error over the neighbouring rows")
    return IdentificationDesign(rows, q.shape, keep, fast, decimation, fc, fs, torque_timing)


def identification_regression(robot, t, q, tau, cutoff_hz: float, decimation: int = 10,
                              decimation_cutoff_hz: float | None = None, jdot: str = "central",
                              edge_s: float = 0.2, min_speed=0.0, order: int = 4,
                              slow_window_s: float | None = 0.0, torque_timing: str = "sample") -> Regression:
    """The paper's identification regression from sampled motor angles and torques.

    t (N,) s uniformly sampled; q (N, 4) encoder angles (rad); tau (N, 4) Gamma = G_T V_T (N m);
    cutoff_hz : low-pass of q before central differences; decimation : keep 1 sample in this many
    after low-passing tau and the regressor columns alike with cut-off ``decimation_cutoff_hz``
    (default: the same cut-off as q's, so both sides share one pass band); jdot : "central"
    (paper) or "analytic"; edge_s : s dropped at each end (filter transients); min_speed : rad/s,
    one number or (n,) per joint: drop the rows of joint j within ``slow_window_s`` of a sample where
    the estimated |qd_j| < min_speed_j (there sign(qd) of the model is unreliable: at rest and at
    velocity reversals); slow_window_s : s, 0 (the slow sample's own row, the default) or None (the
    filters' reach, :func:`low_speed_window`); ``dropped`` of the result counts those rows;
    torque_timing : "sample" (tau[k] is the torque at t_k) or "hold" (tau[k] was held over
    [t_k, t_{k+1}): the row at t_k takes (tau[k-1] + tau[k]) / 2,
    :func:`boundid.experiments.preprocessing.torque_at_samples`).
    Rows are sample-major (joint 0..3 of each kept sample); ``info`` records the settings.
    The angles' half is :func:`identification_design` (reuse it when only the torque changes).
    """
    q, tau = np.asarray(q, float), np.asarray(tau, float)
    if tau.shape != q.shape:
        raise InputError(f"need q and tau of the same shape (N, {robot.n_joints}); got {q.shape}, {tau.shape}.")
    return identification_design(robot, t, q, cutoff_hz, decimation, decimation_cutoff_hz, jdot, edge_s,
                                 min_speed, order, slow_window_s, torque_timing).regression(tau)


@dataclass(frozen=True)
class H4ExperimentConfig:
    """Settings of the simulated H4 experiment (defaults follow studies/h4_obe.toml).

    structural : scale of H4Structural (0 = none, 1 = the default arms, rods and cogging; the
    truth's theta stays the robot's, see :func:`simulated_truth`); bandwidth_hz : position loop
    (PID from the a-priori inertia at home); cutoff_hz : None = cutoff_from_bandwidth(bandwidth_hz);
    optimize_evals : Powell evaluations for the trajectory (0 = random coefficients only).
    fast_period, slow_fraction : s, period of the fast (inertia) segment and the share of the
        duration given to the slow (friction) one (see ``exciting_trajectory``).
    """

    duration_s: float = 20.0
    validation_duration_s: float = 10.0
    fs_hz: float = 1000.0
    counts_per_rev: int = 65536
    coulomb_width: float = 0.01
    structural: float = 1.0
    torque_noise: TorqueNoise = field(default_factory=lambda: TorqueNoise("uniform", 0.05))
    amplifier_gain: float = 1.5
    torque_limit: float = 15.0
    bandwidth_hz: float = 8.0
    cutoff_hz: float | None = None
    decimation: int = 10
    jdot: str = "central"
    edge_s: float = 0.2
    substeps: int = 4
    optimize_evals: int = 0
    fast_period: float = 2.0
    slow_fraction: float = 0.4


@dataclass
class H4Experiment:
    """Identification and cross-validation data of one simulated H4 experiment."""

    identification: Regression
    validation: Regression
    runs: dict[str, ClosedLoopRun]
    trajectories: dict[str, SegmentedTrajectory]
    info: dict


def measure(truth, trajectory: SegmentedTrajectory, duration: float, controller: JointPID,
            config: H4ExperimentConfig, rng: np.random.Generator) -> tuple[ClosedLoopRun, np.ndarray]:
    """Closed-loop run on ``truth`` and the measured torque G_T V_T + noise (N, 4)."""
    run = simulate_closed_loop(truth, trajectory, duration, controller, config.fs_hz, config.amplifier_gain,
                               config.torque_limit, config.counts_per_rev, config.substeps, config.coulomb_width)
    noise, _ = config.torque_noise.sample(run.tau.shape, rng)
    return run, run.tau + noise


@dataclass
class H4Recording:
    """One measured closed-loop experiment: the run (true states, encoder readings), the measured
    torque G_T V_T + noise (N, 4) [N m], and the trajectory it tracked."""

    run: ClosedLoopRun
    tau_meas: np.ndarray
    trajectory: SegmentedTrajectory


def simulated_truth(robot, config: H4ExperimentConfig | None = None):
    """The robot the experiment simulates: H4Truth with ``robot``'s geometry, gravity and
    theta_true (so Imot holds the arms' motor-inertia share) and ``config.structural``.

    Pass it to :func:`boundid.experiments.best_approximation.best_approximation` for the model's
    best approximation of the simulated robot.
    """
    from boundid.models.h4 import H4Truth

    cfg = config or H4ExperimentConfig()
    return H4Truth(robot.geometry, cfg.structural, g=robot.g, theta_true=robot.theta_true)


def simulate_h4_experiment(rng: np.random.Generator, config: H4ExperimentConfig | None = None,
                           robot=None, trajectory: SegmentedTrajectory | None = None
                           ) -> tuple[dict[str, H4Recording], dict]:
    """Simulate the paper's two closed-loop experiments ("identification", "validation").

    robot : the identification model (default H4Robot()); the simulated truth is
    :func:`simulated_truth`. Two different exciting trajectories are drawn from
    ``rng`` (the identification run tracks ``trajectory`` instead, when given: e.g. designed,
    :mod:`boundid.studies.excitation`). Returns the recordings and facts (condition numbers,
    saturation, cut-off).
    """
    from boundid.models.h4 import H4Robot

    cfg = config or H4ExperimentConfig()
    robot = robot or H4Robot()
    truth = simulated_truth(robot, cfg)
    qh = robot.inverse_kinematics(np.asarray(robot.geometry.home))
    prior = np.where(np.isnan(robot.theta_prior), 0.0, robot.theta_prior)
    controller = JointPID.from_bandwidth(np.diag(robot.mass_matrix(qh, prior)), cfg.bandwidth_hz)
    recs, info = {}, {"cutoff_hz": cfg.cutoff_hz or cutoff_from_bandwidth(cfg.bandwidth_hz)}
    for name, duration in (("identification", cfg.duration_s), ("validation", cfg.validation_duration_s)):
        if name == "identification" and trajectory is not None:
            traj = trajectory
        else:
            traj = exciting_trajectory(robot, rng, duration=duration, slow_fraction=cfg.slow_fraction,
                                       fast_period=cfg.fast_period)
        if cfg.optimize_evals > 0 and traj is not trajectory:
            traj, opt = optimize_trajectory(robot, traj, max_evals=cfg.optimize_evals)
            info[f"{name}_optimisation"] = opt
        check_in_workspace(robot, traj)
        info[f"{name}_condition"] = condition_number(observation_matrix(robot, traj), scaled=False)
        info[f"{name}_condition_scaled"] = condition_number(observation_matrix(robot, traj), scaled=True)
        run, tau_meas = measure(truth, traj, duration, controller, cfg, rng)
        recs[name] = H4Recording(run, tau_meas, traj)
        info[f"{name}_saturated_fraction"] = float(run.saturated.mean())
    return recs, info


def run_h4_experiment(seed: int = 0, config: H4ExperimentConfig | None = None, robot=None) -> H4Experiment:
    """Simulate the paper's experiment and build its two regressions; all randomness from
    numpy.random.default_rng(seed) (see :func:`simulate_h4_experiment`)."""
    from boundid.models.h4 import H4Robot

    cfg = config or H4ExperimentConfig()
    robot = robot or H4Robot()
    recs, info = simulate_h4_experiment(np.random.default_rng(seed), cfg, robot)
    info["seed"] = seed
    regs = {name: identification_regression(robot, r.run.t, r.run.q_meas, r.tau_meas, info["cutoff_hz"],
                                            cfg.decimation, jdot=cfg.jdot, edge_s=cfg.edge_s)
            for name, r in recs.items()}
    return H4Experiment(regs["identification"], regs["validation"], {k: r.run for k, r in recs.items()},
                        {k: r.trajectory for k, r in recs.items()}, info)
