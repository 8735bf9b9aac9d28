"""Certify a set estimate against the exact feasible polytope: the "distance to the exact optimum".

For the feasible polytope P = {theta : |y_k - w_k^T theta| <= e_k} and a convex set S (a recursive
estimator's final set of any family, or any user's set), :func:`validate` reports, through the
:class:`~boundid.sets.ConvexSet` protocol only:

(a) whether S contains P: every vertex of P in S (``S.contains``; all vertices for p <= 6; for
    p > 6 the 2p vertices where the exact LP bounds are attained, a necessary condition only),
    and S's support function at least P's in the directions +-e_j of those LP bounds,
    h_S(+-e_j) >= h_P(+-e_j); with the largest gauge of the checked vertices where the family has
    one (an ellipsoid's Mahalanobis^2, <= 1 inside);
(b) per parameter, the width of S's projection over the exact LP bound width (>= 1 if S ⊇ P);
(c) the log-volume excess of S per dimension, (ln vol S - ln vol E_ref) / p, over
    - the outer reference: an achievable outer ellipsoid of P, the exact minimum-volume one for
      p <= 6 (minimum-volume ellipsoid of the vertices), else the S-procedure ellipsoid on
      tightened strips ([refs §SDP]);
    - the inner (maximum-volume inscribed) ellipsoid: vol(E_in) <= vol(P) <= vol(any outer
      set), so this excess bounds the distance to the unknown optimum from above;
    and, for p <= 6, over P itself (NaN where the family cannot give its ln volume).
The distance of an ellipsoid to the minimum-volume outer ellipsoid, per dimension, lies between
the two excesses (exactly the outer one for p <= 6).
"""

from __future__ import annotations

import textwrap
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from boundid.errors import InputError
from boundid.estimators.estimate import Estimate
from boundid.sets.convex import ConvexSet
from boundid.sets.ellipsoid import Ellipsoid
from boundid.sets.polytope import MAX_VERTEX_DIM, Polytope

#: slack of the containment tests for the rounding of LP and Qhull vertices (relative: the
#: Mahalanobis^2 of an ellipsoid may reach 1 + VERTEX_RTOL)
VERTEX_RTOL = 1e-8


@dataclass
class Certificate:
    """How far a set estimate is from the exact answers for one polytope.

    method : name of the certified estimate (the set's family for a bare set, e.g. "Ellipsoid")
    names : parameter names
    contains_polytope : every checked vertex of P lies in S, and the support check holds
    vertex_kind : "all" (p <= 6: every vertex) or "lp-bound" (the 2p LP-optimal vertices)
    n_vertices, n_outside : vertices checked, and how many lie outside S
    support_ok : h_S(+-e_j) >= h_P(+-e_j) for every j (to VERTEX_RTOL of P's width)
    max_gauge : largest S.gauge over the checked vertices (<= 1 inside; an ellipsoid's
        Mahalanobis^2); NaN for a family without a gauge
    lp_lo, lp_hi : (p,) exact parameter bounds over P (LP)
    lo, hi : (p,) S's projected intervals
    width_ratio : (p,) (hi - lo) / (lp_hi - lp_lo)
    log_volume : ln vol S (NaN where the family cannot say)
    log_volume_outer, outer_kind : the outer reference's ln vol and what it is
    log_volume_inner : ln vol of the maximum-volume inscribed ellipsoid
    log_volume_polytope : ln vol P (p <= 6, else NaN)
    min_outer_bracket : (lower, upper) bracket of ln vol of the minimum-volume ellipsoid containing
        P (:func:`boundid.sets.sdp.min_volume_bracket`), or (NaN, NaN) when not given
    excess_outer, excess_inner, excess_polytope : per-dimension ln-volume excesses of E
    excess_min_outer : (low, high) per-dimension ln-volume excess of the set over the minimum-volume
        outer ellipsoid, bracketed: the true excess lies in it (NaN when no bracket was given)
    info : timings (s) and solver facts
    """

    method: str
    names: tuple[str, ...]
    contains_polytope: bool
    vertex_kind: str
    n_vertices: int
    n_outside: int
    support_ok: bool
    max_gauge: float
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
    min_outer_bracket: tuple[float, float] = (float("nan"), float("nan"))
    info: dict = field(default_factory=dict)

    @property
    def p(self) -> int:
        return int(self.lp_lo.shape[0])

    @property
    def excess_min_outer(self) -> tuple[float, float]:
        lower, upper = self.min_outer_bracket
        return (self.log_volume - upper) / self.p, (self.log_volume - lower) / self.p

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
        verdict = "yes" if self.contains_polytope else (
            f"NO ({self.n_outside} of {self.n_vertices} vertices outside"
            + ("" if self.support_ok else "; support below P's along some axis") + ")")
        which = "every vertex" if self.vertex_kind == "all" else "the 2p LP-bound vertices (necessary condition)"
        wr = self.width_ratio
        head = [
            ("Estimate", self.method),
            ("Parameters", str(self.p)),
            ("Contains P", f"{verdict}; checked {which} and the support along every axis, max gauge "
                           f"{self.max_gauge:.6g}"),
            ("Width ratio", f"mean {np.mean(wr):.4g}, min {np.min(wr):.4g}, max {np.max(wr):.4g} (estimate / LP)"),
            ("ln vol S", f"{self.log_volume:.6g}"),
            ("Excess/dim", f"{self.excess_outer:.4g} over the outer reference ({self.outer_kind})"),
            ("", f"{self.excess_inner:.4g} over the inscribed ellipsoid (upper bound on the distance)"),
        ]
        if np.isfinite(self.log_volume_polytope):
            head.append(("", f"{self.excess_polytope:.4g} over the polytope itself"))
        if np.all(np.isfinite(self.min_outer_bracket)):
            lo_x, hi_x = self.excess_min_outer
            head.append(("", f"[{lo_x:.4g}, {hi_x:.4g}] over the minimum-volume outer ellipsoid (bracketed)"))
        lines = ["=" * width, f"{'boundid certificate: distance to the exact optimum':^{width}}", "-" * width]
        lines += [f"{k + ':' if k else '':<14}{v}" for k, v in head]
        lines = [ln for row in lines for ln in (textwrap.wrap(row, width, subsequent_indent=" " * 14) or [""])]
        lines.append("-" * width)
        lines += self.to_frame().to_string(float_format=lambda v: f"{v: .6g}").splitlines()
        lines.append("=" * width)
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()


