"""Where does the standard-form OBE break down on a study's problem?

[H4Paper] (sections III.A-B) applies the OBE in its factorized (square-root information, QR) form
"in order to guarantee numerical stability": the standard form of its eq. (30), which keeps M^-1
by Sherman-Morrison downdates, "is potentially numerically unstable" because the information
matrix "may become non definite positive". :func:`standard_form_stability` puts that claim to the
test on the study's own data: it refits the study's two OBE forms (standard and factorized, the
same weight criterion, bound e_max and prior box) under a small grid of :class:`Condition`\\ s
and records, per condition and form, whether the fit broke down and how, with the differences
between the two forms where both finished. Every row is a fit, nothing is asserted.

The conditions vary what could make the standard form lose positive definiteness:

* the rows: the study's own rows (low-pass + decimation, the paper's "parallel filtering"); every
  sample of the recording, parallel-filtered at the study's cut-off but not decimated (ten times
  the rows at decimation 10, strongly correlated); every sample at decimation 1 as the pipeline
  builds it (no parallel filter at all, so the torque noise and ripple stay in the rows);
* the prior: the prior box's half-widths times a factor (same centre), the OBE starting from the
  ellipsoid circumscribing it. A step that shrinks the ellipsoid along a row by a factor rho loses
  about log10(rho) digits of M^-1 in the standard form (:mod:`boundid.estimators.obe`), so a wide
  prior met by informative rows is the classic way to break it;
* the length: the rows repeated k times (a longer run on the same excitation, without the cost of
  simulating one).

Single precision is not in the grid: the compiled recursion is written for float64; running it on
float32 arrays compiles a second version of it (seconds of compilation on first use) that still
computes partly in float64, and whose rounding bound, written for the float64 unit roundoff,
would not hold, so neither its arithmetic nor its "guaranteed" would be honest single precision.

What counts as a breakdown is what :func:`boundid.studies.validation.obe_breakdown_sweep` counts
(the estimator raises one of :data:`boundid.errors.RUN_FAILURES`, or ends "unverified"), split by
cause, plus a guaranteed set that misses the simulated truth where the truth satisfies the bound
on those rows (where it does not, missing it is the bound's fault, not the arithmetic's, and is
not counted).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from boundid.errors import RUN_FAILURES, StudyError
from boundid.estimators import Estimate
from boundid.estimators.obe import OBE
from boundid.experiments.preprocessing import DECIMATION_ORDER, differentiate, torque_at_samples, zero_phase_lowpass
from boundid.experiments.regression import Regression, stack_joint_rows
from boundid.models import RobotModel
from boundid.studies.config import EstimatorConfig, PriorConfig, StudyConfig
from boundid.studies.data import StudyData
from boundid.studies.estimation import estimation_problem

FORMS = ("standard", "factorized")
#: the row sets a condition may use (see the module docstring)
ROWS = ("study", "full_rate_filtered", "full_rate_unfiltered")
#: the breakdown causes a row may report (None: no breakdown)
FAILURES = ("raised", "lost positive definiteness", "unverified", "misses the truth")


@dataclass(frozen=True)
class Condition:
    """One refit: ``rows`` one of :data:`ROWS`; the prior box's half-widths times ``prior_factor``
    (same centre); the rows repeated ``repeat`` times."""

    rows: str = "study"
    prior_factor: float = 1.0
    repeat: int = 1

    def label(self, decimation: int, fs_hz: float) -> str:
        rows = {"study": f"study rows (decimation {decimation})",
                "full_rate_filtered": f"{fs_hz:g} Hz rows, parallel-filtered, not decimated",
                "full_rate_unfiltered": f"{fs_hz:g} Hz rows, decimation 1 (no parallel filter)"}[self.rows]
        parts = [rows]
        if self.prior_factor != 1.0:
            parts.append(f"prior x {self.prior_factor:.0e}")
        if self.repeat != 1:
            parts.append(f"rows repeated x {self.repeat}")
        return "; ".join(parts)

    @property
    def is_study(self) -> bool:
        """The study's own setting."""
        return self.rows == "study" and self.prior_factor == 1.0 and self.repeat == 1


