"""One registered estimator on one regression of a study: the prior box of the study file, the
regression as the estimator registry's :class:`~boundid.estimators.method.Problem`, and the run."""

from __future__ import annotations

import time

import numpy as np

from boundid.errors import StudyError
from boundid.estimators import Estimate
from boundid.estimators.method import Problem
from boundid.estimators.registry import METHODS
from boundid.experiments.regression import Regression
from boundid.models import RobotModel
from boundid.sets import Box
from boundid.studies.config import EstimatorConfig, PriorConfig, prior_box


def estimation_problem(ec: EstimatorConfig, reg: Regression, model: RobotModel, prior: PriorConfig) -> Problem:
    """The regression as the estimator registry sees it: rows grouped by joint, the study's prior
    box, the estimator's bound e_max, a history of at most ~2000 records."""
    return Problem(W=reg.W, y=reg.y, groups=reg.joint, names=model.param_names, unit=reg.unit,
                   prior=Box.from_center(*prior_box(model, prior)), e_max=ec.e_max,
                   record_every=max(1, reg.n_rows // 2000))


def run_estimator(ec: EstimatorConfig, reg: Regression, model: RobotModel, prior: PriorConfig) -> Estimate:
    """One registered estimator (:data:`boundid.estimators.registry.METHODS`) on one regression."""
    method = METHODS[ec.method]
    if method.needs_bound and ec.e_max is None:
        raise StudyError(f"estimator {ec.label!r}: e_max (the bound on |y - w^T theta|, in {reg.unit}) is required "
                         f"by the {ec.method} method.")
    t0 = time.perf_counter()
    est = method.run(estimation_problem(ec, reg, model, prior), ec.options)
    if not np.isfinite(est.time_s):
        est.time_s = time.perf_counter() - t0
    return est
