"""The report page of one study run: set-up, the paper's table beside ours, convergence,
validation, and the distance of every estimator to the exact optimum.

Every number on the page is computed by the run that writes it; the paper's own published
figures appear only in columns and captions labelled "paper".
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd

from boundid.errors import RUN_FAILURES
from boundid.report import figures as F
from boundid.report.html import Page
from boundid.report.output import replace_folder
from boundid.report.tables import deviation_percent, estimate_summary, parameter_table, widths
from boundid.sets import log_unit_ball_volume
from boundid.studies.certify_files import certificate_row
from boundid.studies.runner import Failure, StudyResult


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
    setup["regressions"] = ", ".join(f"{k} ({v.n_rows} rows, {v.unit})" for k, v in r.regressions.items())
    for key, value in r.data.info.items():
        if isinstance(value, int | float):
            setup[key.replace("_", " ")] = f"{value:.4g}"
    setup["seed"] = cfg.seed
    setup["run time"] = f"{sum(r.timings.values()):.1f} s (" + ", ".join(
        f"{k} {v:.1f}" for k, v in r.timings.items()) + ")"
    return setup


def _det_shape(est) -> float:
    """det(M^-1) of E = {(theta - c)^T M (theta - c) <= 1}, the H4 paper's uncertainty volume, from
    ln vol E = ln vol(unit ball) + ln det(M^-1) / 2; for a set of another family, that of the
    ellipsoid of the same volume (NaN where the family cannot give its volume)."""
    return float(np.exp(2.0 * (est.set.log_volume() - log_unit_ball_volume(est.p))))


def _tag(label: str, est) -> str:
    """The label of a set on the page: an unverified set says so."""
    return label if est.kind != "unverified" else f"{label} (unverified)"


def _paper_section_h4(page: Page, r: StudyResult) -> None:
    m, names = r.model, r.model.param_names
    ests = {lab: e for (lab, rn), e in r.estimates.items() if rn == "inverse_dynamic"}
    cols: dict = {"truth (paper Table I centre)": m.theta_true, "a-priori (Table I)": m.theta_prior}
    for lab, e in ests.items():
        cols[f"{lab} centre"] = e.center
        if e.statistics is not None:
            cols[f"{lab} sigma"] = e.statistics.std_err
    if r.exact is not None and r.exact.bounds is not None:
        cols["LP exact"] = (r.exact.bounds.lo, r.exact.bounds.hi)
    for lab, e in ests.items():
        if e.set_membership:
            cols[f"{_tag(lab, e)} interval"] = e.intervals
    page.section("Table I, reproduced",
                 "The simulation's true values are the centre of the paper's Table I; the a-priori values are "
                 "its right column. Every other column is computed by this run.")
    page.table(parameter_table(names, cols), "Identified parameters (SI units) beside the truth and the prior.",
               name="table_I")
    rows = {}
    paper = r.config.paper
    for lab, e in ests.items():
        if not e.set_membership:
            continue
        n = e.n_samples
        rows[_tag(lab, e)] = {"det(M^-1) ours": _det_shape(e),
                              "det(M^-1) paper": paper.get("uncertainty_volume", np.nan),
                              "outliers ours [%]": 100.0 * e.outliers.size / max(n, 1),
                              "outliers paper [%]": f"< {paper.get('outlier_rate_percent_below', 'n/a')}",
                              "updates": e.n_updates, "samples": n}
    if rows:
        page.table(pd.DataFrame.from_dict(rows, orient="index").rename_axis("estimate"),
                   "Uncertainty volume det(M^-1) and outlier rate after all data, beside the paper's.",
                   float_format="{:.4g}", name="volume_outliers")


def _paper_section_direct_drive(page: Page, r: StudyResult) -> None:
    m, names = r.model, r.model.param_names
    rls = {rn: e for (lab, rn), e in r.estimates.items() if e.method == "RLS"}
    page.section("Table II, reproduced: RLS on three regression models",
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
        reg, bands = v["validation_regression"], v["torque_bands"]
        n = r.model.n_joints
        measured = reg.y.reshape(-1, n)
        t = reg.t.reshape(-1, n)[:, 0]
        page.section("Cross-validation: torque bounds of eq. (37)",
                     "On a trajectory not used for identification, the guaranteed torque bounds "
                     "y = w^T theta_hat +- sqrt(w^T M^-1 w) of the OBE, beside the 95 % prediction band of WLS.")
        rows = {lab: {"kind": b.kind, "samples outside [%]": 100 * b.outside_fraction(measured),
                      "mean half-width [N m]": float(np.mean(b.half_width))} for lab, b in bands.items()}
        page.table(pd.DataFrame.from_dict(rows, orient="index").rename_axis("estimate"),
                   "Measured validation torques outside each band.", float_format="{:.3g}", name="crossval")
        main = next((lab for lab, b in bands.items() if b.kind == "guaranteed"), next(iter(bands)))
        extra = {f"{lab} 95 %": (b.lower, b.upper) for lab, b in bands.items()
                 if lab != main and b.kind == "statistical"}
        page.figure(F.torque_bounds(t, measured, bands[main].lower, bands[main].upper,
                                    band_label=f"{main} bounds", extra_bands=extra),
                    f"Measured torque on the validation trajectory inside the {main} bounds (eq. 37).",
                    name="torque_bounds")


def _exact_section(page: Page, r: StudyResult, guard: _Guard) -> None:
    ex = r.exact
    if ex is None:
        return
    m, names = r.model, r.model.param_names
    page.section("Distance to the exact optimum",
                 f"The feasible polytope of the {ex.regression} rows with |e| <= {ex.e_max:g}, intersected with the "
                 f"prior box: gamma* = {ex.gamma_star:.4g} (the data are consistent with the bounds iff gamma* <= 1).")
    if np.isfinite(ex.truth_error_ratio):
        holds = ex.truth_violations == 0
        page.text(f"At the true parameters the largest error is {ex.truth_error_ratio:.3g} x e_max: the bound "
                  + ("holds on every row, so every guaranteed set must contain the truth." if holds else
                     f"is exceeded on {ex.truth_violations} rows, so no set-membership guarantee applies to "
                     "this data set: the truth may legitimately lie outside the sets."))
    for what, msg in ex.errors.items():
        page.text(f"{what}: {msg}.")
    sets = {_tag(lab, e): e for (lab, rn), e in r.estimates.items() if rn == ex.regression and e.set is not None}
    compared = {**{lab: e.intervals for lab, e in sets.items() if e.set_membership},
                **{f"SDP {k}": v.ellipsoid.intervals() for k, v in ex.sdp.items()}}
    if ex.bounds is not None and compared:
        with guard("figure", "width ratios"):
            w = widths(names, {"LP exact": (ex.bounds.lo, ex.bounds.hi), **compared})
            page.figure(F.width_ratios(w), "Per-parameter interval width over the exact LP width (1 = exact).",
                        name="width_ratios")
    logv = {lab: e.set.log_volume() / m.p for lab, e in sets.items() if e.set_membership}
    logv.update({f"SDP {k}": v.ellipsoid.log_volume() / m.p for k, v in ex.sdp.items()})
    if logv:
        with guard("figure", "log volumes"):
            page.figure(F.log_volume_bars(logv), "ln volume per dimension of the guaranteed sets and the SDP "
                        "ellipsoids (the inner ellipsoid is a lower bound on any outer set).", name="log_volumes")
    rows = {lab: certificate_row(cert) for lab, cert in ex.certificates.items()}
    if rows:
        page.table(pd.DataFrame.from_dict(rows, orient="index").rename_axis("estimate"),
                   "Certification of each set-membership estimate against the exact optima (an unverified "
                   "set is certified too, and labelled so).", float_format="{:.4g}",
                   name="certificates")
    ref = (ex.bounds.lo, ex.bounds.hi) if ex.bounds is not None else None
    page.table(estimate_summary({f"{lab} / {rn}": e for (lab, rn), e in r.estimates.items()}, m.theta_true,
                                reference=ref),
               "Every estimate: set kind, volume, mean width (over the exact width), truth containment, run time. "
               "A confidence set's level holds only for white noise independent of the regressors: filtered "
               "equations, differentiated encoder noise and a structural model error all break that, so "
               "confidence sets may miss the truth; guaranteed sets may not, wherever the bound holds.",
               float_format="{:.4g}", name="estimates")
    for a, b in r.config.exact.projections:
        with guard("projection", f"({a}, {b})"):
            idx = [names.index(a), names.index(b)]
            shadow = ex.polytope.project(*idx) if ex.bounds is not None else None
            shadows = {lab: e.set.project(*idx) for lab, e in sets.items()}
            shadows.update({f"SDP {k}": v.ellipsoid.project(*idx) for k, v in ex.sdp.items()})
            centers = {lab: e.center[idx] for lab, e in sets.items()}
            centers.update({f"SDP {k}": v.ellipsoid.center[idx] for k, v in ex.sdp.items()})
            box = ((ex.bounds.lo[idx], ex.bounds.hi[idx]) if ex.bounds is not None else None)
            page.figure(F.projection_2d(shadow, shadows, m.theta_true[idx], box, (a, b), centers=centers,
                                        units=[m.param_units[i] for i in idx]),
                        f"Projection on ({a}, {b}): exact polytope shadow (grey), LP box (dashed), the sets' "
                        "shadows, truth (star).",
                        name=f"projection_{a}_{b}")


def _convergence_sets(page: Page, r: StudyResult) -> None:
    obe = {_tag(lab, e): e.history for (lab, rn), e in r.estimates.items()
           if e.set_membership and e.history is not None}
    if obe:
        page.section("Recursive set estimates over the samples")
        page.figure(F.volume_history({lab: (h.index, h.log_volumes) for lab, h in obe.items()}),
                    "ln volume of the OBE ellipsoids against the number of rows processed.", name="volume_history")
        if "closed_loop" in r.model.experiments:  # the H4 paper's experiment and its figure
            first = next(iter(obe))
            page.figure(F.parameter_convergence(None, {lab: h for lab, h in obe.items()}, r.model.theta_true,
                                                r.model.param_names, units=r.model.param_units),
                        f"Centres of the OBE ellipsoids against the row index (dashed: truth); {first} is the "
                        "paper's estimator.", name="obe_convergence")


def study_page(r: StudyResult) -> Page:
    """Build the page of ``r`` (nothing written). A section, figure or projection that fails is left
    out and listed, with the run's own failures, in the table of the last section, "What failed".
    Each estimator is drawn in its method's style (:meth:`StudyConfig.styles`)."""
    with F.method_styles(r.config.styles()):
        return _page(r)


