"""Running a study: data -> regressions -> estimators -> exact optima -> validation -> tidy table."""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
import pandas as pd

from boundid.errors import RUN_FAILURES
from boundid.estimators import Estimate
from boundid.estimators.certify import validate
from boundid.experiments.regression import Regression
from boundid.models import RobotModel
from boundid.sets import OutlierCount, Polytope, RelaxedBounds, SDPResult, min_outliers, relaxed_bounds
from boundid.sets.sdp import VolumeBracket, min_volume_bracket, polytope_ellipsoids
from boundid.studies.bounds import BoundRule, GammaStar, gamma_star
from boundid.studies.config import StudyConfig, prior_box
from boundid.studies.data import StudyData, acquire
from boundid.studies.estimation import run_estimator
from boundid.studies.excitation import ExcitationDesign, design_excitation
from boundid.studies.paper_experiments import paper_experiments
from boundid.studies.physical_stage import PhysicalResult, physical_stage
from boundid.studies.progress import QUIET, Progress
from boundid.studies.published import PublishedComparison, compare_published
from boundid.studies.registry import make_robot
from boundid.studies.regressions import build_regressions
from boundid.studies.validation import validate_study

#: seconds HiGHS may spend on the minimum-outlier MILP of a run whose data contradict the bound
OUTLIER_TIME_LIMIT_S = 10.0
#: seconds HiGHS may spend on each of the 2p MILPs of the q-relaxed bounds ([exact] relaxed_q)
RELAXED_TIME_LIMIT_S = 5.0


@dataclass
class ExactResult:
    """The exact optima of one regression's feasible polytope (with the prior box).

    regression: its name; e_max: the bound on its rows, one number or (N,) per row, in the
    regression's unit; polytope: the feasible polytope; gamma_star: the smallest factor of e_max
    (row by row) some parameter vector of the prior box satisfies on every row (<= 1: the data respect
    the bound); evidence: gamma* in the regression's unit three ways
    (:class:`boundid.studies.bounds.GammaStar`, computed for a rule and for measured data, else
    None); rule: the bound rule, if any;
    outliers: the minimum number of rows to drop when the data contradict the bound;
    truth_error_ratio: max_k |y_k - w_k^T theta_true| / e_max (simulated data; <= 1 means the bound
    really holds, so every guaranteed set must contain the truth); truth_violations: rows where it does not;
    bounds: exact LP parameter bounds (None if the data are inconsistent with the bounds);
    sdp: SDP ellipsoids by name ("outer", "inner", "john"); errors: what failed, by name
    (reported, never replaced by a wrong answer); certificates: per set-membership estimate label
    (guaranteed or unverified: an unverified set is certified too); physical: the physically
    consistent exact bounds beside the plain ones (:mod:`boundid.studies.physical_stage`; None when
    the robot states no physical constraints or the LP bounds failed); bracket: ln vol of the
    minimum-volume outer ellipsoid bracketed (:func:`boundid.sets.sdp.min_volume_bracket`; None
    without the outer and inner SDPs); relaxed: the bounds of the parameters that violate at most
    [exact] relaxed_q rows (:func:`boundid.sets.relaxed_bounds`; None when not asked).
    """

    regression: str
    e_max: float | np.ndarray
    polytope: Polytope
    gamma_star: float
    truth_error_ratio: float = float("nan")
    truth_violations: int = 0
    bounds: object | None = None
    sdp: dict[str, SDPResult] = field(default_factory=dict)
    errors: dict[str, str] = field(default_factory=dict)
    certificates: dict = field(default_factory=dict)
    time_s: dict[str, float] = field(default_factory=dict)
    physical: PhysicalResult | None = None
    bracket: VolumeBracket | None = None
    evidence: GammaStar | None = None
    rule: BoundRule | None = None
    outliers: OutlierCount | None = None
    relaxed: RelaxedBounds | None = None
    unit: str = ""
    row_joint: np.ndarray | None = None

    @property
    def consistent(self) -> bool:
        """Whether the data respect the bound (False also when the consistency LP failed: gamma* NaN)."""
        return self.gamma_star <= 1.0

    def bound_text(self) -> str:
        """The bound in words: "0.5 N m", or the per-row bounds of a rule ("0.37 N m (2 x gamma*, one
        bound on every row)"; per joint "0.30, 0.41, 0.27 N m by joint (...)")."""
        e = np.atleast_1d(np.asarray(self.e_max, float))
        if np.ptp(e) == 0 or self.row_joint is None:
            value = f"{e[0]:.4g} {self.unit}".strip()
        else:
            per = [e[self.row_joint == g][0] for g in np.unique(self.row_joint)]
            value = f"{', '.join(f'{v:.4g}' for v in per)} {self.unit} by joint".strip()
        return value if self.rule is None else f"{value} ({self.rule.describe()})"