#: The grid for the H4 study, chosen by experiment to show the boundary: on the study's rows the
#: standard form held up to the prior x 2e10 and broke from x 3e10 on, whatever the row count (the
#: parallel-filtered 1 kHz rows, and the study's rows repeated 10, 30 and 100 times, broke at the same
#: factor); the unfiltered 1 kHz rows broke from x 1e9 (held at x 1e8). About 1.5 s on the H4
#: study on 2 cores (most of it the fits of the repeated rows and building the 1 kHz rows).
DEFAULT_CONDITIONS = (
    Condition(),
    Condition(prior_factor=1e3),
    Condition(prior_factor=1e6),
    Condition(prior_factor=1e9),
    Condition(prior_factor=1e10),
    Condition(prior_factor=1e11),
    Condition("full_rate_filtered"),
    Condition("full_rate_filtered", prior_factor=1e10),
    Condition("full_rate_filtered", prior_factor=1e11),
    Condition("full_rate_unfiltered"),
    Condition("full_rate_unfiltered", prior_factor=1e8),
    Condition("full_rate_unfiltered", prior_factor=1e9),
    Condition(repeat=30),
    Condition(repeat=30, prior_factor=1e10),
)


@dataclass
class StabilityRow:
    """One form's fit under one condition.

    condition : the condition's label;  spec : the :class:`Condition`;  form : "standard" | "factorized"
    n_rows : rows the estimator processed (repetitions included; where it raised, up to the end of the
        pass over the rows in which it did)
    broke : whether the fit broke down;  failure : its cause, one of :data:`FAILURES`, or None
    detail : the estimator's message (the exception, or ``unverified_reason``), or None
    kind : the Estimate's kind ("guaranteed" | "unverified"), None when it raised
    n_breakdowns : rows where the state proved indefinite (standard: M^-1; factorized: X singular)
    error_bound : the estimator's first-order bound on the rounding error of the Mahalanobis^2 of a
        point of its set (dimensionless; "guaranteed" needs <= 1e-4), NaN when it raised
    shrink : max over parameters of the prior ellipsoid's half-width / the set's half-width
        (dimensionless): how far the data shrank the prior, the quantity that costs the standard
        form digits; NaN when it raised
    truth_ratio : max |y - w^T theta_true| / e_max over the rows (<= 1: the truth satisfies the
        bound, so a guaranteed set must contain it); NaN without a simulated truth
    truth_in_set : whether the set contains theta_true (None without a truth or a set)
    center_diff : max_j |c_std_j - c_fac_j| / sqrt(S_fac_jj), the centres' largest difference in
        units of the factorized set's half-width along parameter j (NaN unless both forms finished)
    shape_diff : max_ab |S_std_ab - S_fac_ab| / sqrt(S_fac_aa S_fac_bb), the shape matrices' largest
        difference relative to the factorized set's own scale (NaN unless both finished)
    time_s : wall time of the fit [s]
    """

    condition: str
    spec: Condition
    form: str
    n_rows: int
    broke: bool
    failure: str | None
    detail: str | None
    kind: str | None
    n_breakdowns: int
    error_bound: float
    shrink: float
    truth_ratio: float
    truth_in_set: bool | None
    center_diff: float = float("nan")
    shape_diff: float = float("nan")
    time_s: float = float("nan")


