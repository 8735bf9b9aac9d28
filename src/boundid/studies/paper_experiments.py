"""The extra fits a paper's claims need, beyond the study's own estimators (run by the study, read by
:mod:`boundid.studies.reproduction`).

- H4 ([H4Paper] abstract, Sect. III): where the standard form breaks down and the factorized one
  does not (:func:`boundid.studies.obe_stability.standard_form_stability`).
- H4 ([H4Paper] Sect. IV.B): "the prior bounds ... were chosen as 5 % of the measurement range of the
  torques (+-15 N m). Then they were increased to 15 % in order to ensure that the number of outliers
  remains negligible": the paper's own estimator (the factorized OBE) refitted at each bound of the
  [paper] table's ``bound_percents`` (share of ``torque_range``, N m), its outlier rate and how
  often the simulator's truth breaks each bound.
- Direct-drive arm ([DirectDrivePaper] Sect. 6.4): "in case of knowledge of the Coulomb coefficients
  and their use for friction compensation, the supplied energy model should have similar
  performances that the filtered power model": RLS on the supplied energy rows with the Coulomb
  terms of the truth moved to the measured side (their columns dropped), started as the study's RLS
  (the paper's: theta(0) = 0, P(0) = 1000 I).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from boundid.errors import RUN_FAILURES
from boundid.estimators import Estimate
from boundid.estimators.rls import RLS, RLSOptions
from boundid.experiments.regression import Regression
from boundid.models import RobotModel
from boundid.studies.config import StudyConfig
from boundid.studies.data import StudyData
from boundid.studies.estimation import run_estimator
from boundid.studies.obe_stability import standard_form_stability


@dataclass
class BoundTrial:
    """The paper's estimator refitted at one error bound: ``percent`` of the torque range, the bound
    e_max [N m], its outliers among ``rows``, the rows on which the simulator's truth exceeds the
    bound (``truth_over``), and the failure (None when the fit ran)."""

    percent: float
    e_max: float
    outliers: int
    rows: int
    truth_over: int
    failure: str | None = None

    @property
    def rate_percent(self) -> float:
        """Outliers as a percentage of the rows."""
        return 100.0 * self.outliers / max(self.rows, 1)


@dataclass
class KnownCoulomb:
    """RLS on supplied energy with the Coulomb coefficients known: the full (p,) vector (the
    Coulomb entries are the truth's), the indices of the Coulomb parameters, and the estimate on
    the other parameters."""

    center: np.ndarray
    coulomb: list[int]
    estimate: Estimate


def paper_estimator(cfg: StudyConfig):
    """The study's estimator that runs the H4 paper's method: the factorized OBE (None if absent)."""
    return next((ec for ec in cfg.estimators
                 if ec.method == "obe" and getattr(ec.options, "form", None) == "factorized"), None)


def bound_trials(cfg: StudyConfig, model: RobotModel, regressions: dict[str, Regression]) -> list[BoundTrial]:
    """[H4Paper] Sect. IV.B: the factorized OBE at each bound of ``[paper] bound_percents`` (percent
    of ``[paper] torque_range`` N m) on its own regression; [] where the study has neither."""
    ec, paper = paper_estimator(cfg), cfg.paper
    if ec is None or "bound_percents" not in paper or "torque_range" not in paper:
        return []
    rn = ec.regressions[0]
    reg = regressions[rn]
    truth_error = np.abs(reg.y - reg.W @ model.theta_true) if cfg.experiment.source == "simulate" else None
    out = []
    for pct in paper["bound_percents"]:
        e_max = float(pct) / 100.0 * float(paper["torque_range"])
        over = int(np.sum(truth_error > e_max)) if truth_error is not None else -1
        try:
            est = run_estimator(replace(ec, e_max=e_max), reg, model, cfg.prior)
        except RUN_FAILURES as exc:
            out.append(BoundTrial(float(pct), e_max, 0, reg.n_rows, over, f"{type(exc).__name__}: {exc}"))
            continue
        out.append(BoundTrial(float(pct), e_max, int(est.outliers.size), est.n_samples, over))
    return out


def known_coulomb_fit(cfg: StudyConfig, model: RobotModel, regressions: dict[str, Regression]) -> KnownCoulomb | None:
    """[DirectDrivePaper] Sect. 6.4: RLS, started as the study's RLS estimator, on the supplied energy rows
    y - W_c theta_c (W_c the Coulomb columns fc1, fc2, theta_c their true values); None where the
    study has no supplied energy regression or no truth."""
    reg = regressions.get("supplied_energy")
    if reg is None or cfg.experiment.source != "simulate":
        return None
    names = list(model.param_names)
    coulomb = [j for j, n in enumerate(names) if n.lower().startswith("fc")]
    if not coulomb:
        return None
    keep = [j for j in range(len(names)) if j not in coulomb]
    y = reg.y - reg.W[:, coulomb] @ model.theta_true[coulomb]
    ec = next((ec for ec in cfg.estimators if ec.method == "rls"), None)  # started as the study's RLS
    o = ec.options if ec is not None else RLSOptions()
    est = RLS(len(keep), center0=o.center0, shape0=o.shape0, forgetting=o.forgetting,
              names=[names[j] for j in keep], record_every=max(1, reg.n_rows // 2000)).fit(reg.W[:, keep], y)
    center = model.theta_true.astype(float).copy()
    center[keep] = est.center
    return KnownCoulomb(center, coulomb, est)


def paper_experiments(cfg: StudyConfig, model: RobotModel, data: StudyData, regressions: dict[str, Regression]) -> dict:
    """The fits the claims of the study's paper need ("bound_trials", "stability", "known_coulomb");
    {} for a study without a paper or on measured data."""
    if cfg.experiment.source != "simulate":
        return {}
    if cfg.robot == "h4":
        out: dict = {"bound_trials": bound_trials(cfg, model, regressions)}
        ec = paper_estimator(cfg)
        if ec is not None:
            out["stability"] = standard_form_stability(cfg, model, data, regressions[ec.regressions[0]])
        return out
    if cfg.robot == "direct_drive":
        return {"known_coulomb": known_coulomb_fit(cfg, model, regressions)}
    return {}
