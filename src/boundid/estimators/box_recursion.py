"""The box (orthotope) recursion: interval contraction, one strip at a time.

Each step replaces the box by the exact interval hull of box ∩ strip (the strip first clipped to
the box's extent along w): O(p) per sample, 2p numbers stored. The compiled loop is
``_set_kernels.run_box``; :func:`box_step` is the same step in plain numpy (the reference of the
tests and benchmarks).
"""

from __future__ import annotations

import numpy as np

from boundid.estimators import _set_kernels as K
from boundid.estimators._set_recursion import Run, SetRecursion, clip_strip, fit_problem
from boundid.estimators.method import Method, NoOptions, Style
from boundid.sets.box import Box


def box_step(lo: np.ndarray, hi: np.ndarray, w: np.ndarray, y: float, e: float) -> tuple[int, np.ndarray, np.ndarray]:
    """One box step in numpy: (status, lo', hi') for the strip |y - w^T x| <= e.

    With centre c and half-widths h of the box, m = w^T c, r = |w|^T h and the clipped strip
    [a, b]: R_j = w^T x - w_j x_j ranges over [m - w_j c_j -+ (r - |w_j| h_j)] on the box, so
    w_j x_j lies in [a - max R_j, b - min R_j]; intersected with [lo_j, hi_j] this is the exact
    interval hull of box ∩ strip. ``status`` is K.OUTLIER, K.NO_INFO or K.UPDATE.
    """
    c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
    m, r, wc = float(w @ c), float(np.abs(w) @ h), float(np.abs(w * c).sum())
    status, yc, sc = clip_strip(y, e, m, r, wc)
    if status != K.UPDATE:
        return status, lo.copy(), hi.copy()
    g = K.ROUND_GUARD * (abs(yc) + sc + wc + r)
    Rc = m - w * c
    Rr = np.maximum(r - np.abs(w) * h, 0.0)
    t_lo, t_hi = yc - sc - Rc - Rr - g, yc + sc - Rc + Rr + g
    nz = w != 0
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = t_lo / w, t_hi / w
    new_lo = np.where(nz, np.maximum(lo, np.minimum(a, b)), lo)
    new_hi = np.where(nz, np.minimum(hi, np.maximum(a, b)), hi)
    return status, new_lo, new_hi


class BoxRecursion(SetRecursion):
    """Recursive box (interval) estimator: the exact interval hull of box ∩ strip at each step.

    Parameters: see :class:`~boundid.estimators._set_recursion.SetRecursion` (p, the prior box
    ``prior`` (or center0, shape0), ``on_outlier``, ``record_every``, ``names``). Cost O(p) per
    sample; the history's ln volume is sum_j ln(hi_j - lo_j).
    """

    method = "Box recursion"

    def _start(self) -> None:
        self.lo, self.hi = self.prior.intervals()

    def _run(self, W, y, e, k0) -> Run:
        b = self._buffers(W.shape[0])
        K.run_box(self.lo, self.hi, W, y, e, self._stop, k0, self.record_every, b["hist_idx"], b["hist_c"],
                  b["hist_lv"], b["out_idx"], b["out_res"], b["counts"])
        return self._collect(b)

    def current_set(self) -> Box:
        return Box(self.lo, self.hi)


METHOD = Method(name="box", summary="recursive box: the interval hull of box ∩ strip, O(p) per sample",
                options=NoOptions, build=lambda pb, o: fit_problem(BoxRecursion, pb), set_family="box",
                kind="guaranteed", needs_bound=True, style=Style("#332288", "D", "--"))
