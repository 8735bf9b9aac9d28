"""The report page of one study run: set-up, the paper's table beside ours, convergence,
validation, and the distance of every estimator to the exact optimum.

Every number on the page is computed by the run that writes it; the paper's own published
figures appear only in columns and captions labelled "paper".
"""

from __future__ import annotations

import os
import platform
import shutil
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd

from boundid.errors import RUN_FAILURES
from boundid.report import figures as F
from boundid.report.excitation_page import design_section
from boundid.report.html import Page
from boundid.report.output import replace_folder
from boundid.report.tables import deviation_percent, estimate_summary, parameter_table
from boundid.report.verdict import run_verdict
from boundid.report.verdict_file import write_verdict_file
from boundid.sets import Polytope, log_unit_ball_volume
from boundid.studies.bounds import bound_sweep, where_rows_sit
from boundid.studies.certify_files import certificate_row
from boundid.studies.reproduction import (
    IDENTIFIED_FACTOR,
    REGISTER_SOURCE,
    TRUTH_SOURCE,
    Claim,
    claims,
    identification,
    prior_bounds,
    shrank,
)
from boundid.studies.reproduction import summary as claims_summary
from boundid.studies.runner import RELAXED_TIME_LIMIT_S, Failure, StudyResult, reference_values
from boundid.studies.validation import (
    BEST_APPROX_DURATION_S,
    COVERAGE_RANGE,
    band_name,
    row_error_rms,
    statistical_coverage,
)

#: largest relative difference |a - b| / max(|a|, |b|, hi - lo) between two OpenBLAS kernels' numbers in a
#: study's results.csv, where both kernels give the study the same regression rows (to this tolerance too);
#: checked, with the verdicts, by `make platforms-report` (tools/platforms.py) in reports/benchmarks/platforms.md.
#: Measured: 1e-13 on the simulated studies, 1.4e-9 on the TX40's 61-parameter regression (rows that differ by
#: 7.5e-12 between kernels, amplified by its conditioning)
PLATFORM_RTOL = 1e-8


class _Guard:
    """``with guard("figure", name): ...``: a part of the page that fails is recorded as a Failure
    (stage, subject, reason) and the page goes on without it."""

    def __init__(self, failures: list[Failure]):
        self.failures = failures

    @contextmanager
    def __call__(self, stage: str, subject: str) -> Iterator[None]:
        try:
            yield
        except RUN_FAILURES as exc:
            self.failures.append(Failure(stage, subject, f"{type(exc).__name__}: {exc}"))


def _setup(r: StudyResult) -> dict:
    cfg, rec, exp = r.config, r.data.recording, r.config.experiment
    setup = {"robot": f"{r.model.name} ({r.model.n_joints} joints, {r.model.p} parameters)",
             "data": exp.source if exp.source == "measured" else f"simulated, {exp.control.replace('_', ' ')}",
             "samples": f"{rec.t.size} at h = {rec.h * 1e3:g} ms ({rec.t[-1] - rec.t[0]:.4g} s)"}
    if exp.source == "simulate":
        n = exp.torque_noise
        setup["torque noise"] = "none" if n.kind == "none" else f"{n.kind}, level {n.level:g} N m"
        setup["encoder"] = f"{exp.encoder_counts_per_rev} counts/rev" if exp.encoder_counts_per_rev else "exact"
    else:
        setup["position step"] = position_step_text(rec)
    setup["regressions"] = ", ".join(f"{k} ({v.n_rows} rows, {v.unit})" for k, v in r.regressions.items())
    for k, v in r.regressions.items():
        if v.dropped is not None and v.dropped.rows:
            d = v.dropped
            setup[f"{k} rows dropped"] = (f"{d.rows} of {d.of} ({100 * d.share:.3g} %; per joint "
                                          f"{', '.join(map(str, d.per_joint))}): {d.reason}")
    for key, value in r.data.info.items():
        if isinstance(value, int | float):
            setup[key.replace("_", " ")] = f"{value:.4g}"
    setup["seed"] = cfg.seed
    parts = []
    for k, v in r.timings.items():
        inner = r.exact.time_s if k == "exact" and r.exact is not None else {}
        parts.append(f"{k} {v:.1f}" + (" [" + ", ".join(f"{n.replace('_', ' ')} {t:.1f}" for n, t in inner.items())
                                        + "]" if inner else ""))
    setup["run time"] = f"{sum(r.timings.values()):.1f} s (" + ", ".join(parts) + ")"
    setup["platform"] = platform_line()
    return setup


def position_step_text(rec) -> str:
    """Each joint's smallest change of position between samples (the encoder's resolution, seen from
    the joint) and that step over one sample period, the velocity noise a difference makes of it."""
    steps = []
    for j in range(rec.n_joints):
        d = np.abs(np.diff(rec.q[:, j]))
        d = d[d > 1e-12 * max(1.0, float(np.abs(rec.q[:, j]).max()))]
        steps.append(float(d.min()) if d.size else float("nan"))
    return (", ".join(f"{s:.2g}" for s in steps) + " rad by joint (the smallest change between samples); over one "
            f"sample period {', '.join(f'{s / rec.h:.2g}' for s in steps)} rad/s: a coarse step is velocity noise "
            "that differences and the filtered models amplify, and the bound must cover it")


def platform_line() -> str:
    """CPU, Python, numpy and numba versions of the machine that ran the study."""
    import numba

    cpu = platform.processor() or platform.machine()
    return (f"{cpu} ({os.cpu_count()} cores), {platform.system()}, Python {platform.python_version()}, "
            f"numpy {np.__version__}, numba {numba.__version__}")


def describe(cfg) -> str:
    """What the study runs, generated from the study file (so it cannot contradict it)."""
    exp, pp = cfg.experiment, cfg.preprocessing
    if exp.source == "measured":
        data = f"Measured recording {exp.measured.file.name}."
    else:
        noise = exp.torque_noise
        data = (f"Simulated {exp.control.replace('_', '-')} experiment of {exp.duration_s:g} s at h = "
                f"{exp.sample_period_s * 1e3:g} ms; encoder "
                + (f"{exp.encoder_counts_per_rev} counts/rev" if exp.encoder_counts_per_rev else "exact")
                + (f"; torque noise {noise.kind}, level {noise.level:g} N m" if noise.kind != "none" else "")
                + (f"; structural error x {exp.structural_error:g}" if exp.control == "closed_loop" else "")
                + (f"; a {exp.validation_duration_s:g} s cross-validation trajectory"
                   if exp.control in ("closed_loop", "tracking") and exp.validation_duration_s > 0 else "") + ".")
    pre = (f" Low-pass {pp.lowpass_cutoff_hz:g} Hz before the inverse-dynamic differences"
           if pp.lowpass_cutoff_hz and "inverse_dynamic" in cfg.regressions else "")
    if "inverse_dynamic" in cfg.regressions and pp.torque_timing == "hold":
        pre += ("; " if pre else " ") + ("each torque held over its sample, so the row at t_k takes "
                                         "(tau[k-1] + tau[k]) / 2")
    if any(rn in cfg.regressions for rn in ("filtered_dynamic", "filtered_power")):
        pre += f"; filters lambda/(s + lambda), lambda = {pp.lambda_rad_s:g} rad/s ({pp.discretisation})"
    runs = "; ".join(f"{ec.label} on {', '.join(ec.regressions)}" for ec in cfg.estimators)
    pr = cfg.prior
    prior = (f"a-priori model values +- {100 * pr.relative_range:g} % (unknown ones +- {pr.absolute_range:g})"
             if pr.center == "model" else f"a box of +- {pr.absolute_range:g} about 0")
    text = f"{data}{pre + '.' if pre else ''} Estimators: {runs}. Prior: {prior}."
    if cfg.exact.regression is not None:
        e = cfg.exact.e_max
        bound = (cfg.exact.e_max_rule.describe() if cfg.exact.e_max_rule is not None else f"{e:g}"
                 if not isinstance(e, tuple) else f"{', '.join(f'{v:g}' for v in e)} by joint")
        text += f" Exact optima: the {cfg.exact.regression} rows with |e| <= {bound}, intersected with the prior box."
    return text


def _det_shape(est) -> float:
    """det(M^-1) of E = {(theta - c)^T M (theta - c) <= 1}, the H4 paper's uncertainty volume, from
    ln vol E = ln vol(unit ball) + ln det(M^-1) / 2; for a set of another family, that of the
    ellipsoid of the same volume (NaN where the family cannot give its volume)."""
    return float(np.exp(2.0 * (est.set.log_volume() - log_unit_ball_volume(est.p))))


def _tag(label: str, est) -> str:
    """The label of a set on the page: an unverified set says so."""
    return label if est.kind != "unverified" else f"{label} (unverified)"


