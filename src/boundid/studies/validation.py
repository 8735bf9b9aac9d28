"""Validation of identified parameters on data they were not fitted to (or by re-simulation).

- open loop ([DirectDrivePaper]): re-simulate the robot with each identified theta under the same torques
  and compare the joint positions with the measured ones;
- cross-validation trajectory ([H4Paper] eq. 37): predict the torque of a different experiment,
  with the bounds of a set-membership estimate S, [-h_S(-w), h_S(w)] (h_S the support function:
  for an ellipsoid w^T theta_hat +- sqrt(w^T S w), eq. 37; the same formula for a set of any
  family), and the statistical band w^T theta_hat +- 1.96 sqrt(w^T Cov w + sigma^2), a 95 % prediction
  band when the validation rows' error is white noise of the variance sigma^2 the estimate assumes (its
  coverage of the validation samples, :func:`band_name`, says whether it is one on the data at hand);
- the second truth (simulated data): the identification model's best approximation of the simulated
  robot (:func:`boundid.experiments.best_approximation.best_approximation`), for comparisons where
  the model cannot represent the simulator's parameters;
- a noise-seed sweep of the OBE fits (simulated open-loop data): how often each OBE form breaks
  down, a rate rather than one run's pass or fail.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from boundid.errors import RUN_FAILURES
from boundid.estimators import Estimate
from boundid.experiments.simulation import simulate_open_loop
from boundid.models import RobotModel
from boundid.sets import Polytope, support_values
from boundid.studies.config import StudyConfig
from boundid.studies.data import StudyData
from boundid.studies.regressions import inverse_dynamic_design, inverse_dynamic_rows


@dataclass
class Resimulation:
    """Open-loop re-simulation with identified parameters. q: (N, n) rad, or None with the reason."""

    label: str
    q: np.ndarray | None
    rms_error_rad: np.ndarray | None
    failure: str | None = None


PREDICTION_LEVEL = 0.95  # nominal coverage of the statistical bands
#: a statistical band whose coverage of the validation samples lies in this range is called a prediction
#: band at PREDICTION_LEVEL; outside it the page names it by what it is (:func:`band_name`)
COVERAGE_RANGE = (0.90, 0.99)


@dataclass
class TorqueBand:
    """Predicted torque on the validation trajectory, (S, n) N m each: the prediction
    w^T theta_hat and the band [lower, upper] around it; ``kind`` the estimate's ("exact" for the
    feasible polytope's own band). error_bound (n,) N m, for a set-membership band: the bound on
    |measured - w^T theta| of each joint's rows, so that under the bound the measured torque lies in
    [lower - e, upper + e] (a statistical band already predicts the measured torque: None).
    A statistical band's ``level`` is its nominal coverage (None for the others) and ``noise`` where
    its noise variance comes from: "residuals" (estimated from the identification residuals: OLS,
    WLS, RLS) or "stated" (given, not estimated: the Kalman filter's R)."""

    label: str
    center: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    kind: str
    error_bound: np.ndarray | None = None
    level: float | None = None
    noise: str | None = None

    @property
    def half_width(self) -> np.ndarray:
        """Half the band's width (S, n) N m."""
        return 0.5 * (self.upper - self.lower)

    def outside_fraction(self, measured: np.ndarray) -> float:
        """Share of the measured torques (S, n) outside the band (NaN entries, rows left out of the
        regression, are not counted)."""
        valid = ~np.isnan(measured)
        return float(np.mean(((measured < self.lower) | (measured > self.upper))[valid]))

    def coverage(self, measured: np.ndarray) -> float:
        """Share of the measured torques (S, n) inside the band (NaN entries not counted)."""
        return 1.0 - self.outside_fraction(measured)

    def error_ratio(self, measured: np.ndarray) -> np.ndarray:
        """Per joint (n,), rms of measured - center over the rms of the standard deviation the band
        predicts (half-width / z of its level): ~1 when the band's noise model holds, NaN for a band
        that is not statistical."""
        n = measured.shape[1]
        if self.level is None:
            return np.full(n, np.nan)
        sd = self.half_width / stats.norm.ppf(0.5 + 0.5 * self.level)
        err = measured - self.center
        return np.array([np.sqrt(np.nanmean(err[:, j] ** 2) / np.nanmean(sd[:, j] ** 2)) for j in range(n)])

    def outside_measured_fraction(self, measured: np.ndarray) -> float:
        """Share of the measured torques (S, n) outside [lower - e, upper + e], the band a measurement
        must lie in under the bound e = ``error_bound``; NaN without one."""
        if self.error_bound is None:
            return float("nan")
        valid = ~np.isnan(measured)
        e = self.error_bound[None, :]
        return float(np.mean(((measured < self.lower - e) | (measured > self.upper + e))[valid]))


def _mass_matrix_pd(model: RobotModel, q: np.ndarray, theta: np.ndarray) -> bool:
    """Whether M(q, theta) is positive definite at every sampled q (physically consistent theta)."""
    return bool(np.all(np.linalg.eigvalsh(model.mass_matrix(q[::10], theta)) > 0))


def resimulate(cfg: StudyConfig, model: RobotModel, data: StudyData, label: str, theta: np.ndarray) -> Resimulation:
    """The study's open-loop experiment simulated again with the identified ``theta`` (the same
    excitation torques, duration and sample period), and the RMS error of its joint angles against
    the recorded ones. A failure is returned with its reason, never raised: M(q) not positive definite
    along the recorded trajectory (no physical robot), or a simulation that fails."""
    exp, rec = cfg.experiment, data.recording
    try:
        if not _mass_matrix_pd(model, rec.q, theta):
            return Resimulation(label, None, None, "M(q) is not positive definite along the trajectory: "
                                                   "these parameters describe no physical robot")
        traj = simulate_open_loop(model, data.excitation, exp.duration_s, exp.sample_period_s, theta=theta,
                                  coulomb_width=exp.coulomb_width_rad_s, rtol=1e-8, atol=1e-8)
    except RUN_FAILURES as exc:  # e.g. a "math domain error" when the identified dynamics diverge
        return Resimulation(label, None, None, f"simulation failed: {type(exc).__name__}: {exc}")
    rms = np.sqrt(np.mean((traj.q - rec.q) ** 2, axis=0))
    return Resimulation(label, traj.q, rms)


def per_sample(values: np.ndarray, reg, n_joints: int) -> tuple[np.ndarray, np.ndarray]:
    """Values (N,) of the rows of ``reg`` (one per joint and sample) as (S, n) per sample, NaN where
    a joint's row was left out (e.g. by min_speed_rad_s), and the times (S,) of the S samples."""
    samples, row = np.unique(reg.sample, return_inverse=True)
    out = np.full((samples.size, n_joints), np.nan)
    out[row, reg.joint] = values
    t = np.empty(samples.size)
    t[row] = reg.t
    return out, t


def torque_bands(reg, n_joints: int, estimates: dict[str, Estimate], polytope: Polytope | None = None,
                 error_bounds: dict[str, np.ndarray] | None = None) -> dict[str, TorqueBand]:
    """[H4Paper] eq. 37 bounds [-h_S(-w), h_S(w)] of each row w of the regression ``reg`` for
    set-membership estimates (guaranteed or unverified, any family), bands w^T c +- 1.96 sqrt(w^T Cov w +
    noise variance) of nominal level PREDICTION_LEVEL for statistical ones (95 % prediction bands when
    the rows' error is white noise of that variance; :func:`band_name`); point estimates get none. With the
    exact feasible polytope, its own band "LP exact" [min, max] of w^T theta over it (2 LPs per
    row): the narrowest band any guaranteed set can give. Each band is (S, n) per sample
    (:func:`per_sample`); error_bounds: label (or "LP exact") -> the bound (n,) of each joint's rows."""
    W, joint = reg.W, reg.joint
    error_bounds = error_bounds or {}
    bands = {}
    if polytope is not None:
        upper, lower = polytope.supports(W), -polytope.supports(-W)
        bands["LP exact"] = TorqueBand("LP exact", *(per_sample(a, reg, n_joints)[0]
                                                     for a in (0.5 * (lower + upper), lower, upper)),
                                       "exact", error_bounds.get("LP exact"))
    z = stats.norm.ppf(0.5 + 0.5 * PREDICTION_LEVEL)
    for label, est in estimates.items():
        center = W @ est.center
        level = noise = None
        if est.set_membership:
            upper, lower = support_values(est.set, W), -support_values(est.set, -W)
        elif est.statistics is not None:
            var = np.einsum("ij,jk,ik->i", W, est.statistics.cov, W)
            half = z * np.sqrt(var + est.statistics.row_noise_variance(joint))
            lower, upper = center - half, center + half
            # dof is infinite where the noise variance was given rather than estimated (Kalman's R)
            level, noise = PREDICTION_LEVEL, "stated" if np.isinf(est.statistics.dof) else "residuals"
        else:
            continue
        bands[label] = TorqueBand(label, *(per_sample(a, reg, n_joints)[0] for a in (center, lower, upper)),
                                  est.kind, error_bounds.get(label) if est.set_membership else None, level, noise)
    return bands


def band_name(band: TorqueBand, measured: np.ndarray) -> str:
    """What a band is, given its coverage of the measured torques (S, n): a statistical band is a
    "95 % prediction band" only where its coverage lies in COVERAGE_RANGE; elsewhere the noise model it
    rests on does not describe the validation rows (their error is larger or smaller than the noise
    variance it assumes: not white noise of that variance, e.g. a deterministic error of the rows
    that depends on the motion) and it is named by where its width comes from."""
    if band.level is None:
        return "[min, max] over the exact polytope" if band.kind == "exact" else "[min, max] over the set"
    lo, hi = COVERAGE_RANGE
    if lo <= band.coverage(measured) <= hi:
        return f"{100 * band.level:g} % prediction band"
    source = "the stated noise variance R" if band.noise == "stated" else "the identification residuals' noise"
    return f"band of {source} (nominal {100 * band.level:g} %, not a prediction band here)"


def statistical_coverage(reg, n_joints: int, estimates: dict[str, Estimate]) -> dict[str, float]:
    """Coverage of the statistical bands of ``estimates`` on the rows of ``reg`` (e.g. the identification
    rows they were fitted to, where the residual noise variance was estimated)."""
    stat = {lab: e for lab, e in estimates.items() if e.kind == "statistical" and e.statistics is not None}
    measured = per_sample(reg.y, reg, n_joints)[0]
    return {lab: b.coverage(measured) for lab, b in torque_bands(reg, n_joints, stat).items()}


def row_error_rms(reg, n_joints: int, theta: np.ndarray) -> np.ndarray:
    """Per joint (n,), the rms of y - W theta over the rows of ``reg`` (with the true theta: the rows'
    own error, noise and any deterministic error of the data, whatever the estimate)."""
    e = reg.y - reg.W @ theta
    return np.array([np.sqrt(np.mean(e[reg.joint == j] ** 2)) if np.any(reg.joint == j) else np.nan
                     for j in range(n_joints)])


@dataclass
class SecondTruth:
    """The identification model's best approximation of the simulated robot (minimax fit on exact,
    noise-free data of a long motion): theta (p,), its max and rms residual [N m] there, the
    simulator's name, and ``represents``: whether the fit is exact (max residual <= REPRESENTS_N_M),
    i.e. whether the model represents the simulator and one truth suffices."""

    theta: np.ndarray
    max_residual: float
    rms_residual: float
    simulator_name: str
    represents: bool


BEST_APPROX_DURATION_S = 120.0  # s of exact motion for the best approximation
REPRESENTS_N_M = 1e-4  # N m: a best approximation this close is the simulator itself (LP tolerance)
SWEEP_SEEDS = 20  # noise draws of the OBE breakdown sweep


def second_truth(cfg: StudyConfig, model: RobotModel) -> SecondTruth | None:
    """:func:`~boundid.experiments.best_approximation.best_approximation` of the robot the study
    simulates by ``model``, on the random stream ``np.random.default_rng([cfg.seed, 1])``
    (independent of the experiment's); None for measured data (no simulator). The H4's simulator is
    :func:`~boundid.experiments.h4_pipeline.simulated_truth` (arms, rods, cogging); the open-loop
    arm's is ``model`` itself."""
    from boundid.experiments.best_approximation import best_approximation

    exp = cfg.experiment
    if exp.source != "simulate":
        return None
    rng = np.random.default_rng([cfg.seed, 1])
    if exp.control == "closed_loop":
        from boundid.experiments.h4_pipeline import H4ExperimentConfig, simulated_truth

        robot = simulated_truth(model, H4ExperimentConfig(structural=exp.structural_error))
        name = f"simulated H4 (structural error x {exp.structural_error:g})"
    else:
        robot, name = model, f"the {model.name} model itself"
    # Coulomb friction as sign(qd) on both sides: the simulation's tanh(qd / width) is a numerical
    # stand-in for it, not a structural error of the model
    ba = best_approximation(robot, model, rng, duration_s=BEST_APPROX_DURATION_S)
    return SecondTruth(ba.theta, ba.max_residual, ba.rms_residual, name, ba.max_residual <= REPRESENTS_N_M)


@dataclass
class BreakdownSweep:
    """OBE fits over ``seeds`` independent noise draws of the same experiment: per estimator label,
    the list of failures (None where the fit succeeded as guaranteed, else the reason)."""

    seeds: list[int]
    regression: str
    outcomes: dict[str, list[str | None]] = field(default_factory=dict)

    def rate(self, label: str) -> float:
        """Share of the seeds on which ``label`` broke down (raised, or ended unverified)."""
        o = self.outcomes[label]
        return sum(x is not None for x in o) / max(len(o), 1)


def obe_breakdown_sweep(cfg: StudyConfig, model: RobotModel, data: StudyData, n_seeds: int) -> BreakdownSweep | None:
    """Re-draw the experiment's noise ``n_seeds`` times (streams ``default_rng([cfg.seed, 2, k])``)
    on the same noise-free motion, rebuild the OBE estimators' regression and refit every OBE
    estimator of the study. Open loop: the encoder and torque noise of the simulated motion; closed
    loop: the torque measurement noise on the recorded run (it is added to the recording only, so
    the motion and the encoder angles are those of the run: the inverse-dynamic regressor is built
    once, only its torque side per seed). None where no OBE runs or the data are not simulated."""
    from boundid.experiments.recording import Recording
    from boundid.experiments.simulation import measure
    from boundid.studies.estimation import run_estimator
    from boundid.studies.regressions import build_regressions

    exp = cfg.experiment
    obes = [ec for ec in cfg.estimators if ec.method == "obe"]
    if not obes or n_seeds <= 0 or exp.source != "simulate" or (data.excitation is None and data.clean_tau is None):
        return None
    regs = sorted({rn for ec in obes for rn in ec.regressions})
    traj = None
    if data.excitation is not None:
        traj = simulate_open_loop(model, data.excitation, exp.duration_s, exp.sample_period_s,
                                  coulomb_width=exp.coulomb_width_rad_s)
    seeds = list(range(n_seeds))
    sweep = BreakdownSweep(seeds, ", ".join(regs), {f"{ec.label} / {rn}": [] for ec in obes for rn in ec.regressions})
    design = None  # closed loop: the angles are the run's on every seed, so the regressor is built once
    if traj is None and "inverse_dynamic" in regs:
        design = inverse_dynamic_design(model, data.recording, cfg.preprocessing)
    others = tuple(rn for rn in regs if design is None or rn != "inverse_dynamic")
    for k in seeds:
        rng = np.random.default_rng([cfg.seed, 2, k])
        if traj is not None:
            meas = measure(traj, exp.encoder_counts_per_rev, exp.torque_noise, rng)
            rec = Recording(t=meas.t, q=meas.q, tau=meas.tau)
        else:
            noise, _ = exp.torque_noise.sample(data.clean_tau.shape, rng)
            rec = Recording(t=data.recording.t, q=data.recording.q, tau=data.clean_tau + noise)
        built = build_regressions(model, rec, cfg.preprocessing, others)
        if design is not None:
            built["inverse_dynamic"] = design.regression(rec.tau)
        for ec in obes:
            for rn in ec.regressions:
                try:
                    est = run_estimator(ec, built[rn], model, cfg.prior)
                    outcome = None if est.kind == "guaranteed" else f"unverified: {est.unverified_reason}"
                except RUN_FAILURES as exc:
                    outcome = f"{type(exc).__name__}: {exc}"
                sweep.outcomes[f"{ec.label} / {rn}"].append(outcome)
    return sweep


def validate_study(cfg: StudyConfig, model: RobotModel, data: StudyData,
                   estimates: dict[tuple[str, str], Estimate], polytope: Polytope | None = None,
                   error_bounds: dict[str, np.ndarray] | None = None) -> dict:
    """Re-simulation, cross-validation bands (on the inverse dynamic rows of the validation
    recording: a second experiment, or the held-out end of a measured one; with the exact
    ``polytope`` of the inverse dynamic rows, its band too; error_bounds as :func:`torque_bands`),
    the second truth ("second_truth") and the OBE breakdown sweep over ``SWEEP_SEEDS`` noise seeds
    ("obe_sweep")."""
    out: dict = {"second_truth": second_truth(cfg, model),
                 "obe_sweep": obe_breakdown_sweep(cfg, model, data, SWEEP_SEEDS)}
    if data.excitation is not None:
        out["resimulation"] = [resimulate(cfg, model, data, f"{lab} / {rn}", est.center)
                               for (lab, rn), est in estimates.items()]
    if data.validation is not None:

        reg = inverse_dynamic_rows(model, data.validation, cfg.preprocessing)
        ests = {lab: e for (lab, rn), e in estimates.items() if rn == "inverse_dynamic"}
        out["validation_regression"] = reg
        out["validation_measured"], out["validation_t"] = per_sample(reg.y, reg, model.n_joints)
        out["torque_bands"] = torque_bands(reg, model.n_joints, ests, polytope, error_bounds)
    return out
