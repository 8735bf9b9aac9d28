"""Certify a set estimate against the exact feasible polytope: the "distance to the exact optimum".

For the feasible polytope P = {theta : |y_k - w_k^T theta| <= e_k} and an ellipsoid E (a
recursive estimator's final set, or any user's ellipsoid), :func:`validate` reports

(a) whether E contains P: every vertex of P inside E (all vertices for p <= 6; for p > 6 the
    2p vertices where the exact LP bounds are attained, a necessary condition only);
(b) per parameter, the width of E's projection over the exact LP bound width (>= 1 if E ⊇ P);
(c) the log-volume excess of E per dimension, (ln vol E - ln vol E_ref) / p, over
    - the outer reference: an achievable outer ellipsoid of P, the exact minimum-volume one for
      p <= 6 (minimum-volume ellipsoid of the vertices), else the S-procedure ellipsoid on
      tightened strips ([refs §SDP]);
    - the inner (maximum-volume inscribed) ellipsoid: vol(E_in) <= vol(P) <= vol(any outer
      ellipsoid), so this excess bounds the distance to the unknown optimum from above;
    and, for p <= 6, over P itself.
The distance of E to the minimum-volume outer ellipsoid, per dimension, lies between the two
excesses (exactly the outer one for p <= 6).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from boundid.errors import InputError
from boundid.estimators.estimate import Estimate
from boundid.sets import sdp
from boundid.sets.ellipsoid import Ellipsoid
from boundid.sets.polytope import MAX_VERTEX_DIM, Polytope


@dataclass
class Certificate:
    """How far a set estimate is from the exact answers for one polytope.

    method : name of the certified estimate ("ellipsoid" for a bare Ellipsoid)
    names : parameter names
    contains_polytope : every checked vertex of P lies in E
    vertex_kind : "all" (p <= 6: every vertex) or "lp-bound" (the 2p LP-optimal vertices)
    n_vertices, n_outside : vertices checked, and how many lie outside E
    max_mahalanobis2 : largest (v - c)^T S^-1 (v - c) over the checked vertices (<= 1 inside)
    lp_lo, lp_hi : (p,) exact parameter bounds over P (LP)
    lo, hi : (p,) E's projected intervals
    width_ratio : (p,) (hi - lo) / (lp_hi - lp_lo)
    log_volume : ln vol E
    log_volume_outer, outer_kind : the outer reference's ln vol and what it is
    log_volume_inner : ln vol of the maximum-volume inscribed ellipsoid
    log_volume_polytope : ln vol P (p <= 6, else NaN)
    excess_outer, excess_inner, excess_polytope : per-dimension ln-volume excesses of E
    info : timings (s) and solver facts
    """

    method: str
    names: tuple[str, ...]
    contains_polytope: bool
    vertex_kind: str
    n_vertices: int
    n_outside: int
    max_mahalanobis2: float
    lp_lo: np.ndarray
    lp_hi: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    width_ratio: np.ndarray
    log_volume: float
    log_volume_outer: float
    outer_kind: str
    log_volume_inner: float
    log_volume_polytope: float
    info: dict = field(default_factory=dict)

    @property
    def p(self) -> int:
        return int(self.lp_lo.shape[0])

    @property
    def excess_outer(self) -> float:
        return (self.log_volume - self.log_volume_outer) / self.p

    @property
    def excess_inner(self) -> float:
        return (self.log_volume - self.log_volume_inner) / self.p

    @property
    def excess_polytope(self) -> float:
        return (self.log_volume - self.log_volume_polytope) / self.p

    def to_frame(self) -> pd.DataFrame:
        """One row per parameter: exact LP bounds, the estimate's interval, the width ratio."""
        return pd.DataFrame(
            {"lp_lo": self.lp_lo, "lp_hi": self.lp_hi, "lo": self.lo, "hi": self.hi,
             "lp_width": self.lp_hi - self.lp_lo, "width": self.hi - self.lo, "width_ratio": self.width_ratio},
            index=pd.Index(self.names, name="parameter"),
        )

    def summary(self) -> str:
        """A plain-text report: containment, width ratios, volume excesses."""
        width = 78
        verdict = "yes" if self.contains_polytope else f"NO ({self.n_outside} of {self.n_vertices} vertices outside)"
        which = "every vertex" if self.vertex_kind == "all" else "the 2p LP-bound vertices (necessary condition)"
        wr = self.width_ratio
        head = [
            ("Estimate", self.method),
            ("Parameters", str(self.p)),
            ("Contains P", f"{verdict}; checked {which}, max Mahalanobis^2 {self.max_mahalanobis2:.6g}"),
            ("Width ratio", f"mean {np.mean(wr):.4g}, min {np.min(wr):.4g}, max {np.max(wr):.4g} (estimate / LP)"),
            ("ln vol E", f"{self.log_volume:.6g}"),
            ("Excess/dim", f"{self.excess_outer:.4g} over the outer reference ({self.outer_kind})"),
            ("", f"{self.excess_inner:.4g} over the inscribed ellipsoid (upper bound on the distance)"),
        ]
        if np.isfinite(self.log_volume_polytope):
            head.append(("", f"{self.excess_polytope:.4g} over the polytope itself"))
        lines = ["=" * width, f"{'boundid certificate: distance to the exact optimum':^{width}}", "-" * width]
        lines += [f"{k + ':' if k else '':<14}{v}" for k, v in head]
        lines.append("-" * width)
        lines += self.to_frame().to_string(float_format=lambda v: f"{v: .6g}").splitlines()
        lines.append("=" * width)
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()