@dataclass
class StabilityTable:
    """What :func:`standard_form_stability` found: ``rows`` (two per condition, standard first),
    ``statement`` (one line on the paper's claim), ``skipped`` (condition label -> why it was not
    run), ``time_s`` (the whole table, row building included) [s]."""

    rows: list[StabilityRow]
    statement: str
    skipped: dict[str, str] = field(default_factory=dict)
    time_s: float = float("nan")

    def frame(self) -> pd.DataFrame:
        """The rows as a DataFrame (one column per :class:`StabilityRow` field but ``spec``, whose
        fields become the columns rows, prior_factor and repeat)."""
        out = []
        for r in self.rows:
            d = {k: v for k, v in r.__dict__.items() if k != "spec"}
            d.update(rows=r.spec.rows, prior_factor=r.spec.prior_factor, repeat=r.spec.repeat)
            out.append(d)
        return pd.DataFrame(out)

    def text(self) -> str:
        """A plain-text table (the report's, or a terminal's): outcome the failure or the kind,
        err.bound, shrink, dc (center_diff), dS (shape_diff), truth r (truth_ratio), in
        (truth_in_set), t [s] (time_s) as in :class:`StabilityRow`; the statement last."""
        head = (f"{'condition':<62} {'form':<10} {'rows':>7} {'outcome':<27} {'err.bound':>9} {'shrink':>8} "
                f"{'dc':>8} {'dS':>8} {'truth r':>7} {'in':>3} {'t [s]':>6}")
        lines = [head, "-" * len(head)]
        for r in self.rows:
            outcome = r.failure or r.kind or ""
            inside = {True: "yes", False: "no", None: "-"}[r.truth_in_set]
            lines.append(f"{r.condition:<62} {r.form:<10} {r.n_rows:>7d} {outcome:<27} {r.error_bound:>9.2g} "
                         f"{r.shrink:>8.2g} {r.center_diff:>8.1e} {r.shape_diff:>8.1e} {r.truth_ratio:>7.2f} "
                         f"{inside:>3} {r.time_s:>6.3f}")
        lines.append(self.statement)
        return "\n".join(lines)


def _form_configs(cfg: StudyConfig, regression: str, e_max: float | None) -> dict[str, EstimatorConfig]:
    """The study's OBE estimator of each form on ``regression``; a form the study does not run is
    the other's with only ``form`` changed (same criterion, bound and options)."""
    obes = [ec for ec in cfg.estimators if ec.method == "obe" and regression in ec.regressions]
    if not obes:
        raise StudyError(f"study {cfg.name!r} runs no OBE estimator on the {regression!r} regression.")
    out = {}
    for form in FORMS:
        mine = [ec for ec in obes if ec.options.form == form]
        ec = mine[0] if mine else replace(obes[0], label=f"OBE-{form}", options=replace(obes[0].options, form=form))
        if e_max is not None:
            ec = replace(ec, e_max=e_max)
        if ec.e_max is None:
            raise StudyError(f"estimator {ec.label!r} takes its bound from [exact]: pass e_max (the bound the run "
                             "used) to standard_form_stability.")
        out[form] = ec
    return out


def full_rate_rows(model: RobotModel, data: StudyData, cfg: StudyConfig) -> tuple[Regression, Regression]:
    """The inverse dynamic rows of every sample of the identification recording, as the study's
    pipeline (:func:`boundid.studies.regressions.inverse_dynamic_rows`) builds them but without
    the decimation: (parallel-filtered: torques and regressor columns low-passed at the study's
    decimation cut-off, every sample kept; decimation 1: no parallel filter, the pipeline's rows at
    ``decimation = 1``). Both (S n, p) with the edges the study drops dropped; the first one's
    every ``decimation``-th sample is the study's own rows. Needs ``min_speed_rad_s = 0``."""
    rec, pp = data.recording, cfg.preprocessing
    tau = torque_at_samples(rec.tau, pp.torque_timing)  # as the study's rows time it
    h = rec.h
    fs = 1.0 / h
    fc = pp.lowpass_cutoff_hz or 0.8 * 0.5 / (h * pp.decimation)
    qf, qd, qdd = differentiate(rec.q, h, pp.lowpass_cutoff_hz)
    Y = model.regressor(qf, qd, qdd)
    N, n, p = Y.shape
    Yf = zero_phase_lowpass(Y.reshape(N, n * p), fc, fs, DECIMATION_ORDER).reshape(N, n, p)
    tauf = zero_phase_lowpass(tau, fc, fs, DECIMATION_ORDER)
    edge = 3.0 / fc
    keep = (rec.t >= rec.t[0] + edge) & (rec.t <= rec.t[-1] - edge)
    info = {"cutoff_hz": pp.lowpass_cutoff_hz, "decimation": 1, "fs_hz": fs}
    filtered = stack_joint_rows(Yf[keep], tauf[keep], rec.t[keep], "inverse_dynamic", model.param_names,
                                info=dict(info, decimation_cutoff_hz=fc))
    unfiltered = stack_joint_rows(Y[keep], tau[keep], rec.t[keep], "inverse_dynamic", model.param_names,
                                  info=info)
    return filtered, unfiltered


