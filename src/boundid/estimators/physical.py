"""Physically consistent estimates: least squares under the model's physical constraints, and
set estimates intersected with the physical set.

* :func:`physical_least_squares` is OLS or Gautier's WLS (:mod:`boundid.estimators.least_squares`)
  solved under the constraints (a conic program: Clarabel through cvxpy, as [FloBaRoID] solves
  its LMI-constrained least squares [WensingKimSlotine2018]). Its confidence set is the
  unconstrained estimator's chi-square ellipsoid intersected with the physical set: a truth that
  is physical lies in the intersection exactly when it lies in the ellipsoid, so the level is
  unchanged. Its intervals are the unconstrained Student-t intervals cut by the bounds every
  physical vector obeys (single-parameter rows such as b >= 0): a physical truth is in the cut
  interval exactly when it is in the uncut one, so each keeps its level (cutting them by the
  ellipsoid ∩ physics bounds would not: two 95 % statements together hold only at 90 %).
  What no longer holds when a constraint is active at the solution: the covariance
  sigma^2 (W^T W)^-1 and the Student-t intervals describe the unconstrained estimator, not this
  one (its distribution is truncated at the constraint); they are reported only when no
  constraint is active, where the two estimates coincide.
* :func:`physical_intersection` intersects a guaranteed (or unverified) ellipsoid, e.g. the
  OBE's, with the physical set: its intervals are the bounds over E ∩ physics (one SOCP/SDP per
  bound, :class:`boundid.sets.physical.ConstrainedEllipsoid`); every physically consistent
  parameter vector in E is kept, so a physical truth inside E stays inside.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from boundid._validation import as_regression
from boundid.errors import InfeasibleDataError, InputError
from boundid.estimators.estimate import Estimate, Statistics
from boundid.estimators.least_squares import ols, wls
from boundid.sets.constraints import PhysicalConstraints
from boundid.sets.ellipsoid import Ellipsoid
from boundid.sets.physical import ConstrainedEllipsoid, column_bounds, constrained_fit, physical_margin


def _check_constraints(constraints, p: int) -> PhysicalConstraints:
    if not isinstance(constraints, PhysicalConstraints):
        raise InputError(f"constraints must be a PhysicalConstraints (e.g. model.physical_constraints()), got "
                         f"{type(constraints).__name__}.")
    if constraints.n_params != p:
        raise InputError(f"the constraints are on {constraints.n_params} parameters but W has {p} columns; take "
                         "them from the same model.")
    return constraints


def physical_least_squares(W, y, constraints: PhysicalConstraints, groups=None, level: float = 0.95,
                           names=None) -> Estimate:
    """OLS (``groups`` None) or WLS (per-group weights, as :func:`wls`) under the physical constraints.

    Returns an Estimate (kind "statistical") whose centre is the constrained solution, whose set is
    the unconstrained confidence ellipsoid at ``level`` intersected with the physical set
    (:class:`ConstrainedEllipsoid`, its exact bounds in ``info["set_intervals"]``) and whose
    intervals are the unconstrained Student-t ones cut by :func:`column_bounds` (module
    docstring). ``statistics``: dof and sigma at the constrained solution (of the weighted problem
    for WLS), the unconstrained condition number; std_err, rel_std_pct and cov only when no
    constraint is active (else NaN, see the module docstring; ``info["statistics"]`` says which).
    ``info``: rss, active_constraints (labels), standard (the standard parameters x at the solution
    when lifted), unconstrained (the OLS/WLS centre) and unconstrained_consistent (whether it is
    physical); WLS adds its sigma_groups.
    Raises InfeasibleDataError if no physically consistent vector lies in the confidence ellipsoid.
    """
    t0 = time.perf_counter()
    W, y = as_regression(W, y)
    N, p = W.shape
    constraints = _check_constraints(constraints, p)
    raw = ols(W, y, level=level, names=names) if groups is None else wls(W, y, groups, level=level, names=names)
    if groups is None:
        row_w = np.ones(N)
    else:
        inverse = np.unique(np.asarray(groups), return_inverse=True)[1]
        row_w = 1.0 / raw.info["sigma_group_values"][inverse]
    Ws, ys = W * row_w[:, None], y * row_w
    theta, x, active = constrained_fit(Ws, ys, constraints)
    res = ys - Ws @ theta
    rss = float(res @ res)
    dof = raw.statistics.dof
    region = ConstrainedEllipsoid(raw.set, constraints)
    try:
        region.intervals()
    except InfeasibleDataError:
        raise InfeasibleDataError(
            f"{raw.method}: its confidence ellipsoid at level {level} holds no physically consistent parameter "
            f"vector (the nearest physical fit has rss {rss:.6g} against {raw.info['rss']:.6g} unconstrained): "
            "the data contradict the model's physics at this level; look for model error.") from None
    clo, chi = column_bounds(constraints)
    lo, hi = np.maximum(raw.intervals[0], clo), np.minimum(raw.intervals[1], chi)
    margin = physical_margin(constraints, raw.center)[0]
    sigma = float(np.sqrt(rss / dof))
    info = {"rss": rss, "active_constraints": active, "unconstrained": raw.center,
            "unconstrained_consistent": bool(margin >= 0.0), "set_intervals": region.intervals(),
            "set_certificate": region.info.get("certificate", "")}
    if constraints.is_lifted:
        info["standard"] = x
    st = raw.statistics
    if active:
        nan = np.full(p, np.nan)
        statistics = Statistics(cov=np.full((p, p), np.nan), std_err=nan, rel_std_pct=nan.copy(), dof=dof,
                                sigma=sigma, condition_number=st.condition_number, noise_variance=st.noise_variance)
        info["statistics"] = ("constraints active at the solution: the covariance and Student-t intervals of least "
                              "squares do not describe this truncated estimator; the set is the unconstrained "
                              f"{100 * level:g} % ellipsoid ∩ physics")
    else:
        statistics = Statistics(cov=st.cov, std_err=st.std_err, rel_std_pct=st.rel_std_pct, dof=dof, sigma=sigma,
                                condition_number=st.condition_number, noise_variance=st.noise_variance)
        info["statistics"] = "no constraint active: the same estimate and statistics as unconstrained"
    for key in ("sigma_groups", "groups", "sigma_group_values"):
        if key in raw.info:
            info[key] = raw.info[key]
    return Estimate(method=f"{raw.method} (physical)", center=theta, set=region, intervals=(lo, hi),
                    kind="statistical", level=raw.level, names=raw.names, n_samples=N,
                    time_s=time.perf_counter() - t0, statistics=statistics, info=info)


def physical_intersection(estimate: Estimate, constraints: PhysicalConstraints) -> Estimate:
    """The estimate's ellipsoid intersected with the physical set (module docstring).

    The result keeps the estimate's kind (a guaranteed set stays guaranteed for a physical truth),
    has the set :class:`ConstrainedEllipsoid`, its exact intervals, and as centre the mean of the
    2p extreme points (a point of the intersection). ``info`` copies the estimate's and adds
    raw_center, raw_intervals, raw_consistent (whether the raw centre is physical) and
    physical (solver statistics and the certificate of the intervals).
    Raises InfeasibleDataError if the ellipsoid holds no physically consistent vector.
    """
    if not isinstance(estimate, Estimate):
        raise InputError(f"estimate must be an Estimate, got {type(estimate).__name__}.")
    E = estimate.set
    if not isinstance(E, Ellipsoid):
        raise InputError(f"{estimate.method}: physical_intersection needs an ellipsoidal set, got "
                         f"{type(E).__name__ if E is not None else 'none'}.")
    constraints = _check_constraints(constraints, E.dim)
    t0 = time.perf_counter()
    region = ConstrainedEllipsoid(E, constraints)
    try:
        lo, hi = region.intervals()
    except InfeasibleDataError as exc:
        raise InfeasibleDataError(f"{estimate.method}: {exc}") from None
    info = {**estimate.info, "raw_center": estimate.center, "raw_intervals": estimate.intervals,
            "raw_consistent": bool(physical_margin(constraints, estimate.center)[0] >= 0.0),
            "physical": {**region.info, "time_s": time.perf_counter() - t0}}
    return replace(estimate, method=f"{estimate.method} ∩ physics", center=region.extreme_points.mean(axis=0),
                   set=region, intervals=(lo, hi), info=info)