def _as_ellipsoid(ref, what: str) -> Ellipsoid:
    if isinstance(ref, sdp.SDPResult):
        return ref.ellipsoid
    if isinstance(ref, Ellipsoid):
        return ref
    raise InputError(f"{what} must be an Ellipsoid or an SDPResult, got {type(ref).__name__}.")


def validate(estimate, polytope, *, inner=None, outer=None, volumes: bool = True,
             allow_fallback: bool = False) -> Certificate:
    """Certify ``estimate`` (an :class:`Estimate` with an ellipsoid, or a bare :class:`Ellipsoid`)
    against the exact feasible polytope.

    Parameters
    ----------
    estimate : Estimate | Ellipsoid
    polytope : Polytope, or a tuple (W, y, e_max) to build one
    inner, outer : optional precomputed reference ellipsoids (Ellipsoid or SDPResult) for P, to
        certify several estimates against one polytope without re-solving the SDPs
    volumes : False skips the SDPs (part (c) then holds NaN)
    allow_fallback : let the SDPs fall back to SCS if Clarabel fails

    Returns
    -------
    Certificate
    """
    t0 = time.perf_counter()
    if isinstance(estimate, Estimate):
        if estimate.ellipsoid is None:
            raise InputError(f"the estimate '{estimate.method}' has no ellipsoid to certify (a point estimate).")
        E, method, names = estimate.ellipsoid, estimate.method, estimate.names
    elif isinstance(estimate, Ellipsoid):
        E, method, names = estimate, "ellipsoid", None
    else:
        raise InputError(f"estimate must be an Estimate or an Ellipsoid, got {type(estimate).__name__}.")
    if isinstance(polytope, tuple) and len(polytope) == 3:
        polytope = Polytope.from_strips(*polytope)
    if not isinstance(polytope, Polytope):
        raise InputError(f"polytope must be a Polytope or a (W, y, e_max) tuple, got {type(polytope).__name__}.")
    P = polytope
    p = P.dim
    if E.dim != p:
        raise InputError(f"the ellipsoid has dimension {E.dim} but the polytope {p}; they must describe "
                         "the same parameters.")
    names = tuple(names) if names is not None else tuple(f"theta{j + 1}" for j in range(p))

    b = P.bounds()
    if p <= MAX_VERTEX_DIM:
        V, vertex_kind = P.vertices(), "all"
    else:
        V, vertex_kind = b.vertices(), "lp-bound"
    d2 = E.mahalanobis2(V)
    inside = d2 <= 1.0 + 1e-8  # slack for the rounding of LP and Qhull vertices only
    lo, hi = E.intervals()
    t_lp = time.perf_counter() - t0

    lv_out = lv_in = lv_p = np.nan
    outer_kind = ""
    if volumes:
        if outer is None:
            if vertex_kind == "all":
                outer, outer_kind = sdp.enclosing_ellipsoid(V, allow_fallback=allow_fallback), \
                    "minimum-volume ellipsoid of the vertices (exact optimum)"
            else:
                outer, outer_kind = sdp.outer_ellipsoid(P, allow_fallback=allow_fallback), \
                    "S-procedure on tightened strips (achievable)"
        else:
            outer_kind = "supplied"
        inner = sdp.inner_ellipsoid(P, allow_fallback=allow_fallback) if inner is None else inner
        lv_out = _as_ellipsoid(outer, "outer").log_volume()
        lv_in = _as_ellipsoid(inner, "inner").log_volume()
        if vertex_kind == "all":
            lv_p = float(np.log(P.volume()))
    return Certificate(
        method=method, names=names, contains_polytope=bool(np.all(inside)), vertex_kind=vertex_kind,
        n_vertices=int(V.shape[0]), n_outside=int(np.sum(~inside)), max_mahalanobis2=float(np.max(d2)),
        lp_lo=b.lo.copy(), lp_hi=b.hi.copy(), lo=lo, hi=hi, width_ratio=(hi - lo) / (b.hi - b.lo),
        log_volume=float(E.log_volume()), log_volume_outer=float(lv_out), outer_kind=outer_kind,
        log_volume_inner=float(lv_in), log_volume_polytope=float(lv_p),
        info={"time_s": time.perf_counter() - t0, "time_lp_s": t_lp, "n_strips": P.n_strips},
    )