def _as_ellipsoid(ref, what: str, sdp) -> Ellipsoid:
    if isinstance(ref, sdp.SDPResult):
        return ref.ellipsoid
    if isinstance(ref, Ellipsoid):
        return ref
    raise InputError(f"{what} must be an Ellipsoid or an SDPResult, got {type(ref).__name__}.")


def validate(estimate, polytope, *, inner=None, outer=None, bracket=None, volumes: bool = True,
             allow_fallback: bool = False) -> Certificate:
    """Certify ``estimate`` (an :class:`Estimate` with a set, or a bare
    :class:`~boundid.sets.ConvexSet`) against the exact feasible polytope.

    Parameters
    ----------
    estimate : Estimate | ConvexSet
    polytope : Polytope, or a tuple (W, y, e_max) to build one
    inner, outer : optional precomputed reference ellipsoids (Ellipsoid or SDPResult) for P, to
        certify several estimates against one polytope without re-solving the SDPs
    bracket : optional :class:`~boundid.sets.sdp.VolumeBracket` of P's minimum-volume outer
        ellipsoid: the certificate then brackets the set's volume excess over that optimum
    volumes : False skips the SDPs (part (c) then holds NaN)
    allow_fallback : let the SDPs fall back to SCS if Clarabel fails

    Returns
    -------
    Certificate
    """
    t0 = time.perf_counter()
    if isinstance(estimate, Estimate):
        if estimate.set is None:
            raise InputError(f"the estimate '{estimate.method}' has no set to certify (a point estimate).")
        S, method, names = estimate.set, estimate.method, estimate.names
    elif isinstance(estimate, ConvexSet):
        S, method, names = estimate, type(estimate).__name__, None
    else:
        raise InputError(f"estimate must be an Estimate or a ConvexSet, got {type(estimate).__name__}.")
    if isinstance(polytope, tuple) and len(polytope) == 3:
        polytope = Polytope.from_strips(*polytope)
    if not isinstance(polytope, Polytope):
        raise InputError(f"polytope must be a Polytope or a (W, y, e_max) tuple, got {type(polytope).__name__}.")
    P = polytope
    p = P.dim
    if S.dim != p:
        raise InputError(f"the set has dimension {S.dim} but the polytope {p}; they must describe "
                         "the same parameters.")
    names = tuple(names) if names is not None else tuple(f"theta{j + 1}" for j in range(p))

    b = P.bounds()
    if p <= MAX_VERTEX_DIM:
        V, vertex_kind = P.vertices(), "all"
    else:
        V, vertex_kind = b.vertices(), "lp-bound"
    inside = np.asarray(S.contains(V, rtol=VERTEX_RTOL))
    gauge = np.asarray(S.gauge(V), dtype=float)
    # the support check: h_S(+-e_j) >= h_P(+-e_j) = lp_hi_j, -lp_lo_j, to VERTEX_RTOL of P's width
    eye = np.eye(p)
    slack = VERTEX_RTOL * (b.hi - b.lo)
    support_ok = all(S.support(eye[j]) >= b.hi[j] - slack[j] and S.support(-eye[j]) >= -b.lo[j] - slack[j]
                     for j in range(p))
    lo, hi = S.intervals()
    t_lp = time.perf_counter() - t0

    lv_out = lv_in = lv_p = np.nan
    outer_kind = ""
    if volumes:
        from boundid.sets import sdp  # cvxpy: loaded where it is used

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
        lv_out = _as_ellipsoid(outer, "outer", sdp).log_volume()
        lv_in = _as_ellipsoid(inner, "inner", sdp).log_volume()
        if vertex_kind == "all":
            lv_p = float(np.log(P.volume()))
    return Certificate(
        method=method, names=names, contains_polytope=bool(np.all(inside)) and support_ok, vertex_kind=vertex_kind,
        n_vertices=int(V.shape[0]), n_outside=int(np.sum(~inside)), support_ok=bool(support_ok),
        max_gauge=float(np.max(gauge)), lp_lo=b.lo.copy(), lp_hi=b.hi.copy(), lo=lo, hi=hi,
        width_ratio=(hi - lo) / (b.hi - b.lo), log_volume=float(S.log_volume()), log_volume_outer=float(lv_out),
        outer_kind=outer_kind, log_volume_inner=float(lv_in), log_volume_polytope=float(lv_p),
        min_outer_bracket=(float("nan"), float("nan")) if bracket is None else (float(bracket.lower),
                                                                              float(bracket.upper)),
        info={"time_s": time.perf_counter() - t0, "time_lp_s": t_lp, "n_strips": P.n_strips},
    )
