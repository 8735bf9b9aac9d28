"""Running a study: data -> regressions -> estimators -> exact optima -> validation -> tidy table."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from boundid.errors import BoundidError, InfeasibleDataError, SolverError, StudyError
from boundid.estimators import OBE, RLS, Estimate, KalmanEstimator, ols, wls
from boundid.estimators.certify import validate
from boundid.experiments import regression as reg_builders
from boundid.experiments.filters import align
from boundid.experiments.h4_pipeline import identification_regression
from boundid.experiments.recording import Recording
from boundid.experiments.regression import Regression
from boundid.models import RobotModel
from boundid.sets import Polytope, SDPResult, inner_ellipsoid, john_outer, outer_ellipsoid
from boundid.studies.config import EstimatorConfig, PreprocessingConfig, PriorConfig, StudyConfig
from boundid.studies.data import StudyData, acquire
from boundid.studies.progress import QUIET, Progress
from boundid.studies.registry import make_robot

# ------------------------------------------------------------------------------ regressions


def inverse_dynamic_rows(model: RobotModel, rec: Recording, pp: PreprocessingConfig) -> Regression:
    """IDIM rows by the H4 paper's pipeline (:func:`identification_regression`, with the analytic
    Jdot rather than the paper's central difference, so any robot model works): zero-phase
    low-pass and central differences for qd, qdd; torques and regressor columns low-pass filtered
    and decimated together ("parallel filtering"); the first and last ``3 / f_c`` seconds, where the
    zero-phase filters start from assumed edge values, dropped."""
    h = rec.h
    fc = pp.lowpass_cutoff_hz or 0.8 * 0.5 / (h * pp.decimation)
    return identification_regression(model, rec.t, rec.q, rec.tau, pp.lowpass_cutoff_hz, pp.decimation,
                                     decimation_cutoff_hz=fc, jdot="analytic", edge_s=3.0 / fc,
                                     min_speed=pp.min_speed_rad_s)


def build_regressions(model: RobotModel, rec: Recording, pp: PreprocessingConfig,
                      names: tuple[str, ...]) -> dict[str, Regression]:
    """The named regression models built from one recording."""
    out: dict[str, Regression] = {}
    aligned = None
    for name in names:
        if name == "inverse_dynamic":
            out[name] = inverse_dynamic_rows(model, rec, pp)
            continue
        if aligned is None:
            aligned = align(rec.q, rec.tau, rec.h, pp.pairing, t0=float(rec.t[0]))
        a = aligned
        if name == "supplied_energy":
            out[name] = reg_builders.supplied_energy(model, a.q, a.qd, a.tau, a.t)
        else:
            build = getattr(reg_builders, name)
            out[name] = build(model, a.q, a.qd, a.tau, a.t, lam=pp.lambda_rad_s, discretisation=pp.discretisation)
    return out


# ------------------------------------------------------------------------------ estimators


def prior_box(model: RobotModel, prior: PriorConfig) -> tuple[np.ndarray, np.ndarray]:
    """The prior box (center, half_width), each (p,)."""
    known = np.isfinite(model.theta_prior) & (model.theta_prior != 0)
    if prior.center == "model":
        center = np.where(np.isfinite(model.theta_prior), model.theta_prior, 0.0)
        half = np.where(known, prior.relative_range * np.abs(center), prior.absolute_range)
    else:
        center = np.zeros(model.p)
        half = np.full(model.p, prior.absolute_range)
    return center, half


def run_estimator(ec: EstimatorConfig, reg: Regression, model: RobotModel, prior: PriorConfig) -> Estimate:
    """One estimator on one regression; the Estimate's info gets the label and regression."""
    o, names, p = ec.options, model.param_names, model.p
    W, y = reg.W, reg.y
    record_every = max(1, reg.n_rows // 2000)
    t0 = time.perf_counter()
    if ec.method == "obe":
        if "e_max" not in o:
            raise StudyError(f"estimator {ec.label!r}: option e_max (the bound on |y - w^T theta|, in {reg.unit}) "
                             "is required.")
        center, half = prior_box(model, prior)
        est = OBE.from_prior(center, half, criterion=o.get("criterion", "volume"), form=o.get("form", "factorized"),
                             record_every=record_every, names=names).fit(W, y, o["e_max"])
    elif ec.method == "rls":
        est = RLS(p, np.full(p, o.get("theta0", 0.0)), o.get("P0", 1000.0), o.get("forgetting", 1.0),
                  record_every=record_every, names=names).fit(W, y)
    elif ec.method == "kalman":
        est = KalmanEstimator(p, np.full(p, o.get("theta0", 0.0)), o.get("P0", 1000.0), o.get("R", 1.0),
                              o.get("Q", 0.0), record_every=record_every, names=names).fit(W, y)
    elif ec.method == "ols":
        est = ols(W, y, level=o.get("level", 0.95), names=names)
    else:
        est = wls(W, y, reg.joint, level=o.get("level", 0.95), names=names)
    est.info.setdefault("time_s", time.perf_counter() - t0)
    est.info.update(label=ec.label, regression=reg.model)
    return est


# ------------------------------------------------------------------------------ exact optima


@dataclass
class ExactResult:
    """The exact optima of one regression's feasible polytope (with the prior box).

    truth_error_ratio: max_k |y_k - w_k^T theta_true| / e_max (simulated data; <= 1 means the bound
    really holds, so every guaranteed set must contain the truth); truth_violations: rows where it does not;
    bounds: exact LP parameter bounds (None if the data are inconsistent with the bounds);
    sdp: SDP ellipsoids by name ("outer", "inner", "john"); errors: what failed, by name
    (reported, never replaced by a wrong answer); certificates: per guaranteed estimate label.
    """

    regression: str
    e_max: float
    polytope: Polytope
    gamma_star: float
    truth_error_ratio: float = float("nan")
    truth_violations: int = 0
    bounds: object | None = None
    sdp: dict[str, SDPResult] = field(default_factory=dict)
    errors: dict[str, str] = field(default_factory=dict)
    certificates: dict = field(default_factory=dict)
    time_s: dict[str, float] = field(default_factory=dict)

    @property
    def consistent(self) -> bool:
        return self.gamma_star <= 1.0


def exact_optima(cfg: StudyConfig, reg: Regression, model: RobotModel, guaranteed: dict[str, Estimate],
                 progress: Progress) -> ExactResult:
    center, half = prior_box(model, cfg.prior)
    P = Polytope.from_strips(reg.W, reg.y, cfg.exact.e_max, box=(center - half, center + half))
    t0 = time.perf_counter()
    gamma = P.consistency().gamma
    res = ExactResult(reg.model, cfg.exact.e_max, P, gamma, time_s={"consistency": time.perf_counter() - t0})
    if cfg.experiment.source == "simulate":
        ratio = np.abs(reg.y - reg.W @ model.theta_true) / cfg.exact.e_max
        res.truth_error_ratio, res.truth_violations = float(ratio.max()), int(np.sum(ratio > 1.0))
    if not res.consistent:
        res.errors["bounds"] = (f"the data contradict the bound e_max = {cfg.exact.e_max:g} {reg.unit}: the "
                                f"smallest consistent bound is {gamma * cfg.exact.e_max:.4g} {reg.unit}")
        return res
    if cfg.exact.lp_bounds or cfg.exact.sdp:
        with progress.stage(f"{cfg.name}: exact LP bounds ({reg.n_rows} strips)"):
            t0 = time.perf_counter()
            res.bounds = P.bounds()
            res.time_s["lp_bounds"] = time.perf_counter() - t0
    solvers = {"outer": outer_ellipsoid, "inner": inner_ellipsoid, "john": john_outer}
    for name in cfg.exact.sdp:
        with progress.stage(f"{cfg.name}: SDP {name} ellipsoid"):
            t0 = time.perf_counter()
            try:
                res.sdp[name] = solvers[name](P)
            except BoundidError as exc:
                res.errors[name] = f"{type(exc).__name__}: {exc}"
            res.time_s[f"sdp_{name}"] = time.perf_counter() - t0
    have_volumes = "outer" in res.sdp and "inner" in res.sdp
    for label, est in guaranteed.items():
        res.certificates[label] = validate(est, P, outer=res.sdp.get("outer"), inner=res.sdp.get("inner"),
                                           volumes=have_volumes)
    return res


# ------------------------------------------------------------------------------ the study


@dataclass
class StudyResult:
    """Everything a study run produced; ``table`` is the tidy results table; ``failures`` holds
    the estimators that failed (e.g. the standard-form OBE losing positive definiteness), with
    the reason, for the report: a failure is shown, never replaced by another answer."""

    config: StudyConfig
    model: RobotModel
    data: StudyData
    regressions: dict[str, Regression]
    estimates: dict[tuple[str, str], Estimate]
    failures: dict[tuple[str, str], str]
    exact: ExactResult | None
    validation: dict
    table: pd.DataFrame
    timings: dict[str, float]


def tidy_table(cfg: StudyConfig, model: RobotModel, estimates: dict[tuple[str, str], Estimate],
               exact: ExactResult | None) -> pd.DataFrame:
    """One row per estimator x regression x parameter: centre, lo, hi, truth, prior, kind."""
    rows = []
    for (label, regname), est in estimates.items():
        lo, hi = est.intervals
        for j, name in enumerate(model.param_names):
            rows.append({"study": cfg.name, "estimator": label, "method": est.method, "regression": regname,
                         "parameter": name, "unit": model.param_units[j], "center": est.center[j], "lo": lo[j],
                         "hi": hi[j], "truth": model.theta_true[j], "prior": model.theta_prior[j],
                         "kind": est.kind, "level": est.level})
    if exact is not None and exact.bounds is not None:
        b = exact.bounds
        for j, name in enumerate(model.param_names):
            rows.append({"study": cfg.name, "estimator": "LP exact", "method": "LP", "regression": exact.regression,
                         "parameter": name, "unit": model.param_units[j], "center": 0.5 * (b.lo[j] + b.hi[j]),
                         "lo": b.lo[j], "hi": b.hi[j], "truth": model.theta_true[j], "prior": model.theta_prior[j],
                         "kind": "exact", "level": None})
    return pd.DataFrame(rows)


def run_study(cfg: StudyConfig, progress: Progress = QUIET) -> StudyResult:
    """Run every stage of a study; nothing is written (see :mod:`boundid.report.study_page`)."""
    timings: dict[str, float] = {}
    rng = np.random.default_rng(cfg.seed)
    model = make_robot(cfg.robot, cfg.robot_options)

    t0 = time.perf_counter()
    with progress.stage(f"{cfg.name}: simulate and measure"):
        data = acquire(cfg, model, rng)
    timings["data"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    with progress.stage(f"{cfg.name}: regressions"):
        regressions = build_regressions(model, data.recording, cfg.preprocessing, cfg.regressions)
    timings["regressions"] = time.perf_counter() - t0

    estimates: dict[tuple[str, str], Estimate] = {}
    failures: dict[tuple[str, str], str] = {}
    t0 = time.perf_counter()
    for ec in cfg.estimators:
        for regname in ec.regressions:
            with progress.stage(f"{cfg.name}: {ec.label} on {regname}"):
                try:
                    estimates[(ec.label, regname)] = run_estimator(ec, regressions[regname], model, cfg.prior)
                except (SolverError, InfeasibleDataError) as exc:
                    failures[(ec.label, regname)] = f"{type(exc).__name__}: {exc}"
    timings["estimators"] = time.perf_counter() - t0

    exact = None
    if cfg.exact.regression is not None:
        t0 = time.perf_counter()
        guaranteed = {lab: e for (lab, rn), e in estimates.items() if rn == cfg.exact.regression and e.guaranteed}
        exact = exact_optima(cfg, regressions[cfg.exact.regression], model, guaranteed, progress)
        timings["exact"] = time.perf_counter() - t0

    from boundid.studies.validation import validate_study

    t0 = time.perf_counter()
    with progress.stage(f"{cfg.name}: validation"):
        validation = validate_study(cfg, model, data, estimates)
    timings["validation"] = time.perf_counter() - t0
    return StudyResult(cfg, model, data, regressions, estimates, failures, exact, validation,
                       tidy_table(cfg, model, estimates, exact), timings)
