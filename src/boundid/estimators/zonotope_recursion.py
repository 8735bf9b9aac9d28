"""The zonotope recursion ([AlamoBravoCamacho2005]) with [Combastel2003] order reduction.

Z = c ⊕ G B^m. For any lambda in R^p, with the strip |y - w^T x| <= s clipped to Z's extent
along w (centre yc, half-width sc) and v = G^T w,

    Z(lambda) = (c + lambda (yc - w^T c)) ⊕ [G - lambda v^T, sc lambda] B^(m+1)  ⊇  Z ∩ S

(any x = c + G xi in S has y - w^T x = sc eps with |eps| <= 1, so
x = x + lambda (yc - w^T x) - lambda sc eps, which is of that form).

Candidates of each step, all members of that family:

* lambda* = G v / (|v|^2 + sc^2), the F-radius minimiser (least Frobenius norm of the new
  generator matrix); it adds a generator, so the result is reduced to the order limit;
* lambda_j = g_j / v_j for each generator with v_j != 0: generator j cancels and is replaced by
  sc g_j / v_j (segment elimination; the count stays);
* lambda = 0: Z itself.

Criterion: the candidate of least total segment length, sum_k |g_k|_2 (after the reduction).
(Measured on random strips, p = 3 and 9: taking lambda* alone, the F-radius choice of the design
note, behaves like a Kalman covariance bound, converges far more slowly, and with the box
reduction at 2p generators grew without bound at p = 9; the volume is a sum over C(m, p)
determinants, too costly per step.)

Order limit: at most ``order * p`` generators (default order 2: 2p). The [Combastel2003]
reduction keeps the order * p - p largest (Euclidean norm) and replaces the others by the box of
their sum (p axis generators). Cost O(p m^2) per update (the Gram matrix of the generators for
the segment lengths), O(p m + m^2) per cutting strip that leaves Z as it is, m <= order * p;
(order * p + 1) p + p numbers stored.

The compiled loop is ``_set_kernels.run_zonotope``; :func:`zonotope_step` is the same step in
plain numpy (the reference of the tests and benchmarks).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from boundid.errors import InputError
from boundid.estimators import _set_kernels as K
from boundid.estimators._set_recursion import Run, SetRecursion, clip_strip, fit_problem
from boundid.estimators.method import Method, Style, option
from boundid.sets.zonotope import Zonotope, reduce_generators


def segments(G: np.ndarray) -> float:
    """Total segment length of a zonotope, sum_k |g_k|_2 (the step's criterion)."""
    return float(np.linalg.norm(G, axis=0).sum())


def zonotope_step(c: np.ndarray, G: np.ndarray, w: np.ndarray, y: float, e: float, max_generators: int):
    """One zonotope step in numpy: (status, c', G', choice) for the strip |y - w^T x| <= e.

    Forms every candidate explicitly (lambda*, reduced; each lambda_j; Z itself) and keeps the
    one of least :func:`segments`. ``choice`` is -1 for lambda*, j for lambda_j, -2 for Z.
    """
    v = G.T @ w
    m, r, wc = float(w @ c), float(np.abs(v).sum()), float(np.abs(w * c).sum())
    status, yc, sc = clip_strip(y, e, m, r, wc)
    if status != K.UPDATE:
        return status, c.copy(), G.copy(), -2
    lam = G @ v / (v @ v + sc * sc)
    cands = [(segments(G), -2, c.copy(), G.copy())]
    Gs = reduce_generators(np.hstack([G - np.outer(lam, v), sc * lam[:, None]]), max_generators)
    cands.append((segments(Gs), -1, c + lam * (yc - m), Gs))
    for j in np.flatnonzero(v):
        Gj = G - np.outer(G[:, j], v / v[j])
        Gj[:, j] = (sc / v[j]) * G[:, j]
        cands.append((segments(Gj), int(j), c + G[:, j] * ((yc - m) / v[j]), Gj))
    _, choice, cn, Gn = min(cands, key=lambda t: t[0])   # first of equals: Z, then lambda*, then j
    return status, cn, Gn, choice


class ZonotopeRecursion(SetRecursion):
    """Recursive zonotope estimator (least total segment length among Alamo's candidates).

    Parameters
    ----------
    order : int, default 2
        At most ``order * p`` generators (>= 2: the reduction keeps order * p - p of them plus
        the p axis generators of the box of the others).

    Other parameters: see :class:`~boundid.estimators._set_recursion.SetRecursion` (p, the prior box
    ``prior`` (or center0, shape0), ``on_outlier``, ``record_every``, ``names``). Starts from the
    prior box (p axis generators). Cost O(p m^2) per update, m <= order * p generators.
    ``Estimate.n_updates`` counts the steps that changed Z; a strip that cuts Z but whose
    candidates are all longer than Z leaves it unchanged and counts as skipped.
    The history's ln volumes are NaN; ``Zonotope.log_volume`` is exact when C(m, p) is small.
    """

    def __init__(self, p: int, *, order: int = 2, **kwargs):
        if not (isinstance(order, int | np.integer) and order >= 2):
            raise InputError(f"order must be an integer >= 2 (at most order * p generators), got {order!r}.")
        self.order = int(order)
        super().__init__(p, **kwargs)

    @property
    def max_generators(self) -> int:
        return self.order * self.p

    @property
    def method(self) -> str:
        return f"Zonotope recursion (segments, <= {self.order}p generators)"

    def _start(self) -> None:
        self.center = self.prior.center
        self._Gt = np.zeros((self.max_generators + 1, self.p))
        self._Gt[: self.p] = np.diag(self.prior.half_widths)
        self._state = np.array([float(self.p)])

    def _run(self, W, y, e, k0) -> Run:
        b = self._buffers(W.shape[0])
        K.run_zonotope(self.center, self._Gt, self._state, W, y, e, self.max_generators, self._stop, k0,
                       self.record_every, b["hist_idx"], b["hist_c"], b["hist_lv"], b["out_idx"], b["out_res"],
                       b["counts"])
        return self._collect(b)

    def current_set(self) -> Zonotope:
        return Zonotope(self.center, self._Gt[: int(self._state[0])].T)

    def _center(self, S) -> np.ndarray:
        return S.center.copy()

    def _info(self) -> dict:
        return {"order": self.order, "n_generators": int(self._state[0])}


@dataclass(frozen=True)
class ZonotopeOptions:
    """What a study file may set for ``method = "zonotope"``."""

    order: int = option(2, "at most order * p generators", lo=2)


METHOD = Method(name="zonotope", summary="recursive zonotope of at most order * p generators (Alamo's candidates)",
                options=ZonotopeOptions, build=lambda pb, o: fit_problem(ZonotopeRecursion, pb, order=o.order),
                set_family="zonotope", kind="guaranteed", needs_bound=True, style=Style("#AA4499", "h", "--"))