def _fit(ec: EstimatorConfig, W: np.ndarray, y: np.ndarray, e: np.ndarray, repeat: int,
         problem) -> tuple[OBE, Estimate | None, str | None]:
    """The study's OBE (built as the registry's ``obe`` entry builds it for
    :func:`boundid.studies.estimation.run_estimator`) on the rows W (N, p), y (N,), bounds e (N,),
    fed ``repeat`` times in a row; keeps the estimator to read its breakdown counts."""
    o = ec.options
    obe = OBE(problem.p, prior=problem.prior, criterion=o.criterion, form=o.form,
              on_outlier="raise" if o.stop_at_outlier else "skip",
              record_every=max(1, repeat * W.shape[0] // 2000), names=problem.names)
    try:
        est = obe.fit(W, y, e)
        for _ in range(repeat - 1):
            est = obe.partial_fit(W, y, e)
        return obe, est, None
    except RUN_FAILURES as exc:
        return obe, None, f"{type(exc).__name__}: {exc}"


def _half_widths(est: Estimate) -> np.ndarray:
    lo, hi = est.intervals
    return 0.5 * (hi - lo)


def compare_forms(configs: dict[str, EstimatorConfig], reg: Regression, model: RobotModel, prior: PriorConfig,
                  cond: Condition, label: str, truth: np.ndarray | None) -> list[StabilityRow]:
    """Fit both forms (``configs``: form -> estimator) on the rows of ``reg`` under ``cond`` (the
    prior ``prior`` scaled by cond.prior_factor, the rows repeated cond.repeat times); truth (p,) the
    simulated parameters or None. Two :class:`StabilityRow`, standard first."""
    wide = replace(prior, relative_range=prior.relative_range * cond.prior_factor,
                   absolute_range=prior.absolute_range * cond.prior_factor)
    k = int(cond.repeat)
    truth_error = np.abs(reg.y - reg.W @ truth) if truth is not None else None  # the same rows for both forms
    truth_ratio: dict[str, float] = {}
    fits = {}
    for form in FORMS:
        pb = estimation_problem(configs[form], reg, model, wide)
        e = np.broadcast_to(np.asarray(pb.e_max, float), (reg.n_rows,))
        truth_ratio[form] = float(np.max(truth_error / e)) if truth_error is not None else float("nan")
        t0 = time.perf_counter()
        obe, est, err = _fit(configs[form], pb.W, pb.y, e, k, pb)
        fits[form] = (obe, est, err, time.perf_counter() - t0, obe.n_samples, pb)
    prior_half = _half_widths(OBE(model.p, prior=fits["factorized"][5].prior).estimate())
    rows = []
    for form in FORMS:
        obe, est, err, dt, n_rows, _ = fits[form]
        inside = None if est is None or truth is None else bool(est.contains(truth))
        if err is not None:
            failure = "lost positive definiteness" if obe.n_breakdowns else "raised"
            detail = err
        elif est.kind != "guaranteed":
            failure, detail = "unverified", est.unverified_reason
        elif inside is False and truth_ratio[form] <= 1.0:
            failure, detail = "misses the truth", "the guaranteed set misses theta_true, which satisfies the bound"
        else:
            failure = None
            detail = ("theta_true violates the bound on these rows (truth_ratio > 1): the set need not contain it"
                      if inside is False else None)
        rows.append(StabilityRow(
            condition=label, spec=cond, form=form, n_rows=n_rows, broke=failure is not None, failure=failure,
            detail=detail, kind=None if est is None else est.kind, n_breakdowns=int(obe.n_breakdowns),
            error_bound=float("nan") if est is None else float(est.error_bound),
            shrink=float("nan") if est is None else float(np.max(prior_half / _half_widths(est))),
            truth_ratio=truth_ratio[form], truth_in_set=inside, time_s=dt))
    a, b = fits["standard"][1], fits["factorized"][1]
    if a is not None and b is not None:
        Sa, Sb = a.set.shape, b.set.shape
        d = np.sqrt(np.diag(Sb))
        dc = float(np.max(np.abs(a.center - b.center) / d))
        dS = float(np.max(np.abs(Sa - Sb) / np.outer(d, d)))
        for r in rows:
            r.center_diff, r.shape_diff = dc, dS
    return rows


def _statement(rows: list[StabilityRow], skipped: dict[str, str]) -> str:
    """One line on [H4Paper]'s claim from the rows."""
    std = [r for r in rows if r.form == "standard"]
    fac_broke = [r.condition for r in rows if r.form == "factorized" and r.broke]
    own = next((r for r in std if r.spec.is_study), None)
    broke = [f"{r.condition} ({r.failure})" for r in std if r.broke]
    if own is None:
        head = "The study's own setting was not in the grid"
    elif own.broke:
        head = f"The standard form breaks down in the study's own setting ({own.failure})"
    else:
        head = (f"The standard form does not break down in the study's own setting (centres within "
                f"{own.center_diff:.1e} and shapes within {own.shape_diff:.1e} of the factorized form, relative to "
                "the set's half-widths)")
    if broke:
        tail = f"; it breaks down under {len(broke)} of {len(std)} conditions: " + "; ".join(broke)
    else:
        widest = max(std, key=lambda r: (r.spec.prior_factor, r.n_rows), default=None)
        tail = (f"; it broke down under none of the {len(std)} conditions tried"
                + (f" (widest prior x {widest.spec.prior_factor:.0e}, most rows {max(r.n_rows for r in std)})"
                   if widest else ""))
    tail += (f". The factorized form broke down under: {'; '.join(fac_broke)}." if fac_broke
             else ". The factorized form broke down under none.")
    if skipped:
        tail += f" Not run: {', '.join(skipped)}."
    return head + tail


def standard_form_stability(cfg: StudyConfig, model: RobotModel, data: StudyData, regression: Regression,
                            conditions: tuple[Condition, ...] = DEFAULT_CONDITIONS,
                            e_max: float | None = None) -> StabilityTable:
    """Refit the study's standard and factorized OBE (same criterion, bound and prior box) on
    ``regression`` (the study's regression, e.g. ``StudyResult.regressions["inverse_dynamic"]``)
    under each of ``conditions`` (see the module docstring and :data:`DEFAULT_CONDITIONS`), and
    say whether the standard form breaks down where [H4Paper] says it may.

    cfg, model, data : ``StudyResult.config``, ``.model``, ``.data``; the full-rate rows are built
    from ``data.recording`` (inverse dynamic regressions only, ``min_speed_rad_s = 0``); the truth
    is ``model.theta_true`` for simulated data (none for measured data). e_max : the bound [the
    regression's unit], when the study's OBE takes it from [exact] (else the estimator's own).

    Returns a :class:`StabilityTable`: two :class:`StabilityRow` per condition run (standard,
    factorized), the conditions that could not be run and why, the one-line statement on the
    paper's claim, and the wall time of the whole table [s].
    """
    t0 = time.perf_counter()
    configs = _form_configs(cfg, regression.model, e_max)
    truth = model.theta_true if cfg.experiment.source == "simulate" else None
    pp = cfg.preprocessing
    fs = 1.0 / data.recording.h
    skipped: dict[str, str] = {}
    regs: dict[str, Regression] = {"study": regression}
    if any(c.rows != "study" for c in conditions):
        if regression.model != "inverse_dynamic":
            why = "full-rate rows are built for the inverse dynamic regression only"
        elif np.any(np.asarray(pp.min_speed_rad_s) > 0):
            why = "full-rate rows do not apply the low-speed rule (min_speed_rad_s > 0)"
        else:
            why = None
            regs["full_rate_filtered"], regs["full_rate_unfiltered"] = full_rate_rows(model, data, cfg)
        if why is not None:
            skipped.update({c.label(pp.decimation, fs): why for c in conditions if c.rows != "study"})
    rows: list[StabilityRow] = []
    for c in conditions:
        if c.rows not in ROWS:
            raise StudyError(f"condition rows must be one of {ROWS}, got {c.rows!r}.")
        if c.rows == "full_rate_unfiltered" and pp.decimation == 1:
            skipped[c.label(pp.decimation, fs)] = "the study's rows are already at decimation 1"
            continue
        if c.rows in regs:
            rows += compare_forms(configs, regs[c.rows], model, cfg.prior, c, c.label(pp.decimation, fs), truth)
    return StabilityTable(rows, _statement(rows, skipped), skipped, time.perf_counter() - t0)
