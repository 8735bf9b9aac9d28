"""The parallelotope recursion ([VicinoZappa1996], [ChisciGarulliZappa1996]).

P = c + G B^p, G invertible. P ∩ S is bounded by p + 1 strips (the p sides of P and the new
strip S). Each is tightened to the exact extent of P ∩ S along its normal; dropping one of the
p + 1 gives a parallelotope containing P ∩ S, and the step keeps the one of least volume. The
minimum is over these p + 1 candidates (the parallelotopes whose sides are parallel to p of the
p + 1 strips), not over every parallelotope. O(p^2) per sample, p^2 + p numbers stored.

The compiled loop is ``_set_kernels.run_parallelotope``; :func:`parallelotope_step` is the same
step in plain numpy (the reference of the tests and benchmarks).
"""

from __future__ import annotations

import numpy as np

from boundid.estimators import _set_kernels as K
from boundid.estimators._set_recursion import Run, SetRecursion, clip_strip, fit_problem
from boundid.estimators.method import Method, NoOptions, Style
from boundid.sets.parallelotope import Parallelotope


def parallelotope_step(c: np.ndarray, G: np.ndarray, w: np.ndarray, y: float, e: float):
    """One parallelotope step in numpy: (status, c', G', chosen) for the strip |y - w^T x| <= e.

    In the unit-box coordinates z of P (x = c + G z) the clipped strip reads
    alpha <= v^T z <= beta, v = G^T w. The box step on [-1, 1]^p gives the tightened sides
    [zl_k, zu_k] (centre z0_k, half-width h_k). Candidate k (drop side k, k < p) has volume
    prod_{i != k} h_i * eta / |v_k|, eta = (beta - alpha) / 2; candidate p (drop the new strip)
    prod_i h_i. ``chosen`` is the index of the dropped strip (p: the new one).
    """
    p = c.shape[0]
    v = G.T @ w
    m, r, wc = float(w @ c), float(np.abs(v).sum()), float(np.abs(w * c).sum())
    status, yc, sc = clip_strip(y, e, m, r, wc)
    if status != K.UPDATE:
        return status, c.copy(), G.copy(), p
    alpha, beta = yc - sc - m, yc + sc - m
    g = K.ROUND_GUARD * (abs(alpha) + abs(beta) + r)
    Rr = np.maximum(r - np.abs(v), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (alpha - Rr - g) / v, (beta + Rr + g) / v
    nz = v != 0
    zl = np.where(nz, np.maximum(-1.0, np.minimum(a, b)), -1.0)
    zu = np.where(nz, np.minimum(1.0, np.maximum(a, b)), 1.0)
    h = np.maximum(0.5 * (zu - zl), K.KAPPA)
    z0 = 0.5 * (zl + zu)
    score = np.abs(v) * h
    j = int(np.argmax(score))
    if sc < score[j]:
        z0[j] = ((yc - m) - (v @ z0 - v[j] * z0[j])) / v[j]
        Gn = h * (G - np.outer(G[:, j], v / v[j]))
        Gn[:, j] = (sc / v[j]) * G[:, j]
        return status, c + G @ z0, Gn, j
    return status, c + G @ z0, G * h, p


class ParallelotopeRecursion(SetRecursion):
    """Recursive parallelotope estimator: the least-volume candidate of the p + 1 at each step.

    Parameters: see :class:`~boundid.estimators._set_recursion.SetRecursion` (p, the prior box
    ``prior`` (or center0, shape0), ``on_outlier``, ``record_every``, ``names``). Starts from the
    prior box; cost O(p^2) per sample; ln volume = p ln 2 + ln |det G|.
    """

    method = "Parallelotope recursion"

    def _start(self) -> None:
        self.center = self.prior.center
        self._Gt = np.diag(self.prior.half_widths)  # rows: generators
        self._state = np.array([float(np.sum(np.log(self.prior.half_widths)))])

    def _run(self, W, y, e, k0) -> Run:
        b = self._buffers(W.shape[0])
        K.run_parallelotope(self.center, self._Gt, self._state, W, y, e, self._stop, k0, self.record_every,
                            b["hist_idx"], b["hist_c"], b["hist_lv"], b["out_idx"], b["out_res"], b["counts"])
        return self._collect(b)

    def current_set(self) -> Parallelotope:
        return Parallelotope(self.center, self._Gt.T)

    def _center(self, S) -> np.ndarray:
        return S.center.copy()


METHOD = Method(name="parallelotope", summary="recursive parallelotope: least-volume candidate of p + 1 per strip",
                options=NoOptions, build=lambda pb, o: fit_problem(ParallelotopeRecursion, pb),
                set_family="parallelotope", kind="guaranteed", needs_bound=True, style=Style("#117733", "s", "--"))