def clipped_intervals(e, box: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """A set-membership estimate's intervals intersected with the prior box (lo, hi): the truth lies in
    both, so in their intersection; a guaranteed interval never claims less than was known before."""
    lo, hi = e.intervals
    return np.maximum(lo, box[0]), np.minimum(hi, box[1])


def _paper_section_h4(page: Page, r: StudyResult) -> None:
    m, names = r.model, r.model.param_names
    ests = {lab: e for (lab, rn), e in r.estimates.items() if rn == "inverse_dynamic"}
    box = prior_bounds(r)
    cols: dict = {"truth 1 (Table I)": m.theta_true}
    second = r.validation.get("second_truth")
    if second is not None and not second.represents:
        cols["truth 2 (best approx.)"] = second.theta
    cols["prior (Table I)"] = m.theta_prior
    sm = {lab: e for lab, e in ests.items() if e.set_membership}
    main = next(iter(sm), None)
    if main is not None:
        cols[f"{main} centre"] = sm[main].center
    ex = r.exact
    if ex is not None and ex.bounds is not None and ex.regression == "inverse_dynamic":
        cols["LP exact"] = (ex.bounds.lo, ex.bounds.hi)
    df = parameter_table(names, cols)
    if "LP exact" in cols:
        df["data shrank the prior?"] = [_yes(x) for x in shrank(ex.bounds.lo, ex.bounds.hi, *box)]
    page.section("Table I: the simulator's truth and the estimates",
                 "The simulator's parameters (truth 1) are the centre of the paper's Table I; truth 2 is the "
                 "identification model's best approximation of the simulated robot (see \"Two truths\"), the one "
                 "to compare estimates with where the model cannot represent the simulator. The a-priori values "
                 "are Table I's right column. Every other column is computed by this run; \"data shrank the prior?\" "
                 "says whether the exact LP interval is narrower than the prior box (no: the data do not constrain "
                 "the parameter beyond the prior). The guaranteed intervals are in \"Distance to the exact optimum\".")
    page.table(df, "Identified parameters (SI units) beside the truth and the prior.", name="table_I")
    others: dict = {}
    for lab, e in ests.items():
        if lab != main:
            others[f"{lab} centre"] = e.center
        if e.statistics is not None:
            others[f"{lab} sigma"] = e.statistics.std_err
    if others:
        page.table(parameter_table(names, others), "The other estimators on the same rows (SI units).",
                   name="table_I_others")
    rows = {}
    paper = r.config.paper
    for lab, e in sm.items():
        n = e.n_samples
        rows[_tag(lab, e)] = {"det(M^-1) ours": _det_shape(e),
                              "det(M^-1) paper": paper.get("uncertainty_volume", np.nan),
                              "outliers ours [%]": 100.0 * e.outliers.size / max(n, 1),
                              "outliers paper [%]": f"< {paper.get('outlier_rate_percent_below', 'n/a')}",
                              "updates": e.n_updates, "samples": n}
    if rows:
        page.table(pd.DataFrame.from_dict(rows, orient="index").rename_axis("estimate"),
                   "Uncertainty volume det(M^-1) and outlier rate after all data, beside the paper's (the "
                   "reason for the gap is in \"Does it reproduce?\").", name="volume_outliers")


def _paper_section_direct_drive(page: Page, r: StudyResult) -> None:
    m, names = r.model, r.model.param_names
    rls = {rn: e for (lab, rn), e in r.estimates.items() if e.method == "RLS"}
    page.section("Table II: RLS on three regression models, against the truth",
                 "Final RLS estimates (theta(0) = 0, P(0) = 1000 I) per regression model, and their deviation "
                 "from the simulation's true values. Paper's outcome: " + str(r.config.paper.get("outcome", "")))
    cols = {"truth": m.theta_true, **{rn: e.center for rn, e in rls.items()}}
    page.table(parameter_table(names, cols), "Final RLS estimates per regression model.", name="table_II")
    dev = deviation_percent({rn: e.center for rn, e in rls.items()}, m.theta_true, names)
    page.table(dev, "Deviation from truth, 100 (theta_hat - theta) / theta [%].", float_format="{:.3g}",
               name="deviation")
    if rls:
        # each history indexes the rows of its own regression: plot against those rows' times
        timed = {rn: (r.regressions[rn].t[e.history.index], e.history.centers)
                 for rn, e in rls.items() if e.history is not None}
        fig = F.parameter_convergence(None, timed, m.theta_true, names, units=m.param_units)
        for ax in fig.axes:
            if ax.get_xlabel():
                ax.set_xlabel("time [s]")
        page.figure(fig, "Parameter convergence theta_hat(t) of RLS per regression model (dashed: truth).",
                    name="convergence")


def _validation_section(page: Page, r: StudyResult) -> None:
    v = r.validation
    if "resimulation" in v:
        page.section("Open-loop re-simulation with the identified parameters",
                     "The robot is simulated again under the same torques with each identified parameter vector; "
                     "the joint positions are compared with the measured ones (the paper's validation).")
        rows = {}
        for rs in v["resimulation"]:
            rows[rs.label] = ({f"RMS error q{j + 1} [rad]": x for j, x in enumerate(rs.rms_error_rad)}
                              if rs.failure is None else {"failure": rs.failure})
        page.table(pd.DataFrame.from_dict(rows, orient="index").rename_axis("parameters from"),
                   "Position error of the open-loop re-simulation.", float_format="{:.3g}", name="resimulation")
        ok = {rs.label: rs.q for rs in v["resimulation"] if rs.failure is None and
              ("RLS" in rs.label or "WLS / inverse" in rs.label)}
        if ok:
            page.figure(F.trajectory_comparison(r.data.recording.t, r.data.recording.q, ok),
                        "Measured joint positions and the open-loop re-simulations (right: difference).",
                        name="resimulation_positions")
    if "torque_bands" in v and v["torque_bands"]:
        bands, measured, t = v["torque_bands"], v["validation_measured"], v["validation_t"]
        eq = " of eq. (37)" if r.config.robot == "h4" else ""  # the H4 paper's equation
        held = r.data.info.get("held out")
        statistical = ("The statistical bands w^T theta_hat +- 1.96 sqrt(w^T Cov w + sigma^2) have a nominal level of "
                       "95 %: they are prediction bands of the measured torque (filtered and decimated like the "
                       "identification rows) when the rows' error on this trajectory is white noise of the variance "
                       "sigma^2 the estimate assumes (the identification residuals', or the Kalman filter's stated R). "
                       "Their coverage of the validation samples, beside the nominal level, says whether they are; "
                       f"one covering less than {100 * COVERAGE_RANGE[0]:g} % or more than "
                       f"{100 * COVERAGE_RANGE[1]:g} % is named by what it is.")
        if held is None:
            page.section(f"Cross-validation: torque bounds{eq}",
                         "On a trajectory not used for identification, the guaranteed torque bounds "
                         "y = w^T theta_hat +- sqrt(w^T M^-1 w) of the OBE ([H4Paper] eq. 37), beside the "
                         "statistical bands. " + statistical)
        else:
            page.section("Held-out validation: predicted torques",
                         f"Identified without {held}, every estimate predicts that part's torques. A guaranteed "
                         "band is [min, max] of w^T theta over the set (the exact one: over the feasible "
                         "polytope, 2 LPs per row; the OBE's: eq. (37) of [H4Paper]); under the bound the "
                         "measured torque lies within e_max of it. " + statistical + " Coverage is of the measured "
                         "torques: on measured data nothing is known of the true torque.")
        names = {lab: band_name(b, measured) for lab, b in bands.items()}
        rows = {lab: {"kind": b.kind, "band": names[lab],
                      "nominal level [%]": np.nan if b.level is None else 100 * b.level,
                      "coverage [%]": 100 * b.coverage(measured),
                      "coverage of the band +- e_max [%]": 100 * (1 - b.outside_measured_fraction(measured)),
                      "mean half-width [N m]": float(np.nanmean(b.half_width)),
                      "rms error / predicted sd": float(np.sqrt(np.mean(b.error_ratio(measured) ** 2)))}
                for lab, b in bands.items()}
        page.table(pd.DataFrame.from_dict(rows, orient="index").rename_axis("estimate"),
                   "Share of the measured validation torques inside each band (coverage), beside a statistical "
                   "band's nominal level, and inside it widened by each joint's bound (NaN: a statistical band, "
                   "which already predicts the measurement). rms error / predicted sd: the rms of measured - "
                   "predicted torque over the standard deviation a statistical band assumes (~1 when its noise "
                   "model holds).", float_format="{:.3g}", name="crossval")
        why = _band_coverage_text(r, bands, measured)
        if why:
            page.text(why)
        main = next((lab for kind in ("exact", "guaranteed") for lab, b in bands.items() if b.kind == kind),
                    next(iter(bands)))
        extra = {(f"{lab} 95 %" if names[lab].startswith("95 %") else f"{lab} (nominal 95 %)"): (b.lower, b.upper)
                 for lab, b in bands.items() if lab != main and b.kind == "statistical"}
        page.figure(F.torque_bounds(t, measured, bands[main].lower, bands[main].upper,
                                    band_label=f"{main} bounds", extra_bands=extra),
                    f"Measured torque on the validation trajectory inside the {main} bounds.",
                    name="torque_bounds")


def _band_coverage_text(r: StudyResult, bands: dict, measured: np.ndarray) -> str:
    """Why each statistical band that is not a 95 % prediction band on the validation rows is not one:
    its coverage there and on the identification rows, the validation error over the sd it assumes per
    joint and, on simulated data, the rows' own error against the truth on both trajectories."""
    lo, hi = COVERAGE_RANGE
    off = {lab: b for lab, b in bands.items() if b.level is not None and not lo <= b.coverage(measured) <= hi}
    if not off:
        return ""
    ident = r.regressions.get("inverse_dynamic")
    ests = {lab: e for (lab, rn), e in r.estimates.items() if rn == "inverse_dynamic" and lab in off}
    in_sample = statistical_coverage(ident, r.model.n_joints, ests) if ident is not None else {}
    parts = []
    for lab, b in off.items():
        ratio = ", ".join(f"{x:.2g}" for x in b.error_ratio(measured))
        text = (f"{lab} covers {100 * b.coverage(measured):.3g} % of the validation samples, not "
                f"{100 * b.level:g} %: there the rms error is {ratio} x (per joint) the standard deviation it assumes")
        if b.noise == "stated":
            over = np.all(b.error_ratio(measured) < 1)
            text += (", the study's stated noise variance R, not estimated from the data: R "
                     + ("overstates" if over else "misstates") + " the rows' error")
        elif lab in in_sample:
            text += (f"; on the identification rows, whose residuals gave its noise variance, it covers "
                     f"{100 * in_sample[lab]:.3g} %")
        parts.append(text)
    text = "; ".join(parts) + "."
    if any(b.noise == "residuals" for b in off.values()):
        text += (" A band estimated from the identification residuals can be a prediction band on another "
                 "trajectory only if the rows' error there is the same white noise; it is not.")
        if r.config.experiment.source == "simulate" and ident is not None:
            vreg = r.validation.get("validation_regression")
            e_id, e_val = (row_error_rms(g, r.model.n_joints, r.model.theta_true) for g in (ident, vreg))
            text += (" Against the simulator's true parameters, the rows' own error (rms per joint) is "
                     + ", ".join(f"{x:.3g}" for x in e_id) + " N m on the identification rows and "
                     + ", ".join(f"{x:.3g}" for x in e_val) + " N m on the validation rows")
            if np.nanmax(np.abs(np.log(e_val / e_id))) > np.log(1.2):
                text += (": the rows carry an error that is not noise but depends on the motion (a deterministic "
                         "error of the data: of the filters, of the torque's timing against the angles, of the "
                         "friction model), and a band whose noise variance comes from the identification rows "
                         "cannot know it. It is a band of the identification rows' error level, not a prediction "
                         "band of this trajectory.")
            else:
                text += (": about the same on both, so the band's miss comes from the estimate, not from the rows' "
                         "error level.")
    return text


def numbers_stored(S) -> int:
    """How many numbers a set of any family keeps: an ellipsoid its centre and the upper triangle of its
    shape (p + p (p + 1) / 2), otherwise the sizes of the arrays that define it (cached factorizations of
    an ellipsoid are not counted)."""
    from boundid.sets import Ellipsoid

    if isinstance(S, Ellipsoid):
        p = S.dim
        return p + p * (p + 1) // 2
    fields = getattr(S, "__dict__", None) or {k: getattr(S, k) for k in getattr(S, "__slots__", ())}
    arrays = [v for k, v in fields.items() if not k.startswith("_") and isinstance(v, np.ndarray)]
    return int(sum(a.size for a in arrays))


def _bracketed_excess(S, bracket, p: int) -> str:
    """[low, high]: ln vol of S over the minimum-volume outer ellipsoid of P, per axis, from the
    bracket of that optimum's ln vol; "–" without a bracket or a volume."""
    lv = S.log_volume()
    if bracket is None or not np.isfinite(lv):
        return "–"
    return f"[{(lv - bracket.upper) / p:.3g}, {(lv - bracket.lower) / p:.3g}]"


def set_comparison(r: StudyResult) -> tuple[pd.DataFrame, pd.DataFrame] | None:
    """Every set estimate on the exact regression (any ConvexSet family) and the SDP ellipsoids against
    the exact LP interval: (summary, per-parameter width / exact width of the intervals ∩ prior box);
    None without LP bounds or without any set."""
    ex = r.exact
    if ex is None or ex.bounds is None:
        return None
    box = prior_bounds(r)
    exact_w = ex.bounds.hi - ex.bounds.lo
    sets = {_tag(lab, e): e for lab, e in _guaranteed_sets(r).items()}
    entries = {lab: (e.set, e.intervals, e.time_s / max(e.n_samples, 1), e) for lab, e in sets.items()}
    entries.update({f"SDP {k}": (v.ellipsoid, v.ellipsoid.intervals(), np.nan, None) for k, v in ex.sdp.items()})
    if not entries:
        return None
    rows, ratios = {}, {}
    for lab, (S, (lo, hi), per_sample, e) in entries.items():
        clo, chi = np.maximum(lo, box[0]), np.minimum(hi, box[1])
        ratios[lab] = (chi - clo) / exact_w
        cert = ex.certificates.get(lab.replace(" (unverified)", "")) if e is not None else None
        contains = ("yes" if cert.contains_polytope else "NO") if cert is not None else (
            "no (inner)" if lab == "SDP inner" else "–")
        rows[lab] = {"contains polytope": contains,
                     "mean width / exact": float(np.mean(ratios[lab])),
                     "max width / exact": float(np.max(ratios[lab])),
                     "ln vol / p": S.log_volume() / r.model.p,
                     "excess over min outer / p": _bracketed_excess(S, ex.bracket, r.model.p),
                     "µs / sample": 1e6 * per_sample,
                     "numbers stored": numbers_stored(S)}
    summary = pd.DataFrame.from_dict(rows, orient="index").rename_axis("set")
    per_param = pd.DataFrame(ratios, index=pd.Index(list(r.model.param_names), name="parameter"))
    return summary, per_param


def bound_evidence(ex) -> str:
    """What the data say about the bound (no truth needed): e_max against gamma*, the smallest bound
    the data allow, and the minimum number of outliers when the data contradict the bound."""
    ev = ex.evidence
    gs = (f"gamma* = {ev.one:.4g} {ev.unit} is the smallest bound on every row the data allow (a lower bound on "
          "the true errors' largest, not an estimate of it)")
    if not ex.consistent:
        text = (f"e_max = {ex.bound_text()} is {ex.gamma_star:.3g}x too small, no parameter vector satisfies every "
                f"row; {gs}")
        if ex.outliers is not None:
            o = ex.outliers
            text += (f"; {o.n_outliers} row{'s' * (o.n_outliers != 1)} must go (proven minimum)" if o.proven else
                     f"; between {o.lower_bound} and {o.n_outliers} rows must go (the MILP's bounds when its time "
                     "limit ran out)")
        return text
    margin = "" if ex.rule is not None else f", {1.0 / ex.gamma_star:.3g} x the smallest consistent bound"
    return f"e_max = {ex.bound_text()}{margin}; {gs}"


def _bound_section(page: Page, r: StudyResult) -> None:
    """Choosing the bound: gamma* three ways, the rows that decide it and where they sit, the outliers."""
    ex = r.exact
    if ex is None or ex.evidence is None:
        return
    ev, reg, rec = ex.evidence, r.regressions[ex.regression], r.data.recording
    page.section("Choosing the bound",
                 "A guaranteed set is exactly as good as its bound e_max: on a recording nothing checks it. What the "
                 "data do say is gamma*, the smallest bound they are consistent with (one LP): below it no parameter "
                 "vector of the prior box fits every row; at it, one does (the Chebyshev fit). "
                 + bound_evidence(ex) + ".")
    page.table(pd.DataFrame(ev.table()).set_index("joint"),
               f"gamma* three ways [{ev.unit}]: gamma*_j of each joint's rows alone, sigma_j the joint's WLS residual "
               "spread, and the smallest consistent bound of the joint's rows under each scaling: one bound on every "
               f"row (gamma* = {ev.one:.4g}), bounds in proportion to each joint's own gamma*_j ({ev.per_joint:.3g} x "
               f"gamma*_j), or to its sigma_j ({ev.scaled:.3g} x sigma_j). A study's e_max may be a rule: a factor "
               "times one of these scalings.",
               name="gamma_star")
    sits = pd.DataFrame(where_rows_sit(reg, rec.t, rec.q, rec.tau, ev.active)).set_index("row")
    counts = sits["where"].value_counts()
    page.table(sits.head(20), f"The {len(ev.active)} rows that decide gamma* (the active strips at the Chebyshev fit"
               + (", the first 20" if len(ev.active) > 20 else "") + "), and where they sit: "
               + ", ".join(f"{n} {w}" for w, n in counts.items()) + ". Rows at velocity reversals and stops carry "
               "the friction model's error (sign(qd) against stiction); at the start and end, the filters' edges.",
               name="active_rows")
    if ex.consistent and ex.bounds is not None:
        scaling = ex.rule.scaling if ex.rule is not None else "one"
        points = {lab: e.center for (lab, rn), e in r.estimates.items()
                  if rn == ex.regression and e.kind == "statistical"}
        sweep = bound_sweep(reg, ex.polytope.box, ev, scaling, points)
        page.figure(F.bound_sweep(sweep), f"What the bound changes ({scaling} scaling): left, the exact feasible set's "
                    "interval widths over the prior box's (2p LPs per bound); right, the rows each statistical "
                    "estimate's centre puts outside their bound. A larger bound is safer and wider; a centre that "
                    "violates rows at the chosen bound is not a point of the guaranteed set.", name="bound-sweep")
    if ex.outliers is not None and ex.outliers.n_outliers:
        o = ex.outliers
        dropped = pd.DataFrame(where_rows_sit(reg, rec.t, rec.q, rec.tau, o.dropped[:30])).set_index("row")
        page.table(dropped, f"The rows to drop for the feasible set to be non-empty at this bound: {o.n_outliers}"
                   + (" (proven minimum" if o.proven else f" (not proven: at least {o.lower_bound}")
                   + f", HiGHS MILP in {o.time_s:.2g} s)" + (", the first 30" if o.n_outliers > 30 else "") + ".",
                   name="outliers")
    if ex.relaxed is not None:
        _relaxed_table(page, r)


def _relaxed_table(page: Page, r: StudyResult) -> None:
    """The q-relaxed bounds beside the exact ones: what allowing q outliers does to each interval."""
    ex, rb = r.exact, r.exact.relaxed
    names = r.model.param_names
    if rb.empty:
        page.text(f"With at most {rb.q} outlier{'s' * (rb.q != 1)} the feasible set is still empty (proven): more "
                  "rows contradict the bound than that.")
        return
    proven = rb.lo_proven & rb.hi_proven
    df = pd.DataFrame({"relaxed lo": rb.lo, "relaxed hi": rb.hi, "found lo": rb.lo_found, "found hi": rb.hi_found,
                       "proven": np.where(proven, "yes", np.where(rb.lo_proven | rb.hi_proven, "one side", "no"))},
                      index=pd.Index(names, name="parameter"))
    if ex.bounds is not None:
        df.insert(0, "exact hi", ex.bounds.hi)
        df.insert(0, "exact lo", ex.bounds.lo)
        df["width / exact"] = (rb.hi - rb.lo) / (ex.bounds.hi - ex.bounds.lo)
    page.table(df, f"Bounds of the parameters that violate at most q = {rb.q} rows at this bound (the q-relaxed "
               f"feasible set [JaulinWalter2002]; 2p HiGHS MILPs, {RELAXED_TIME_LIMIT_S:g} s each, "
               f"{rb.time_s:.3g} s in all). The set is a union of polytopes: [relaxed lo, relaxed hi] is an outer "
               f"interval hull, exact where proven ({int(proven.sum())} of {len(names)} parameters), the MILP's "
               "dual bound where its time ran out; [found lo, found hi] is attained by points of the set. A robust "
               "answer: no choice of q outlying rows moves a parameter beyond it.", name="relaxed-bounds")


def _exact_section(page: Page, r: StudyResult, guard: _Guard) -> None:
    ex = r.exact
    if ex is None:
        return
    m, names = r.model, r.model.param_names
    page.section("Distance to the exact optimum",
                 f"The feasible polytope of the {ex.regression} rows with |e| <= {ex.bound_text()}, intersected with "
                 f"the prior box: the smallest consistent inflation of these bounds is {ex.gamma_star:.4g} (the data "
                 "are consistent with them iff it is <= 1).")
    truth = _truth(r)
    if truth is not None and np.isfinite(ex.truth_error_ratio):
        holds = ex.truth_violations == 0
        page.text(f"At the true parameters the largest error is {ex.truth_error_ratio:.3g} x e_max: the bound "
                  + ("holds on every row, so every guaranteed set must contain the truth." if holds else
                     f"is exceeded on {ex.truth_violations} rows, so no set-membership guarantee applies to "
                     "this data set: the truth may legitimately lie outside the sets."))
    for what, msg in ex.errors.items():
        page.text(f"{what}: {msg}.")
    sets = {_tag(lab, e): e for (lab, rn), e in r.estimates.items() if rn == ex.regression and e.set is not None}
    if ex.bounds is not None:
        box = prior_bounds(r)
        cols = {"prior box": box, "LP exact": (ex.bounds.lo, ex.bounds.hi),
                **{f"{_tag(lab, e)} ∩ prior": clipped_intervals(e, box) for lab, e in _guaranteed_sets(r).items()}}
        df = parameter_table(names, cols)
        df["data shrank the prior?"] = [_yes(x) for x in shrank(ex.bounds.lo, ex.bounds.hi, *box)]
        page.table(df, "Guaranteed intervals intersected with the prior box (under the bound the truth lies in "
                   "both), beside the exact LP interval; \"data shrank the prior?\": the LP interval is narrower than "
                   "the prior box.", name="intervals")
    comparison = None
    with guard("table", "set comparison"):
        comparison = set_comparison(r)
    if comparison is not None:
        summary, per_param = comparison
        page.table(summary, "Every set estimator against the exact polytope: contains it (certified by its vertices "
                   "and support), interval width over the exact LP width (mean and max over the parameters, "
                   "intervals intersected with the prior box), "
                   "ln volume per dimension (the SDP inner ellipsoid bounds any outer set from below), "
                   + ("its excess over the minimum-volume outer ellipsoid, bracketed, " if r.exact.bracket is not None
                      else "(excess over the minimum-volume outer ellipsoid not bracketed: " + (
                          "exact.volume_bracket = false in the study file) " if not r.config.exact.volume_bracket
                          else "no bracket, see above) "))
                   + "time per sample and the numbers the set keeps.", float_format="{:.3g}", name="set_comparison")
        page.table(per_param, "Width / exact LP width per parameter (1 = exact).", float_format="{:.3g}",
                   name="width_over_exact")
        with guard("figure", "width ratios"):
            w = pd.DataFrame({"LP exact": ex.bounds.hi - ex.bounds.lo,
                              **{c: per_param[c].to_numpy() * (ex.bounds.hi - ex.bounds.lo) for c in per_param}},
                             index=per_param.index)
            page.figure(F.width_ratios(w), "Per-parameter interval width (∩ prior box) over the exact LP width "
                        "(1 = exact), one dot per set.", name="width_ratios")
    logv = {lab: e.set.log_volume() / m.p for lab, e in sets.items() if e.set_membership}
    logv.update({f"SDP {k}": v.ellipsoid.log_volume() / m.p for k, v in ex.sdp.items()})
    if logv:
        with guard("figure", "log volumes"):
            page.figure(F.log_volume_bars(logv), "ln volume per dimension of the guaranteed sets and the SDP "
                        "ellipsoids (the inner ellipsoid is a lower bound on any outer set).", name="log_volumes")
    rows = {lab: {k: _cell(v) for k, v in certificate_row(cert).items()} for lab, cert in ex.certificates.items()}
    if rows:
        cert = pd.DataFrame.from_dict(rows, orient="index").rename_axis("estimate")
        page.table(cert.T.rename_axis("certificate"),
                   "Certification of each set-membership estimate against the exact optima (an unverified "
                   "set is certified too, and labelled so); widths of the raw sets, before the prior box.",
                   float_format="{:.3g}", name="certificates")
    ref = (ex.bounds.lo, ex.bounds.hi) if ex.bounds is not None else None
    summ = estimate_summary({f"{lab} / {rn}": e for (lab, rn), e in r.estimates.items()},
                            truth[0] if truth is not None else None, reference=ref)
    key = ["kind", "truth in set", "mean width / exact", "ln vol / p", "level", "outliers", "time [s]"]
    summ = summ[[c for c in key if c in summ.columns]]  # key columns first, at most 7
    page.table(summ, "Every estimate: set kind, volume, mean width (over the exact width), "
               + ("containment of the " + truth[1] + ", " if truth is not None else "") + "run time. "
               "A confidence set's level holds only for white noise independent of the regressors: filtered "
               "equations, differentiated encoder noise and a structural model error all break that, so "
               "confidence sets may miss the truth; guaranteed sets may not, wherever the bound holds.",
               float_format="{:.3g}", name="estimates")
    for a, b in r.config.exact.projections:
        with guard("projection", f"({a}, {b})"):
            idx = [names.index(a), names.index(b)]
            shadow = ex.polytope.project(*idx, rtol=SHADOW_RTOL) if ex.bounds is not None else None
            shadows = {lab: e.set.project(*idx, rtol=SHADOW_RTOL) if isinstance(e.set, Polytope)
                       else e.set.project(*idx) for lab, e in sets.items()}
            shadows.update({f"SDP {k}": v.ellipsoid.project(*idx) for k, v in ex.sdp.items()})
            centers = {lab: e.center[idx] for lab, e in sets.items()}
            centers.update({f"SDP {k}": v.ellipsoid.center[idx] for k, v in ex.sdp.items()})
            box = ((ex.bounds.lo[idx], ex.bounds.hi[idx]) if ex.bounds is not None else None)
            page.figure(F.projection_2d(shadow, shadows, truth[0][idx] if truth is not None else None, box, (a, b),
                                        centers=centers, units=[m.param_units[i] for i in idx]),
                        f"Projection on ({a}, {b}): exact polytope shadow (grey; its vertices are the shadow's, which "
                        f"reaches at most {SHADOW_RTOL:.1%} of its width along each axis beyond an edge), LP box "
                        "(dashed), the sets' "
                        "shadows" + (f", {truth[1]} (star)" if truth is not None else "") + "; John's ellipsoid "
                        "may run past the frame.",
                        name=f"projection_{a}_{b}")


def coinciding(histories: dict) -> str:
    """A caption note naming the recursive estimates whose histories agree to 1e-6 (relative) and so
    are drawn on top of each other; "" if none do."""
    labs, pairs = list(histories), []
    for i, a in enumerate(labs):
        for b in labs[i + 1:]:
            ha, hb = histories[a], histories[b]
            if (ha.centers.shape == hb.centers.shape and np.array_equal(ha.index, hb.index)
                    and np.allclose(ha.centers, hb.centers, rtol=1e-6, atol=0.0)):
                pairs.append(f"{a} and {b}")
    return (" " + "; ".join(pairs) + " coincide to 1e-6 and are drawn on top of each other.") if pairs else ""


def _convergence_sets(page: Page, r: StudyResult) -> None:
    obe = {_tag(lab, e): e.history for (lab, rn), e in r.estimates.items()
           if e.set_membership and e.history is not None}
    if obe:
        page.section("Recursive set estimates over the samples")
        same = coinciding(obe)
        page.figure(F.volume_history({lab: (h.index, h.log_volumes) for lab, h in obe.items()}),
                    "ln volume of the OBE ellipsoids against the number of rows processed." + same,
                    name="volume_history")
        truth = _truth(r)
        if "closed_loop" in r.model.experiments:  # the H4 paper's experiment and its figure
            first = next(iter(obe))
            page.figure(F.parameter_convergence(None, {lab: h for lab, h in obe.items()},
                                                truth[0] if truth is not None else None,
                                                r.model.param_names, units=r.model.param_units),
                        f"Centres of the OBE ellipsoids against the row index (dashed: truth); {first} is the "
                        "paper's estimator." + same, name="obe_convergence")


def _guaranteed_sets(r: StudyResult) -> dict:
    ex = r.exact
    if ex is None:
        return {}
    return {lab: e for (lab, rn), e in r.estimates.items() if rn == ex.regression and e.set_membership}


def findings(r: StudyResult, verdicts: list[Claim], failures: list[Failure]) -> dict[str, str]:
    """The page's first screen: does the bound hold at the truth, do the guaranteed sets contain the
    exact polytope, the paper verdicts, failures, OBE width over the exact width, breakdown rates."""
    out: dict[str, str] = {}
    ex, truth = r.exact, _truth(r)
    if verdicts:
        out["paper claims"] = claims_summary(verdicts) + " (the register below)"
    if ex is not None:
        n_rows = r.regressions[ex.regression].n_rows
        if ex.evidence is not None:
            out["the bound"] = bound_evidence(ex)
        if truth is None:
            out["bound at the truth"] = ("unknown: measured data have no truth; what the page shows holds under the "
                                         "bound")
        elif np.isfinite(ex.truth_error_ratio):
            share = 100.0 * ex.truth_violations / n_rows
            out["bound at the truth"] = (
                f"{'holds' if ex.truth_violations == 0 else 'BROKEN'}: max |error| / e_max = "
                f"{ex.truth_error_ratio:.3g}, {ex.truth_violations} of {n_rows} rows ({share:.3g} %) over "
                f"e_max = {ex.bound_text()}")
        if truth is not None and ex.bounds is not None:
            out["truth inside"] = _truth_inside(r, truth[0])
        if ex.bounds is not None:
            out["identified by the data"] = _identified_finding(r)
        second = r.validation.get("second_truth")
        if second is not None and not second.represents:
            out["model's best approximation"] = (f"max residual {second.max_residual:.3g} N m on noise-free data "
                                                 f"(the model cannot represent the simulator exactly)")
        sets = _guaranteed_sets(r)
        certs = {lab: ex.certificates[lab] for lab in sets if lab in ex.certificates}
        if certs:
            miss = [lab for lab, c in certs.items() if not c.contains_polytope]
            out["guaranteed sets contain the exact polytope"] = (
                f"yes, all {len(certs)}" if not miss else f"NO: {', '.join(miss)} (of {len(certs)})")
            width = _width_finding(r, certs)
            if width:
                out[width[0]] = width[1]
    if ex is not None and ex.physical is not None:
        out["physically consistent bounds"] = _physical_finding(ex.physical)
    if ex is not None and ex.evidence is not None and r.config.experiment.source == "measured":
        out["rows that decide gamma*"] = _active_rows_finding(r)
        wider = _wider_than_confidence(r)
        if wider:
            out["guaranteed / confidence width"] = wider
    if r.published is not None:
        out["published values"] = _published_finding(r)
    held = _held_out_finding(r)
    if held:
        out["held-out torques"] = held
    band = _cross_validation_finding(r)
    if band:
        out["cross-validation torque bands"] = band
    sweep = r.validation.get("obe_sweep")
    if sweep is not None:
        out["OBE breakdown rate"] = ", ".join(
            f"{lab.split(' / ')[0]} {sum(x is not None for x in o)} of {len(o)} noise seeds"
            for lab, o in sweep.outcomes.items())
    elif any(e.method.startswith("OBE") for e in r.estimates.values()):
        out["OBE breakdown rate"] = ("not measured: the data are not simulated, so no other noise draw exists; "
                                     "this run's OBE outcomes may differ between machines")
    out["failures"] = "none" if not failures else f"{len(failures)}, listed in the last section"
    return out


def _truth_inside(r: StudyResult, truth: np.ndarray) -> str:
    """Whether the truth lies in the exact LP bounds and in each guaranteed set (they must contain it
    when the bound holds at the truth)."""
    ex = r.exact
    tol = 1e-9 * np.maximum(1.0, np.abs(truth))
    sets = _guaranteed_sets(r)
    listed = np.isfinite(truth)
    if not listed.all():  # reference values of some parameters only: their intervals, not the whole vector
        def count(lo, hi) -> str:
            return f"{int(np.sum(((lo - tol <= truth) & (truth <= hi + tol))[listed]))} of {int(listed.sum())}"
        return (f"the reference values of {int(listed.sum())} parameters: exact LP intervals hold "
                f"{count(ex.bounds.lo, ex.bounds.hi)}; "
                + "; ".join(f"{lab} {count(*e.intervals)}" for lab, e in sets.items()))
    in_lp = bool(np.all((ex.bounds.lo - tol <= truth) & (truth <= ex.bounds.hi + tol)))
    missed = [lab for lab, e in sets.items() if not e.set.contains(truth)]
    text = (f"exact LP bounds {'yes' if in_lp else 'NO'}; "
            + (f"every guaranteed set ({len(sets)})" if not missed else
               f"{len(sets) - len(missed)} of {len(sets)} guaranteed sets (not: {', '.join(missed)})"))
    if ex.truth_violations:
        text += " (no guarantee applies: the bound is broken at the truth)"
    return text


def _verdict_section(page: Page, r: StudyResult, verdicts: list[Claim]) -> None:
    paper = {"h4": "H4 paper", "direct_drive": "direct-drive paper"}.get(r.config.robot, "paper")
    page.section("Does it reproduce?",
                 f"The claims register of the {paper}, written from {REGISTER_SOURCE.get(r.config.robot, 'its text')}: "
                 "every claim of its abstract, results and conclusion, with its section, tested first on the paper's "
                 "own method as this run applies it, on simulated data with true parameters from "
                 f"{TRUTH_SOURCE.get(r.config.robot, 'the paper')}. \"Partly\" says that one part of a claim holds "
                 "and another does not (the reason says which). \"Holds by construction\" marks a claim that cannot "
                 "fail on these data (the reason says why): it is not counted as reproduced. \"Cannot be tested\" "
                 f"says what is missing. The verdicts: {claims_summary(verdicts)}. What the other estimators say is in "
                 "the second table and never decides a verdict.")
    df = pd.DataFrame([c.__dict__ for c in verdicts]).set_index("id")
    table = pd.DataFrame({"claim (section)": [f"{c.claim} ({c.section})" for c in verdicts],
                          "verdict": df["verdict"], "the paper": df["paper"],
                          "ours, on the paper's method": df["ours"]}, index=df.index)
    page.table(table, "The paper's claims, our figure on the paper's method and the verdict; the method as run here "
               "and the reason for each verdict, from the run, are listed below the table.", name="reproduction")
    page.text("\n\n".join(f"{c.id}. {c.claim} — {c.verdict} (method: {c.method}): {c.reason}." for c in verdicts))
    page.table(df[["claim", "others"]].rename(columns={"others": "the other estimators"}),
               "The same claims on the other estimators of this run (not used for the verdicts).",
               name="reproduction_others")


def _stability_section(page: Page, r: StudyResult) -> None:
    """The grid of refits behind the H4 paper's stability claim (H1): each condition, each form, how
    it ended (:mod:`boundid.studies.obe_stability`)."""
    table = (r.validation.get("paper") or {}).get("stability")
    if table is None:
        return
    df = pd.DataFrame([{"condition": row.condition, "form": row.form, "rows": row.n_rows,
                        "outcome": row.failure or row.kind, "shrink of the prior": row.shrink,
                        "centres apart": row.center_diff, "shapes apart": row.shape_diff,
                        "truth's max |error| / e_max": row.truth_ratio,
                        "truth in set": "–" if row.truth_in_set is None else _yes(row.truth_in_set)}
                       for row in table.rows]).set_index("condition")
    page.section("Where the standard form breaks",
                 folded=f"The standard and factorized OBE refitted under {len(table.rows) // 2} conditions "
                        f"({table.time_s:.2g} s): {table.statement.split(';')[0]}")
    page.text(f"{table.statement} Each condition refits both forms with the study's criterion and bound: the "
              "study's rows; every 1 kHz sample parallel-filtered but not decimated (ten times the rows, strongly "
              "correlated); every sample without the parallel filter; the prior box widened by a factor (a step "
              "that shrinks the ellipsoid by rho costs the standard form about log10(rho) digits of M^-1); the "
              "rows repeated (a longer run). \"Shrink of the prior\" is the largest ratio of the prior "
              "ellipsoid's half-width to the final set's; \"centres apart\" and \"shapes apart\" are the two "
              "forms' largest differences in units of the factorized set's half-widths. Missing the truth counts "
              "as a breakdown only where the truth keeps the bound on those rows. \"Guaranteed\" is the "
              "estimator's own verdict on its arithmetic: it holds under the bound, so where the truth breaks the "
              "bound (its max |error| / e_max above 1, as on the unfiltered rows) the set need not contain the truth.")
    page.table(df, "The standard and the factorized OBE under each condition.", float_format="{:.3g}",
               name="obe_stability")


def _two_truths_section(page: Page, r: StudyResult) -> None:
    second = r.validation.get("second_truth")
    if second is None:
        return
    m, ex = r.model, r.exact
    page.section("Two truths: the simulator and the model's best approximation")
    if second.represents:
        page.text(f"The identification model represents the simulator ({second.simulator_name}) exactly: its best "
                  f"approximation is the simulator's parameters (max residual {second.max_residual:.3g} N m on "
                  "noise-free data), so there is one truth.")
        return
    page.text(f"The simulator ({second.simulator_name}) holds more than the {m.p}-parameter model can represent. "
              f"Truth 1, the simulator's parameters, leaves a structural error; truth 2, the model's best "
              f"approximation (minimax fit on {BEST_APPROX_DURATION_S:g} s of exact, noise-free motion), has max "
              f"residual {second.max_residual:.3g} N m (rms {second.rms_residual:.3g}). Deviations of estimates are "
              "compared with truth 2 where the model cannot represent truth 1.")
    cols = {"truth 1: simulator": m.theta_true, "truth 2: best approximation": second.theta}
    df = parameter_table(m.param_names, cols)
    if ex is not None:
        reg = r.regressions[ex.regression]
        rows = {}
        for name, theta in cols.items():
            ratio = np.abs(reg.y - reg.W @ theta) / ex.e_max
            rows[name] = {"max |error| / e_max (identification rows)": float(ratio.max()),
                          "rows over the bound [%]": 100.0 * float(np.mean(ratio > 1.0)),
                          "in exact polytope": _yes(ex.polytope.contains(theta))}
            for lab, e in _guaranteed_sets(r).items():
                rows[name][f"in {lab}"] = _yes(e.contains(theta))
        page.table(pd.DataFrame.from_dict(rows, orient="index").rename_axis("truth"),
                   "Each truth against the identification data and the guaranteed sets.", float_format="{:.3g}",
                   name="two_truths_check")
    page.table(df, "The two truths (SI units).", float_format="{:.4g}", name="two_truths")


def _truth_section(page: Page, r: StudyResult) -> None:
    """Every estimate's centre against the simulator's parameters (simulated studies): per estimate
    the median and largest relative deviation and how many of its intervals hold the truth, then the
    deviation of each parameter. Where the model cannot represent the simulator, the deviations from
    its best approximation (truth 2) are summarised too."""
    if r.config.experiment.source != "simulate" or not r.estimates:
        return
    m = r.model
    ests = {f"{lab} / {rn}" if len({k[1] for k in r.estimates}) > 1 else lab: e
            for (lab, rn), e in r.estimates.items()}
    truths = {"truth": m.theta_true}
    second = r.validation.get("second_truth")
    if second is not None and not second.represents:
        truths = {"truth 1 (simulator)": m.theta_true, "truth 2 (best approximation)": second.theta}
    rows: dict = {}
    for lab, e in ests.items():
        row = {"kind": e.kind}
        for tname, theta in truths.items():
            dev = np.abs(deviation_percent({lab: e}, theta, m.param_names)[lab].to_numpy())
            lo, hi = e.intervals
            tol = 1e-9 * np.maximum(1.0, np.abs(theta))
            suffix = "" if len(truths) == 1 else f" ({' '.join(tname.split(' ')[:2])})"
            row[f"median |deviation| [%]{suffix}"] = float(np.nanmedian(dev))
            row[f"max |deviation| [%]{suffix}"] = float(np.nanmax(dev))
            row[f"truth in its intervals{suffix}"] = f"{int(np.sum((lo - tol <= theta) & (theta <= hi + tol)))}/{m.p}"
        rows[lab] = row
    page.section("Estimates against the truth",
                 "Each estimate's centre against the parameters the data were simulated with, relative to the true "
                 "value (a true value of 0 gives no relative deviation: –); \"truth in its intervals\" counts the "
                 "parameters whose interval (guaranteed, or the confidence interval of a statistical estimate, at "
                 "its level) holds the true value. A guaranteed set must hold every "
                 "one where the bound holds at the truth; a confidence interval holds each with its level."
                 + (" The model cannot represent the simulator exactly (see \"Two truths\"), so the deviations "
                    "from its best approximation are given too." if len(truths) > 1 else ""))
    page.table(pd.DataFrame.from_dict(rows, orient="index").rename_axis("estimate"),
               "Deviation of each estimate from the truth, summarised.", float_format="{:.3g}", name="truth_summary")
    page.table(deviation_percent(ests, m.theta_true, m.param_names),
               "Deviation from the truth (the simulator's parameters), 100 (theta_hat - theta) / |theta| [%], per "
               "parameter and estimate.", float_format="{:.3g}", name="truth_deviation")


def _cell(v) -> str:
    """A table cell as text: floats to 4 significant digits, booleans yes/no."""
    if isinstance(v, bool | np.bool_):
        return _yes(v)
    if isinstance(v, float | np.floating):
        return "–" if np.isnan(v) else f"{v:.4g}"
    return str(v)


def _yes(b) -> str:
    return "yes" if bool(b) else "no"


def _truth(r: StudyResult) -> tuple[np.ndarray, str] | None:
    """(values, name) the page compares with (:func:`boundid.studies.runner.reference_values`)."""
    return reference_values(r.config, r.model)


def _headline(r: StudyResult, verdicts: list[Claim]) -> str:
    """One sentence under the title: for a paper's study the data's origin and the claims' verdicts
    first, then the bound at the truth and the guarantee."""
    ex, parts = r.exact, []
    if verdicts:
        parts.append(f"On simulated data (true parameters from {TRUTH_SOURCE.get(r.config.robot, 'the paper')}): "
                     f"{claims_summary(verdicts)}")
    if ex is not None and ex.evidence is not None and r.config.experiment.source != "simulate":
        parts.append(f"Under the bound e_max = {ex.bound_text()}, which no truth checks on measured data"
                     if ex.consistent else f"The data contradict the bound e_max = {ex.bound_text()}")
    if ex is not None and _truth(r) is not None and np.isfinite(ex.truth_error_ratio):
        parts.append("The error bound holds at the truth" if ex.truth_violations == 0 else
                     f"The error bound is broken at the truth on {ex.truth_violations} rows")
    certs = [ex.certificates[lab] for lab in _guaranteed_sets(r) if lab in ex.certificates] if ex else []
    if certs:
        parts.append("every guaranteed set contains the exact polytope" if all(c.contains_polytope for c in certs)
                     else "a guaranteed set MISSES part of the exact polytope")
    if not parts:
        return ""
    parts = [parts[0][0].upper() + parts[0][1:]] + [p[0].lower() + p[1:] for p in parts[1:]]
    return "; ".join(parts) + "."


def study_page(r: StudyResult) -> Page:
    """Build the page of ``r`` (nothing written): the findings box under the title, "Does it
    reproduce?", the set-up, then the paper's tables and the rest. A section, figure or projection
    that fails is left out and listed, with the run's own failures, in the last section, "What failed".
    Each estimator is drawn in its method's style (:meth:`StudyConfig.styles`)."""
    with F.method_styles(F.study_styles(r.config)):
        return _page(r)


def _citations(r: StudyResult) -> list[tuple[str, str]]:
    """(label, key) of the works named in full under the headline: the paper the study reproduces, else the
    sources of its published values (:func:`boundid.report.glossary.study_citations`)."""
    from boundid.report.glossary import study_citations

    return study_citations(r.config)


def _page(r: StudyResult) -> Page:
    started = time.perf_counter()
    cfg = r.config
    failures = list(r.failures)
    guard = _Guard(failures)
    verdicts: list[Claim] = []
    with guard("section", "paper verdicts"):
        verdicts = claims(r)
    box = findings(r, verdicts, failures)
    headline = _headline(r, verdicts)
    page = Page(cfg.title, headline, setup=box, glossary=True, cites=_citations(r))
    if verdicts:
        _verdict_section(page, r, verdicts)
        with guard("section", "the standard form's stability"):
            _stability_section(page, r)
    page.section("Set-up", describe(cfg))
    if cfg.description.strip():
        page.text("Notes from the study file: " + " ".join(cfg.description.split()))
    setup = _setup(r)
    page.table(pd.DataFrame({"value": [str(v) for v in setup.values()]},
                            index=pd.Index(list(setup), name="setting")),
               "The run's set-up. Figures from iterative solvers and long recursions (OBE update counts, volumes, "
               "LP/SDP optima) may differ in their last digits between machines (BLAS, CPU); on one machine the "
               "same seed gives the same numbers. Across OpenBLAS kernels (reports/benchmarks/platforms.md) the "
               "kinds and containment verdicts of results.csv are the same, and its numbers agree to a relative "
               f"{PLATFORM_RTOL:g} wherever both kernels give the same regression rows (a rounding difference can flip "
               "an encoder count in a simulated feedback loop), except the limited polytope's, whose choice of "
               "strips may differ.", name="setup")
    if r.design is not None:
        with guard("section", "excitation design"):
            design_section(page, r.design)
    with guard("section", "base parameters"):
        _base_parameter_section(page, r)
    paper = {"h4": _paper_section_h4, "direct_drive": _paper_section_direct_drive}.get(cfg.robot)
    if paper is not None and cfg.experiment.source == "simulate":
        with guard("section", "paper's table"):
            paper(page, r)
    with guard("section", "two truths"):
        _two_truths_section(page, r)
    with guard("section", "estimates against the truth"):
        _truth_section(page, r)
    with guard("section", "recursive set estimates"):
        _convergence_sets(page, r)
    with guard("section", "validation"):
        _validation_section(page, r)
    with guard("section", "choosing the bound"):
        _bound_section(page, r)
    with guard("section", "distance to the exact optimum"):
        _exact_section(page, r, guard)
    with guard("section", "physically consistent bounds"):
        _physical_section(page, r)
    with guard("section", "published values"):
        _published_section(page, r)
    with guard("section", "OBE breakdown rate"):
        _sweep_section(page, r)
    with guard("section", "where the time went"):
        _time_section(page, r, time.perf_counter() - started)
    box["failures"] = "none" if not failures else f"{len(failures)}, listed in the last section"
    if failures:
        standard_obe = any(f.stage == "estimator" and "OBE" in f.subject and "definite" in f.reason
                           for f in failures)
        page.section("What failed",
                     "Reported as it failed; no other answer is substituted, and the rest of the page stands."
                     + (" The standard-form OBE keeps M^-1 by rank-one downdates, which lose positive definiteness "
                        "to rounding when a wide prior meets very informative rows: the reason the H4 paper uses the "
                        "factorized (square-root) form." if standard_obe else ""))
        page.table(pd.DataFrame(failures, columns=["stage", "subject", "failure"]).set_index("stage"),
                   "Failures of the run and of the page.", name="failures")
    page.setup.update({"failures": box["failures"]})
    return page


#: the polytopes' shadows on the page are drawn to this fraction of their width along each axis
#: (:meth:`Polytope.project`): 0.1 % is below a line's width, and at p = 52 the exact shadow needs 3,000 LPs
#: where this needs a few hundred
SHADOW_RTOL = 1e-3

#: what each stage of :func:`boundid.studies.runner.run_study` and of the exact optima does, for the time table
STAGE_NAMES = {
    "design": "design the excitation (the candidates' exact design sets)",
    "data": "simulate and measure, or read the recording", "regressions": "regressions (filter, differentiate, rows)",
    "gamma_star": "gamma*, the smallest bound the data allow (LPs)", "estimators": "every estimator",
    "exact": "exact optima, in all", "consistency": "consistency LP (gamma* at the bound)",
    "lp_bounds": "LP bounds (2p LPs)", "relaxed_bounds": "relaxed bounds", "sdp_outer": "SDP outer ellipsoid",
    "sdp_inner": "SDP inscribed ellipsoid", "sdp_john": "John's ellipsoid (from the inscribed one)",
    "volume_bracket": "bracket of the minimum-volume ellipsoid", "physical": "physically consistent bounds",
    "published": "published values", "validation": "validation (bands, re-simulation)",
    "paper": "the paper's own experiments"}


#: the exact optima's parts in the time table, under their total
PART_MARK = "↳ "


def _time_section(page: Page, r: StudyResult, page_s: float) -> None:
    """Where the run's time went: each stage's wall time [s] and share, the exact optima's parts
    (marked PART_MARK) under their total, and the page up to this table."""
    total = sum(r.timings.values()) + page_s
    rows = []
    for key, seconds in r.timings.items():
        rows.append((STAGE_NAMES.get(key, key), seconds))
        if key == "exact" and r.exact is not None:
            rows += [(PART_MARK + STAGE_NAMES.get(k, k.replace("_", " ")), t) for k, t in r.exact.time_s.items()]
    rows.append(("this page (figures, tables, projections) up to this table", page_s))
    df = pd.DataFrame(rows, columns=["stage", "seconds"]).set_index("stage")
    df["share of the run"] = [f"{100 * t / total:.0f} %" if not name.startswith(PART_MARK) else ""
                              for name, t in rows]
    reg = r.regressions.get(r.config.exact.regression) if r.config.exact.regression else None
    size = f" The exact stage's polytope has p = {reg.W.shape[1]} parameters and N = {reg.n_rows} rows." \
        if reg is not None else ""
    slowest = max(r.timings, key=r.timings.get) if r.timings else None
    page.section("Where the time went",
                 f"{total:.1f} s in all on {platform_line()}; the slowest stage: "
                 f"{STAGE_NAMES.get(slowest, slowest)} ({r.timings.get(slowest, 0.0):.1f} s).{size}")
    page.table(df, f"Wall time of each stage of this run [s]. {PART_MARK.strip()}: the parts of the exact optima "
               "(one after the other; the outer ellipsoid's LPs on two threads). The machine's load varies; "
               "reports/benchmarks/ compares costs side by side.", float_format="{:.2f}", name="times")


def in_bound_units(ex, s: float) -> str:
    """A factor s of the chosen bound in words: "2.21 x gamma* (1.1 x e_max)" under a rule (s x its
    factor, in its scaling's smallest bounds), "1.1 x e_max" for a number."""
    if not np.isfinite(s):
        return "never (the prior box excludes it)" if s == np.inf else "not computed"
    if ex.rule is None:
        return f"{s:.3g} x e_max"
    return f"{s * ex.rule.factor:.3g} x gamma* ({s:.3g} x e_max)"


def _active_rows_finding(r: StudyResult) -> str:
    """How many rows decide gamma* and where they sit (velocity reversals, stops, the edges ...)."""
    ex, rec = r.exact, r.data.recording
    reg = r.regressions[ex.regression]
    sits = pd.DataFrame(where_rows_sit(reg, rec.t, rec.q, rec.tau, ex.evidence.active))
    counts = sits["where"].value_counts() if len(sits) else pd.Series(dtype=int)
    return (f"{len(sits)} rows of {reg.n_rows} hold the Chebyshev fit at gamma*: "
            + ", ".join(f"{n} {w}" for w, n in counts.items()) + " (Choosing the bound)")


def _wider_than_confidence(r: StudyResult) -> str:
    """Median over parameters of each guaranteed interval's width (clipped to the prior box) over the
    first statistical estimate's confidence interval width, on the exact regression."""
    ex = r.exact
    stats = [(lab, e) for (lab, rn), e in r.estimates.items() if rn == ex.regression and e.kind == "statistical"]
    if not stats or ex.bounds is None:
        return ""
    slab, st = stats[0]
    ci = st.intervals[1] - st.intervals[0]
    sets = {"exact": (ex.bounds.lo, ex.bounds.hi)}
    sets |= {lab: clipped_intervals(e, ex.polytope.box) for (lab, rn), e in r.estimates.items()
             if rn == ex.regression and e.set_membership}
    level = f"{100 * st.level:g} %" if st.level else "confidence"
    return (f"median over parameters of the interval width over the {slab} {level} interval: "
            + ", ".join(f"{lab} {np.median((hi - lo) / ci):.3g} x" for lab, (lo, hi) in sets.items()))


def _held_out_finding(r: StudyResult) -> str:
    """The held-out part of a measured recording: each band's coverage of the measured torques and
    its mean half-width ("" without a held-out part)."""
    v = r.validation
    if r.data.info.get("held out") is None or not v.get("torque_bands"):
        return ""
    m = v["validation_measured"]
    parts = []
    for lab, b in v["torque_bands"].items():
        inside = 100 * (1 - (b.outside_fraction(m) if b.error_bound is None else b.outside_measured_fraction(m)))
        band = (f"{lab}'s {band_name(b, m)} (mean half-width {np.nanmean(b.half_width):.3g} N m)"
                if b.error_bound is None else
                f"{lab}'s band (mean half-width {np.nanmean(b.half_width):.3g} N m) widened by e_max")
        parts.append(f"{band} holds {inside:.3g} %")
    return f"{r.data.info['held out']}: " + "; ".join(parts) + " of the measured torques"


def _published_finding(r: StudyResult) -> str:
    """Each table as a whole: from which bound the data allow all its values (and whether it is the
    chosen one), and the values that lie outside their exact intervals alone."""
    pub, ex = r.published, r.exact
    if ex is None or ex.bounds is None:
        return "not compared with exact intervals: the data contradict the bound"
    parts = []
    for _, t in pub.tables.iterrows():
        verdict = "consistent at the chosen bound" if t["together from"] <= 1 else "CONTRADICTED at the chosen bound"
        parts.append(f"{t['published']} ({t['comparable']} values) allowed from "
                     f"{in_bound_units(ex, t['together from'])}, {verdict}")
    v = pub.values
    alone, comparable = v["inside exact"].eq("yes").sum(), v["inside exact"].isin(["yes", "no"]).sum()
    text = (f"as whole tables: {'; '.join(parts)}. Alone (every other parameter free), {alone} of {comparable} "
            "values lie inside their exact intervals")
    if "inside physical" in v:
        out = v[v["inside physical"].eq("no")]
        if len(out):
            text += "; outside the physically consistent interval: " + ", ".join(
                f"{t} {q} = {x:.4g}" for t, q, x in zip(out["published"], out["quantity"], out["value"], strict=True))
    return text


def _published_section(page: Page, r: StudyResult) -> None:
    """The published tables against the data (:mod:`boundid.studies.published`)."""
    pub, ex = r.published, r.exact
    if pub is None:
        return
    page.section("Published values against the data",
                 "Each published value is a combination c^T theta of this model's base parameters (where the "
                 "source's model differs, the study file says which). Alone, a value is allowed by the data if it "
                 "lies in its exact interval [min, max] of c^T theta over the feasible polytope; but that leaves "
                 "every other parameter free. A table as a whole is allowed when one parameter vector takes all its "
                 "values at once and satisfies every row: one LP gives the smallest factor of the bound from which "
                 "that holds (gamma* with the table's values fixed). A table allowed only above the chosen bound "
                 "is contradicted by the data at that bound: its values cannot all be right unless the errors are "
                 "larger than e_max.")
    t = pub.tables.set_index("published")
    summary = pd.DataFrame(index=t.index)
    if ex is not None and ex.bounds is not None:
        summary["all values together allowed from"] = [in_bound_units(ex, s) for s in t["together from"]]
        summary["at the chosen bound"] = ["consistent" if s <= 1 else "contradicted" for s in t["together from"]]
    summary["comparable / values"] = [f"{c} / {n}" for c, n in zip(t["comparable"], t["values"], strict=True)]
    summary["inside exact"] = t["inside exact"]
    summary["inside physical / checked"] = [f"{i} / {c}" for i, c in zip(t["inside physical"],
                                                                         t["physical checked"], strict=True)]
    summary["source"] = t["source"]
    page.table(summary, "Each published table against the data: the factor of the chosen bound from which the data "
               "allow all its values together, its values that are combinations of the base parameters, those "
               "inside their exact intervals alone and (for a single parameter) inside the physically consistent "
               "ones.", float_format="{:.4g}", name="published-tables")
    cols = [c for c in ("published", "name", "quantity", "value", "exact lo", "exact hi", "inside exact",
                        "inside physical", "from bound") if c in pub.values]
    cols += [c for c in pub.values if c.endswith("- value [%]")]
    page.section("Every published value", folded=f"{len(pub.values)} values: each one's exact interval, the bound "
                 "from which the data allow it alone, and the estimates' differences from it")
    page.table(pub.values[cols].set_index("published"),
               "Every published value: the quantity in this model's base parameters, its exact interval, inside it "
               "(and inside the physically consistent interval, for a single parameter), the factor of the chosen "
               "bound from which the data allow the value alone, and each estimate's centre minus the value, in % "
               "of the value.", float_format="{:.4g}", name="published-values")


def _physical_finding(ph) -> str:
    """How much physics adds to the exact intervals, not counting what the sign constraint alone does
    (a lower bound below 0 moved up to 0 narrows an interval without telling anything about the
    parameter's value)."""
    if ph.error is not None:
        return f"not computed: {ph.error.split(':')[0]} (see What failed)"
    iv = ph.intervals
    tol = PHYSICS_GAIN_RTOL * (iv["plain_hi"] - iv["plain_lo"])
    beyond = (iv["phys_hi"] < iv["plain_hi"] - tol) | (iv["phys_lo"] > np.maximum(iv["plain_lo"], 0.0) + tol)
    sign_only = (iv["narrower"] == "yes") & ~beyond
    text = (f"{int(beyond.sum())} of {len(iv)} exact intervals narrower beyond the sign constraint (by more than "
            f"{100 * PHYSICS_GAIN_RTOL:g} % of the width)"
            f"{' (' + ', '.join(iv.index[beyond]) + ')' if 0 < beyond.sum() <= 6 else ''}")
    if sign_only.any():
        text += f"; {int(sign_only.sum())} only lose their negative part or less"
    return text + f" (mean width {ph.mean_width_ratio:.3g} x the plain width)"


#: an exact bound that moved by less than this share of the plain interval's width has not moved
#: (the conic solver's accuracy is about 1e-5 of the widths)
SAME_BOUND_RTOL = 1e-4
#: physics narrows an interval beyond the sign constraint when a bound moves by more than this share of its width
PHYSICS_GAIN_RTOL = 1e-2


def _identified_finding(r: StudyResult) -> str:
    """Which parameters the exact intervals narrow beyond the prior box, by how much: identified (at
    least IDENTIFIED_FACTOR x narrower), narrowed less, not constrained at all."""
    factor = identification(r)
    names = np.array(r.model.param_names)
    ident = factor >= IDENTIFIED_FACTOR
    some = (factor > 1.0 + SAME_BOUND_RTOL) & ~ident
    none = ~ident & ~some

    def listed(mask, with_factor=True) -> str:
        idx = np.flatnonzero(mask)
        if idx.size > 8:
            return (f"{idx.size} parameters" + (f" ({factor[idx].min():.3g}-{factor[idx].max():.3g} x)"
                                                 if with_factor else ""))
        return ", ".join(f"{names[j]}" + (f" {factor[j]:.3g} x" if with_factor else "") for j in idx)

    parts = [f"{int(ident.sum())} of {names.size} identified (exact interval >= {IDENTIFIED_FACTOR:g} x narrower "
             "than the prior)" + (f": {listed(ident)}" if ident.any() else "")]
    if some.any():
        parts.append(f"narrowed less: {listed(some)}")
    if none.any():
        parts.append(f"NOT constrained beyond the prior: {listed(none, False)}")
    return "; ".join(parts)


def _width_finding(r: StudyResult, certs: dict) -> tuple[str, str] | None:
    """Each guaranteed set's mean width over the exact width, on the parameters the data identify
    (elsewhere both are the prior box once intersected with it, a ratio of 1 that says nothing), and
    the raw set's over every parameter."""
    comparison = set_comparison(r)
    if comparison is None:
        return None
    ident = identification(r) >= IDENTIFIED_FACTOR
    per_param = comparison[1]
    if not ident.any():
        raw = {lab: float(np.mean(c.width_ratio)) for lab, c in certs.items()}
        return ("set width / exact width", "no parameter is identified, so the sets ∩ prior box equal the prior box "
                "as the exact set does; raw sets: " + ", ".join(f"{lab} {x:.3g} x" for lab, x in raw.items()))
    raw = {lab: float(np.mean(np.asarray(c.width_ratio)[ident])) for lab, c in certs.items()}
    cells = []
    for lab in certs:
        col = next((c for c in per_param if c.replace(" (unverified)", "") == lab), None)
        clipped = f"{float(np.mean(per_param[col].to_numpy()[ident])):.3g} x" if col is not None else "–"
        cells.append(f"{lab} {clipped} (raw set {raw[lab]:.3g} x)")
    return (f"set width / exact width on the {int(ident.sum())} identified parameters (∩ prior box)",
            ", ".join(cells))


def _cross_validation_finding(r: StudyResult) -> str:
    """The cross-validation torque bands of a simulated study against the signal they predict: each
    band's mean half-width and the share of samples inside ("" without a second trajectory)."""
    v = r.validation
    if r.data.info.get("held out") is not None or not v.get("torque_bands"):
        return ""
    m = v["validation_measured"]
    peak = float(np.nanmax(np.abs(m)))
    parts = [f"{lab} +-{np.nanmean(b.half_width):.3g} N m ({100 * (1 - b.outside_fraction(m)):.4g} % inside)"
             for lab, b in v["torque_bands"].items()]
    return f"on torques up to {peak:.3g} N m, mean half-widths: " + "; ".join(parts)


def _physical_section(page: Page, r: StudyResult) -> None:
    """The exact bounds with the model's physical constraints beside the plain exact bounds, and
    whether each statistical estimate is physically consistent ([WensingKimSlotine2018])."""
    ex = r.exact
    ph = ex.physical if ex is not None else None
    if ph is None:
        return
    if ph.error is not None:
        return
    n = len(ph.intervals)
    negative = int((ph.intervals["plain_lo"] < 0).sum() - (ph.intervals["phys_lo"] < 0).sum())
    page.section("Physically consistent exact bounds",
                 f"The exact polytope of the {ex.regression} rows and the prior box knows nothing of physics: its "
                 f"intervals reach into negative inertias, masses or friction. Intersected with the model's "
                 f"{ph.n_constraints} physical constraints (docs/models.md; {ph.method}, certificate: "
                 f"{ph.certificate}), {ph.narrower} of {n} intervals are narrower and {negative} lower bounds move "
                 f"from below 0 to 0 or above; gamma* is {ph.gamma_plain:.4g} without physics and "
                 f"{ph.gamma_phys:.4g} with it (<= 1: the data and physics agree within the bound).")
    df = ph.intervals.copy()
    df.columns = ["plain lo", "plain hi", "physical lo", "physical hi", "width ratio", "narrower?", "truth inside?"]
    if df["truth inside?"].isna().all():
        df = df.drop(columns="truth inside?")
    page.table(df, "Exact bounds per parameter, plain (strips ∩ prior box) and physically consistent, in SI "
               "units; width ratio = physical width / plain width.", name="physical_bounds")
    if len(ph.estimates):
        est = ph.estimates.rename(columns={"margin": "physical margin", "consistent": "physically consistent?",
                                           "worst": "most violated constraint"})
        page.table(est, "Is each statistical estimate's centre physically consistent? The margin is minus the "
                   "largest violation of a constraint (>= 0: consistent; for base parameters, at the standard "
                   "parameters that violate the constraints least, in scaled units); the most violated constraint "
                   "is named with its violation in parameter units.", name="physical_estimates")


def _sweep_section(page: Page, r: StudyResult) -> None:
    sweep = r.validation.get("obe_sweep")
    if sweep is None:
        return
    page.section("OBE breakdown over noise seeds",
                 f"Whether a recursion breaks down depends on rounding, so one run's pass or fail can flip between "
                 f"machines. The study re-draws the measurement noise of the same experiment {len(sweep.seeds)} "
                 f"times and refits every OBE on the {sweep.regression} rows; the rate is the conclusion.")
    rows = {}
    for lab, o in sweep.outcomes.items():
        reasons = sorted({x.split(":")[0] for x in o if x is not None})
        rows[lab] = {"breakdowns": sum(x is not None for x in o), "seeds": len(o),
                     "rate [%]": 100.0 * sweep.rate(lab), "how": ", ".join(reasons) or "–"}
    page.table(pd.DataFrame.from_dict(rows, orient="index").rename_axis("estimator"),
               "Breakdowns (an exception, or a set the recursion could not vouch for) per noise seed.",
               float_format="{:.3g}", name="obe_breakdown")


def _base_parameter_section(page: Page, r: StudyResult) -> None:
    """What each parameter is, when the model names combinations by symbols (base parameters)."""
    m = r.model
    if tuple(m.param_definitions) == tuple(m.param_names):
        return
    page.section("Base parameters", folded=f"{m.p} identifiable combinations of the standard parameters: what each "
                                            "symbol stands for")
    page.text("The regressor of the standard parameters is rank deficient; its independent columns (QR with column "
              "pivoting on random states [GautierKhalil1990]) define the base parameters. A symbol ending in R is "
              "the standard parameter with others regrouped into it; every estimator and every exact bound on this "
              "page is in these parameters.")
    table = pd.DataFrame({"definition": list(m.param_definitions), "unit": list(m.param_units)},
                         index=pd.Index(list(m.param_names), name="parameter"))
    truth = _truth(r)
    if truth is not None:
        table[truth[1]] = truth[0]
    page.table(table, "Base parameters: symbol, definition in standard parameters, unit"
               + (" and true value." if truth is not None else "."), name="base_parameters")


def _exported_estimate(r: StudyResult):
    """(label, Estimate) exported to the robot's own formats: the WLS (else the first statistical)
    estimate on the exact regression, or None."""
    reg = r.config.exact.regression
    found = [(lab, e) for (lab, rn), e in r.estimates.items() if rn == reg and e.kind == "statistical"]
    found.sort(key=lambda item: item[1].method != "WLS")
    return found[0] if found else None


def _export_section(page: Page, r: StudyResult, folder: Path) -> None:
    """Write the exported estimate in the robot's own formats into ``folder`` and say so on the page."""
    chosen = _exported_estimate(r)
    if chosen is None:
        return
    label, est = chosen
    reg = r.config.exact.regression
    folder.mkdir()
    try:
        paths = r.model.export_identified(est.center, folder, estimate=f"the {label} centre on the {reg} regression",
                                          cov=est.statistics.cov if est.statistics is not None else None)
    except RUN_FAILURES as exc:
        shutil.rmtree(folder)
        page.section("Identified parameters, exported",
                     f"Exporting the {label} estimate failed and nothing was written: {exc}")
        return
    if not paths:  # the robot has no format of its own
        folder.rmdir()
        return
    raw = [p for p in paths if p.stem.endswith("_unconstrained")]  # the estimate itself, when projected
    for path in paths:
        page.attach(path.name, f"{folder.name}/{path.name}", f"{label} centre, not physically consistent: tables "
                    "only" if path in raw else f"{label} estimate, exported")
    text = (f"The {label} centre on the {reg} regression, in the robot's own formats: "
            + ", ".join(p.name for p in paths if p not in raw) + f" (in {folder.name}/). ")
    if raw:
        ph = r.exact.physical if r.exact is not None else None
        worst = ph.estimates["worst"].get(label, "") if ph is not None and len(ph.estimates) else ""
        text = (f"The {label} centre on the {reg} regression is not physically consistent"
                + (f" (most violated: {worst})" if worst else "") + ", so it is not exported as a URDF: it is in "
                + " and ".join(p.name for p in raw) + " only. Exported instead, in the robot's own formats ("
                + ", ".join(p.name for p in paths if p not in raw) + f", in {folder.name}/): its projection onto "
                f"the physical set, the least squares in the {label} covariance metric under the physical "
                "constraints (the LMI-constrained fit; the files' headers name the active constraints). ")
    text += ("Every link of the URDF copy is a rigid body (mass > 0, principal moments with A + B > C), so pinocchio "
             "and MuJoCo load it as it is; friction is in its <dynamics>, and the joints' armature, damping and "
             "frictionloss in the MJCF fragment (its header says how to apply it).")
    if tuple(r.model.param_definitions) != tuple(r.model.param_names):
        text += (" Base parameters fix combinations of the standard ones only: the standard parameters written are "
                 "the ones nearest the URDF's values whose links are rigid bodies, the armature (a joint property, "
                 "never a link inertia) taking what a combination leaves, or for a projection that the solver cannot "
                 "place there, the projection's own (the files' headers say which); the tables list both sets.")
    page.section("Identified parameters, exported", text)


def write_study_report(r: StudyResult, out_dir: str | Path) -> Path:
    """Write ``out_dir/index.html`` (self-contained) with figures/, tables/, summary.md and results.csv.

    The folder is written as a whole into a hidden sibling and swapped into place (see
    :func:`boundid.report.output.replace_folder`): a run killed while writing leaves the previous
    page as it was. A ``campaign/`` sub-folder (``boundid campaign``) is carried over.
    """
    out_dir = Path(out_dir)
    page = study_page(r)
    with replace_folder(out_dir, keep=("campaign",)) as tmp:
        r.table.to_csv(tmp / "results.csv", index=False)
        write_verdict_file(r, tmp, run_verdict(r).line)  # every check of the run (docs/verdict-file.md)
        _export_section(page, r, tmp / "export")
        page.write(tmp / "index.html")
    return out_dir / "index.html"