def _reason(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def _unfiltered_hint(cfg: StudyConfig, reg: Regression) -> str:
    """The likelier fix than a larger bound when inverse dynamic rows come from unfiltered angles."""
    if reg.model != "inverse_dynamic" or cfg.preprocessing.lowpass_cutoff_hz is not None:
        return ""
    return ("; these inverse dynamic rows differentiate the angles twice without a low-pass filter, which "
            "amplifies the encoder's steps into qdd: set [preprocessing] lowpass_cutoff_hz (a few times the "
            "motion's bandwidth) before enlarging e_max")


def exact_bound(cfg: StudyConfig, reg: Regression, model: RobotModel) -> tuple[float | np.ndarray,
                                                                                 GammaStar | None]:
    """The exact regression's bound: [exact] e_max, or its rule's per-row bounds (N,), and gamma*
    three ways (:func:`boundid.studies.bounds.gamma_star`; computed for a rule and for measured
    data, whose verdict states it; None for simulated data with a number)."""
    e_max = cfg.exact.e_max
    if isinstance(e_max, tuple):  # one bound per joint: each row takes its joint's
        e_max = np.asarray(e_max, dtype=float)[reg.joint]
    if cfg.exact.e_max_rule is None and cfg.experiment.source == "simulate":
        return e_max, None
    center, half = prior_box(model, cfg.prior)
    evidence = gamma_star(reg, (center - half, center + half))
    if cfg.exact.e_max_rule is None:
        return e_max, evidence
    return cfg.exact.e_max_rule.rows(evidence, reg.joint), evidence


def _relaxed(cfg: StudyConfig, reg: Regression, res: ExactResult, box, progress: Progress) -> None:
    """[exact] relaxed_q: the q-relaxed bounds at the run's bound into ``res.relaxed`` (or its failure
    into ``res.errors``)."""
    q = cfg.exact.relaxed_q
    if q is None:
        return
    with progress.stage(f"{cfg.name}: bounds with at most {q} outliers ({2 * reg.W.shape[1]} MILPs)"):
        t0 = time.perf_counter()
        try:
            res.relaxed = relaxed_bounds(reg.W, reg.y, res.e_max, box, min(q, reg.n_rows),
                                         time_limit=RELAXED_TIME_LIMIT_S)
        except RUN_FAILURES as exc:
            res.errors["relaxed bounds"] = _reason(exc)
        res.time_s["relaxed_bounds"] = time.perf_counter() - t0


def exact_optima(cfg: StudyConfig, reg: Regression, model: RobotModel, set_estimates: dict[str, Estimate],
                 progress: Progress, e_max: float | np.ndarray | None = None,
                 evidence: GammaStar | None = None) -> ExactResult:
    """The exact optima of ``reg``'s polytope with bound ``e_max`` (default :func:`exact_bound`'s:
    [exact] e_max, per row for one per joint or a rule); a step that fails (LP, SDP, certificate) is
    recorded in ``errors`` by name and the others go on. When the data contradict the bound, the
    minimum number of rows to drop (:func:`boundid.sets.min_outliers`) is computed instead of the
    bounds."""
    e_max = exact_bound(cfg, reg, model)[0] if e_max is None else e_max
    center, half = prior_box(model, cfg.prior)
    box = (center - half, center + half)
    P = Polytope.from_strips(reg.W, reg.y, e_max, box=box)
    t0 = time.perf_counter()
    try:
        gamma, failed = P.consistency().gamma, None
    except RUN_FAILURES as exc:
        gamma, failed = float("nan"), _reason(exc)
    res = ExactResult(reg.model, e_max, P, gamma, time_s={"consistency": time.perf_counter() - t0},
                      evidence=evidence, rule=cfg.exact.e_max_rule, unit=reg.unit, row_joint=reg.joint)
    if cfg.experiment.source == "simulate":
        ratio = np.abs(reg.y - reg.W @ model.theta_true) / e_max
        res.truth_error_ratio, res.truth_violations = float(ratio.max()), int(np.sum(ratio > 1.0))
    if failed is not None:
        res.errors["consistency"] = failed
        return res
    if not res.consistent:
        res.errors["bounds"] = (f"the data contradict the bound e_max = {res.bound_text()}: the bounds must grow by "
                                f"a factor {gamma:.4g} for any parameter vector of the prior box to satisfy every row"
                                + _unfiltered_hint(cfg, reg))
        with progress.stage(f"{cfg.name}: minimum number of outliers ({reg.n_rows} rows)"):
            try:
                res.outliers = min_outliers(reg.W, reg.y, e_max, box, time_limit=OUTLIER_TIME_LIMIT_S)
            except RUN_FAILURES as exc:
                res.errors["outliers"] = _reason(exc)
        _relaxed(cfg, reg, res, box, progress)
        return res
    if cfg.exact.lp_bounds or cfg.exact.sdp:
        with progress.stage(f"{cfg.name}: exact LP bounds ({reg.n_rows} strips)"):
            t0 = time.perf_counter()
            try:
                res.bounds = P.bounds()
            except RUN_FAILURES as exc:
                res.errors["bounds"] = _reason(exc)
            res.time_s["lp_bounds"] = time.perf_counter() - t0
    _relaxed(cfg, reg, res, box, progress)
    if cfg.exact.sdp:
        with progress.stage(f"{cfg.name}: SDP {', '.join(cfg.exact.sdp)} ellipsoids"):
            for name, (out, seconds) in polytope_ellipsoids(P, cfg.exact.sdp).items():
                if isinstance(out, RUN_FAILURES):
                    res.errors[name] = _reason(out)
                elif isinstance(out, Exception):
                    raise out
                else:
                    res.sdp[name] = out
                res.time_s[f"sdp_{name}"] = seconds
    have_volumes = "outer" in res.sdp and "inner" in res.sdp
    if have_volumes and cfg.exact.volume_bracket:
        with progress.stage(f"{cfg.name}: bracket of the minimum-volume outer ellipsoid"):
            t0 = time.perf_counter()
            try:
                res.bracket = min_volume_bracket(P)
            except RUN_FAILURES as exc:
                res.errors["volume bracket"] = _reason(exc)
            res.time_s["volume_bracket"] = time.perf_counter() - t0
    for label, est in set_estimates.items():
        try:
            res.certificates[label] = validate(est, P, outer=res.sdp.get("outer"), inner=res.sdp.get("inner"),
                                               bracket=res.bracket, volumes=have_volumes)
        except RUN_FAILURES as exc:
            res.errors[f"certificate of {label}"] = _reason(exc)
    return res


# ------------------------------------------------------------------------------ the study


class Failure(NamedTuple):
    """A stage of a run that failed: stage ("estimator", "exact optima", "validation", "figure" ...),
    subject (e.g. "OBE-standard / filtered_dynamic") and the reason (exception type and message)."""

    stage: str
    subject: str
    reason: str


@dataclass
class StudyResult:
    """Everything a study run produced; ``table`` is the tidy results table; ``failures`` holds
    the stages that failed (e.g. the standard-form OBE losing positive definiteness, a
    re-simulation that diverges), with the reason, for the report: a failure is shown, never
    replaced by another answer, and the rest of the run goes on."""

    config: StudyConfig
    model: RobotModel
    data: StudyData
    regressions: dict[str, Regression]
    estimates: dict[tuple[str, str], Estimate]
    failures: list[Failure]
    exact: ExactResult | None
    validation: dict
    table: pd.DataFrame
    timings: dict[str, float]
    published: PublishedComparison | None = None
    #: the excitation search, when [experiment] excitation designs the identification run's excitation
    design: ExcitationDesign | None = None


def reference_values(cfg: StudyConfig, model: RobotModel) -> tuple[np.ndarray, str] | None:
    """(values (p,), name) a run is compared with: the simulator's parameters for simulated data; for
    measured data the study file's reference values ([paper] reference_values = {name = value}),
    NaN for a parameter it does not list; None when there are none (never the prior)."""
    if cfg.experiment.source == "simulate":
        return model.theta_true, "truth"
    ref = cfg.paper.get("reference_values")
    if not ref:
        return None
    return np.array([float(ref.get(n, np.nan)) for n in model.param_names]), "reference values (study file)"


def tidy_table(cfg: StudyConfig, model: RobotModel, estimates: dict[tuple[str, str], Estimate],
               exact: ExactResult | None) -> pd.DataFrame:
    """One row per estimator x regression x parameter: centre, lo, hi, truth, prior (the prior box's
    centre), kind, and containments. ``truth`` is the simulator's value, or for measured data the study
    file's reference value where it lists one (NaN otherwise: never the prior):

    truth_in_interval : lo_j <= truth_j <= hi_j for this parameter (NA without a truth value)
    truth_in_set : theta_true lies in the estimate's set -- its guaranteed or confidence set, of
        any family, or the exact polytope for "LP exact"; NA for a point estimate (no set) and for
        measured data (no whole true vector)
    truth_in_all_intervals : lo_j <= theta_true_j <= hi_j for every parameter j, i.e. theta_true lies
        in the set's bounding box (NA for measured data). Implied by truth_in_set, not the converse: a
        truth in a corner of the box, outside the ellipsoid, has True here and False there.
    """
    known = cfg.experiment.source == "simulate"
    prior_center = prior_box(model, cfg.prior)[0]
    ref = reference_values(cfg, model)
    truth = np.full(model.p, np.nan) if ref is None else ref[0]
    sets = []  # (label, method, regression, kind, centre, (lo, hi), truth in set, level)
    for (label, regname), est in estimates.items():
        in_set = est.contains(truth) if est.set is not None and known else pd.NA
        sets.append((label, est.method, regname, est.kind, est.center, est.intervals, in_set, est.level))
    if exact is not None and exact.bounds is not None:
        b = exact.bounds
        sets.append(("LP exact", "LP", exact.regression, "exact", 0.5 * (b.lo + b.hi), (b.lo, b.hi),
                     bool(exact.polytope.contains(truth)) if known else pd.NA, None))
    rows = []
    for label, method, regname, kind, center, (lo, hi), in_set, level in sets:
        in_box = bool(np.all((lo <= truth) & (truth <= hi))) if known else pd.NA
        for j, name in enumerate(model.param_names):
            inside = bool(lo[j] <= truth[j] <= hi[j]) if np.isfinite(truth[j]) else pd.NA
            rows.append({"study": cfg.name, "estimator": label, "method": method, "regression": regname,
                         "parameter": name, "unit": model.param_units[j], "center": center[j], "lo": lo[j],
                         "hi": hi[j], "truth": truth[j], "prior": prior_center[j], "kind": kind,
                         "level": level, "truth_in_interval": inside, "truth_in_set": in_set,
                         "truth_in_all_intervals": in_box})
    table = pd.DataFrame(rows)
    for col in ("truth_in_interval", "truth_in_set", "truth_in_all_intervals"):
        if col in table:
            table[col] = table[col].astype("boolean")
    return table


def _published(cfg: StudyConfig, model: RobotModel, exact: ExactResult | None,
               estimates: dict[tuple[str, str], Estimate]) -> PublishedComparison:
    """The study's published tables against the exact polytope (when the data respect the bound), the
    physically consistent intervals and the centres of the estimates on the exact regression
    (:func:`boundid.studies.published.compare_published`)."""
    usable = exact is not None and exact.bounds is not None
    regname = exact.regression if exact is not None else None
    centers = {lab: e.center for (lab, rn), e in estimates.items() if rn == regname or regname is None}
    physical = exact.physical.intervals if usable and exact.physical is not None else None
    return compare_published(cfg.published, model, exact.polytope if usable else None, physical, centers)


def _validation_bounds(cfg: StudyConfig, exact: ExactResult | None, bound_of: dict, regressions: dict,
                       n_joints: int) -> tuple[Polytope | None, dict[str, np.ndarray]]:
    """What the cross-validation bands need from the exact stage: the feasible polytope of the inverse
    dynamic rows (None unless that is the exact regression and its data respect the bound) and each
    set-membership band's bound per joint (n,): a number for every joint, or a per-row bound of the
    exact regression's rows (a rule's) read per joint."""
    out = {}
    for label, e in [*bound_of.items(), *([("LP exact", exact.e_max)] if exact is not None else [])]:
        e = np.asarray(e, dtype=float)
        if e.ndim == 0:
            out[label] = np.full(n_joints, float(e))
        elif exact is not None:
            joint = regressions[exact.regression].joint
            out[label] = np.array([e[joint == j].max() if np.any(joint == j) else np.nan for j in range(n_joints)])
    usable = (exact is not None and exact.regression == "inverse_dynamic" and exact.bounds is not None)
    return (exact.polytope if usable else None), out


def run_study(cfg: StudyConfig, progress: Progress = QUIET) -> StudyResult:
    """Run every stage of a study; nothing is written (see :mod:`boundid.report.study_page`)."""
    timings: dict[str, float] = {}
    rng = np.random.default_rng(cfg.seed)
    model = make_robot(cfg.robot, cfg.robot_options)

    design = None
    if cfg.experiment.excitation != "default":
        t0 = time.perf_counter()
        with progress.stage(f"{cfg.name}: design the excitation ({cfg.experiment.design.candidates} candidates)"):
            design = design_excitation(cfg, model)
        timings["design"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    with progress.stage(f"{cfg.name}: " + ("read the recording" if cfg.experiment.source == "measured"
                                           else "simulate and measure")):
        data = acquire(cfg, model, rng, design.excitation if design is not None else None)
    timings["data"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    with progress.stage(f"{cfg.name}: regressions"):
        regressions = build_regressions(model, data.recording, cfg.preprocessing, cfg.regressions)
    timings["regressions"] = time.perf_counter() - t0

    failures: list[Failure] = []
    bound, evidence = None, None  # the exact regression's bound, and gamma* (when computed)
    if cfg.exact.regression is not None:
        t0 = time.perf_counter()
        with progress.stage(f"{cfg.name}: gamma*, the smallest bound the data allow"):
            try:
                bound, evidence = exact_bound(cfg, regressions[cfg.exact.regression], model)
            except RUN_FAILURES as exc:
                failures.append(Failure("exact optima", "gamma*", _reason(exc)))
        timings["gamma_star"] = time.perf_counter() - t0

    estimates: dict[tuple[str, str], Estimate] = {}
    bound_of: dict[str, float | np.ndarray] = {}  # each set-membership estimator's bound (scalar or per row)
    t0 = time.perf_counter()
    for ec in cfg.estimators:
        if ec.bound_from_exact:
            if bound is None:
                failures.append(Failure("estimator", ec.label, "no bound: gamma* of the exact regression failed"))
                continue
            ec = replace(ec, e_max=bound)
        if ec.e_max is not None:
            bound_of[ec.label] = ec.e_max
        for regname in ec.regressions:
            with progress.stage(f"{cfg.name}: {ec.label} on {regname}"):
                try:
                    estimates[(ec.label, regname)] = run_estimator(ec, regressions[regname], model, cfg.prior)
                except RUN_FAILURES as exc:
                    failures.append(Failure("estimator", f"{ec.label} / {regname}", _reason(exc)))
    timings["estimators"] = time.perf_counter() - t0

    exact = None
    if cfg.exact.regression is not None and bound is not None:
        t0 = time.perf_counter()
        sets = {lab: e for (lab, rn), e in estimates.items() if rn == cfg.exact.regression and e.set_membership}
        try:
            exact = exact_optima(cfg, regressions[cfg.exact.regression], model, sets, progress, bound, evidence)
        except RUN_FAILURES as exc:
            failures.append(Failure("exact optima", cfg.exact.regression, _reason(exc)))
        else:
            failures += [Failure("exact optima", what, msg) for what, msg in exact.errors.items()]
        timings["exact"] = time.perf_counter() - t0
        constraints = model.physical_constraints()
        if exact is not None and exact.bounds is not None and constraints is not None:
            t0 = time.perf_counter()
            with progress.stage(f"{cfg.name}: physically consistent bounds"):
                on_exact = {lab: e for (lab, rn), e in estimates.items() if rn == cfg.exact.regression}
                truth = model.theta_true if cfg.experiment.source == "simulate" else None
                try:
                    exact.physical = physical_stage(exact.polytope, constraints, model.param_names, on_exact, truth)
                except RUN_FAILURES as exc:
                    failures.append(Failure("physical consistency", cfg.exact.regression, _reason(exc)))
                else:
                    if exact.physical.error is not None:
                        failures.append(Failure("physical consistency", cfg.exact.regression, exact.physical.error))
            timings["physical"] = time.perf_counter() - t0

    published = None
    if cfg.published:
        t0 = time.perf_counter()
        with progress.stage(f"{cfg.name}: published values against the data"):
            published = _published(cfg, model, exact, estimates)
        timings["published"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    with progress.stage(f"{cfg.name}: validation"):
        polytope, error_bounds = _validation_bounds(cfg, exact, bound_of, regressions, model.n_joints)
        try:
            validation = validate_study(cfg, model, data, estimates, polytope, error_bounds)
        except RUN_FAILURES as exc:
            validation = {}
            failures.append(Failure("validation", "cross-validation trajectory", _reason(exc)))
    failures += [Failure("re-simulation", rs.label, rs.failure) for rs in validation.get("resimulation", [])
                 if rs.failure is not None]
    timings["validation"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    with progress.stage(f"{cfg.name}: the paper's own experiments"):
        try:
            validation["paper"] = paper_experiments(cfg, model, data, regressions)
        except RUN_FAILURES as exc:
            failures.append(Failure("validation", "the paper's own experiments", _reason(exc)))
    timings["paper"] = time.perf_counter() - t0
    return StudyResult(cfg, model, data, regressions, estimates, failures, exact, validation,
                       tidy_table(cfg, model, estimates, exact), timings, published, design)