def _page(r: StudyResult) -> Page:
    cfg = r.config
    page = Page(cfg.title, cfg.description.strip(), setup=_setup(r))
    failures = list(r.failures)
    guard = _Guard(failures)
    paper = {"h4": _paper_section_h4, "direct_drive": _paper_section_direct_drive}.get(cfg.robot)
    if paper is not None:
        with guard("section", "paper's table"):
            paper(page, r)
    with guard("section", "recursive set estimates"):
        _convergence_sets(page, r)
    with guard("section", "validation"):
        _validation_section(page, r)
    with guard("section", "distance to the exact optimum"):
        _exact_section(page, r, guard)
    if failures:
        page.setup["failures"] = f"{len(failures)}, listed in the last section"
        page.section("What failed",
                     "Reported as it failed; no other answer is substituted, and the rest of the page stands. "
                     "The standard-form OBE keeps M^-1 by rank-one downdates, which lose positive definiteness "
                     "to rounding when a wide prior meets very informative rows: the reason the H4 paper uses the "
                     "factorized (square-root) form.")
        page.table(pd.DataFrame(failures, columns=["stage", "subject", "failure"]).set_index("stage"),
                   "Failures of the run and of the page.", name="failures")
    return page


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
        page.write(tmp / "index.html")
    return out_dir / "index.html"
