"""The physical-consistency stage of a study: the exact bounds of the feasible set intersected
with the model's physical constraints, beside the plain exact bounds, and whether each
statistical estimate is physically consistent.

    P_phys = P ∩ {theta : the model's physical constraints}     (P: strips ∩ prior box)

Inertias, masses and friction coefficients cannot be negative, a link's inertia tensor must be
that of a body ([WensingKimSlotine2018]); P ignores this, so a plain exact interval can reach
into parameter values no robot has. The stage computes, on the same regression and prior box as
the exact LP bounds (:class:`boundid.sets.physical.PhysicalSet`, an LP with linear constraints, a
conic program by Clarabel otherwise):

* per parameter: the plain LP interval, the physically consistent interval, the ratio of their
  widths, and (simulated data) whether the truth lies in the physical interval;
* per statistical estimate (OLS, WLS, RLS, Kalman): the physical margin of its centre
  (:func:`boundid.sets.physical.physical_margin`; >= 0: consistent) and the most violated
  constraint (:func:`most_violated`; for base parameters of standard ones, at the standard
  parameters that violate the constraints least).

A failure (empty physical set, solver failure) is returned as ``error``, never replaced.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pandas as pd

from boundid.errors import InfeasibleDataError, SolverError
from boundid.estimators.estimate import Estimate
from boundid.sets.conic import ConicProblem
from boundid.sets.constraints import PhysicalConstraints
from boundid.sets.physical import PhysicalBounds, PhysicalSet, physical_margin
from boundid.sets.polytope import Polytope


@dataclass
class PhysicalResult:
    """intervals : one row per parameter: plain_lo, plain_hi, phys_lo, phys_hi, width_ratio
        (physical width / plain width), narrower (yes/no), truth_inside (simulated data; NA else)
    estimates : one row per statistical estimate: margin (>= 0: the centre is physically
        consistent), consistent (yes/no), worst (the most violated constraint and its violation,
        :func:`most_violated`; "" if none)
    bounds : the PhysicalBounds (None when ``error``); method, certificate: how they were solved
    n_constraints : number of constraint rows (linear rows, cones, LMIs)
    gamma_plain, gamma_phys : gamma* of P and of P_phys (> 1: the data contradict the bound, or physics)
    time_s : time of the stage [s]; error : what failed (None when nothing did)
    """

    intervals: pd.DataFrame
    estimates: pd.DataFrame
    bounds: PhysicalBounds | None
    method: str
    certificate: str
    n_constraints: int
    gamma_plain: float
    gamma_phys: float
    time_s: float
    error: str | None = None

    @property
    def mean_width_ratio(self) -> float:
        return float(self.intervals["width_ratio"].mean()) if len(self.intervals) else float("nan")

    @property
    def narrower(self) -> int:
        """Number of parameters whose physical interval is narrower than the plain one."""
        return int((self.intervals["narrower"] == "yes").sum()) if len(self.intervals) else 0


def most_violated(constraints: PhysicalConstraints, theta) -> tuple[float, str]:
    """(margin, worst) of theta (p,): its physical margin (:func:`physical_margin`, >= 0: consistent)
    and, when < 0, the constraint violated most, "label (what it is) by v", "" otherwise.

    v is the violation of :meth:`PhysicalConstraints.check`: a lower bound on the distance to the
    constraint's set, in the units of x (exact for a linear row: 0.5 N m for a Coulomb coefficient
    of -0.5 N m). Not lifted, x = theta and the constraint is check's worst. Lifted (theta = K x,
    base parameters), no constraint can be judged at theta alone: x is the standard vector that
    maximises the margin (physical_margin's), and the constraint the one of the largest violation
    in that program's measure (rows and cones divided by their norms, LMIs after its congruence, in
    the scaled coordinates x / scale; every x with K x = theta violates some constraint by -margin
    or more in that measure).
    """
    margin, x = physical_margin(constraints, theta)
    if margin >= 0:
        return float(margin), ""
    v = constraints.check(x).violations
    if constraints.is_lifted:
        dx = constraints.scale if constraints.scale is not None else np.ones(constraints.dim)
        cons = constraints.in_coordinates(np.zeros(constraints.dim), np.diag(dx))
        w = x / dx
        probe = ConicProblem(constraints.dim)
        for L in cons.lmis:
            probe.add_lmi(L.F0, L.F)
        lmis = [-np.linalg.eigvalsh(F0 + np.tensordot(w, F, axes=1))[0] for F0, F in probe.psds]
        n_rows = cons.linear.m + len(cons.cones)
        k = int(np.argmax(np.concatenate([cons.violations(w)[0][:n_rows], lmis])))
    else:
        k = int(np.argmax(v))
    reason = constraints.reasons[k]
    what = f" ({reason.split(':')[0]})" if ":" in reason else ""
    return float(margin), f"{constraints.labels[k]}{what} by {v[k]:.3g}"


def _estimate_rows(constraints: PhysicalConstraints, estimates: dict[str, Estimate]) -> pd.DataFrame:
    rows = []
    for label, est in estimates.items():
        if est.kind != "statistical":
            continue
        margin, worst = most_violated(constraints, est.center)
        rows.append({"estimate": label, "margin": margin, "consistent": "yes" if margin >= 0 else "no",
                     "worst": worst})
    return pd.DataFrame(rows, columns=["estimate", "margin", "consistent", "worst"]).set_index("estimate")


def physical_stage(P: Polytope, constraints: PhysicalConstraints, names, estimates: dict[str, Estimate],
                   truth=None) -> PhysicalResult:
    """The physically consistent exact bounds of ``P``'s strips and box under ``constraints``,
    beside P's plain LP bounds, and the physical consistency of each statistical estimate.

    P : the study's exact polytope (strips ∩ prior box); constraints : the model's
    ``physical_constraints()`` on the same p parameters; names : p parameter names;
    estimates : label -> Estimate (only statistical ones are judged); truth : (p,) or None.
    """
    t0 = time.perf_counter()
    S = PhysicalSet(P.W, P.y, P.e_max, constraints, box=P.box, plain=P)  # P's LP bounds, solved once
    est_rows = _estimate_rows(constraints, estimates)
    n_cons = len(constraints)
    empty = pd.DataFrame(columns=["plain_lo", "plain_hi", "phys_lo", "phys_hi", "width_ratio", "narrower",
                                  "truth_inside"])
    try:
        plain = P.bounds()
        c = S.consistency()
        if c.empty:
            raise InfeasibleDataError(
                f"no physically consistent parameter vector satisfies every strip: gamma* is {c.gamma_plain:.4g} "
                f"without physics and {c.lower:.4g} with it (> 1); the data contradict the model's physics within "
                "the bound — look for model error or a bound set too tight")
        b = S.bounds()
    except (InfeasibleDataError, SolverError) as exc:
        return PhysicalResult(empty, est_rows, None, S.method, "", n_cons, float("nan"), float("nan"),
                              time.perf_counter() - t0, f"{type(exc).__name__}: {exc}")
    width_plain, width_phys = plain.hi - plain.lo, b.hi - b.lo
    ratio = np.divide(width_phys, width_plain, out=np.full_like(width_phys, np.nan), where=width_plain > 0)
    if truth is None:
        inside = [pd.NA] * len(names)
    else:
        t = np.asarray(truth, dtype=float)
        tol = 1e-9 * np.maximum(1.0, np.abs(t))
        inside = ["yes" if ok else "no" for ok in (b.lo - tol <= t) & (t <= b.hi + tol)]
    table = pd.DataFrame({"plain_lo": plain.lo, "plain_hi": plain.hi, "phys_lo": b.lo, "phys_hi": b.hi,
                          "width_ratio": ratio,
                          "narrower": np.where(width_phys < (1 - 1e-6) * width_plain, "yes", "no"),
                          "truth_inside": inside}, index=pd.Index(list(names), name="parameter"))
    return PhysicalResult(table, est_rows, b, b.method, b.certificate, n_cons, float(c.gamma_plain), float(c.gamma),
                          time.perf_counter() - t0)
