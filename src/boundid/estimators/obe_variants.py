"""Two variants of the OBE ([FogelHuang1982] volume weight, factorized form, [refs §OBE]) that use
more than one strip at a time.

* :class:`BoxedOBE`: the prior box stays in the recursion. Its p sides |theta_j - c0_j| <= h_j
  enter as strips before the first sample and again every ``box_every`` samples, so the ellipsoid
  always encloses E ∩ prior box (the plain OBE starts from the ellipsoid circumscribing the box
  and forgets the box; its early ellipsoids stick out of it).
* :class:`WindowedOBE`: after every window of samples, the ellipsoid is reset to the S-procedure
  outer ellipsoid ([Boyd1994] §3.7.2, :func:`boundid.sets.outer_ellipsoid`) of a polytope that
  holds the truth: the window's strips ∩ the interval hulls of the ellipsoids at the window's
  start and end ∩ the prior box ∩ the end ellipsoid's bounding box in its principal frame; the
  reset is taken when that ellipsoid is the smaller. Each window's strips are then enclosed
  jointly instead of one at a time.

Both start from the ellipsoid circumscribing the prior box (an :class:`OBE` with ``prior=`` the
box) and return the ellipsoid as ``Estimate.set``; a segment whose OBE could not vouch for its
set makes the result "unverified", with the OBE's reason.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from boundid.errors import InfeasibleDataError, InputError, SolverError
from boundid.estimators._set_kernels import ROUND_GUARD
from boundid.estimators._set_recursion import Run, SetRecursion, fit_problem
from boundid.estimators.method import Method, Style, option
from boundid.estimators.obe import OBE
from boundid.sets.box import Box
from boundid.sets.ellipsoid import Ellipsoid
from boundid.sets.polytope import Polytope


class _OBEVariant(SetRecursion):
    """An OBE run in segments, each by a fresh OBE from the previous segment's ellipsoid (the
    volume step depends on the ellipsoid only, so a restart changes nothing)."""

    def _start(self) -> None:
        # the prior box widened by the rounding guard of every step: the OBE clips each strip to
        # the ellipsoid's own extent, so a truth exactly on the prior box's face would otherwise
        # sit exactly on the ellipsoid's boundary, to rounding
        c0, h0 = self.prior.center, self.prior.half_widths
        self._box = (c0, h0 + ROUND_GUARD * (np.abs(c0) + h0))
        self.ellipsoid = OBE(self.p, prior=Box.from_center(*self._box)).ellipsoid()

    def _segment(self, W, y, e, n_pre: int, k0: int, acc: dict) -> int:
        """Run an OBE from the current ellipsoid over the rows of W: the first ``n_pre`` are
        prior rows, the others the global samples k0, k0 + 1, ... Appends the samples' records,
        outliers and counts to ``acc``; returns the number of samples processed (fewer than given
        when an outlier stops the run with on_outlier="raise")."""
        obe = OBE(self.p, prior=self.ellipsoid, on_outlier=self.on_outlier)
        try:
            est = obe.fit(W, y, e)
            processed = W.shape[0]
        except InfeasibleDataError:
            est = obe.estimate()
            processed = obe.n_samples - 1
        if processed < n_pre or np.any(est.outliers < n_pre):
            raise InfeasibleDataError(
                "a side of the prior box misses the current ellipsoid: the data say the true parameters are "
                "not inside the prior box. Widen the prior or check its centre.")
        h = est.history
        sel = h.index >= n_pre
        acc["idx"].append(h.index[sel] - n_pre + k0)
        acc["c"].append(h.centers[sel])
        acc["lv"].append(h.log_volumes[sel])
        acc["out"].append(est.outliers - n_pre + k0)
        acc["res"].append(est.outlier_residuals)
        acc["upd"] += est.n_updates
        acc["skip"] += est.n_skipped
        if est.kind == "unverified" and self.unverified_reason is None:
            self.unverified_reason = est.unverified_reason
        self.ellipsoid = est.set
        return processed - n_pre

    def _pack(self, processed: int, acc: dict) -> Run:
        idx = np.concatenate(acc["idx"])
        keep = ((idx + 1) % self.record_every == 0) | (np.arange(idx.size) == idx.size - 1)
        return Run(processed, acc["upd"], acc["skip"], idx[keep], np.concatenate(acc["c"])[keep],
                   np.concatenate(acc["lv"])[keep], np.concatenate(acc["out"]).astype(np.int64),
                   np.concatenate(acc["res"]))

    @staticmethod
    def _acc() -> dict:
        return {"idx": [], "c": [], "lv": [], "out": [], "res": [], "upd": 0, "skip": 0}

    def current_set(self) -> Ellipsoid:
        return self.ellipsoid

    def _center(self, S) -> np.ndarray:
        return S.center.copy()


class BoxedOBE(_OBEVariant):
    """OBE with the prior box as p extra strips, before the first sample and every ``box_every``
    samples (default 100 p): the ellipsoid encloses E ∩ prior box at those steps.

    Parameters: ``box_every`` and those of :class:`~boundid.estimators._set_recursion.SetRecursion`
    (p, the prior box ``prior`` (or center0, shape0), ``on_outlier``, ``record_every``, ``names``).
    Cost: the OBE's O(p^2) per sample, plus p box strips (O(p^3)) every ``box_every`` samples.
    """

    method = "OBE ∩ prior box"

    def __init__(self, p: int, *, box_every: int | None = None, **kwargs):
        if box_every is not None and not (isinstance(box_every, int | np.integer) and box_every >= 1):
            raise InputError(f"box_every must be a positive integer, got {box_every!r}.")
        super().__init__(p, **kwargs)
        self.box_every = int(box_every) if box_every is not None else 100 * self.p

    def _run(self, W, y, e, k0) -> Run:
        N = W.shape[0]
        acc = self._acc()
        I, (c0, h0) = np.eye(self.p), self._box
        start, processed = 0, 0
        while start < N:
            k = k0 + start
            n_pre = self.p if k % self.box_every == 0 else 0
            stop = min(N, start + self.box_every - k % self.box_every)
            rows = slice(start, stop)
            done = self._segment(np.vstack([I[:n_pre], W[rows]]), np.concatenate([c0[:n_pre], y[rows]]),
                                 np.concatenate([h0[:n_pre], e[rows]]), n_pre, k, acc)
            processed += done
            if done < stop - start:
                break
            start = stop
        return self._pack(processed, acc)

    def _info(self) -> dict:
        return {"box_every": self.box_every}


class WindowedOBE(_OBEVariant):
    """OBE reset after every ``window`` samples (default 20 p) to the S-procedure outer
    ellipsoid of the window's polytope when that one is smaller (see the module docstring).

    Parameters: ``window`` and those of :class:`~boundid.estimators._set_recursion.SetRecursion`.
    Cost: the OBE's O(p^2) per sample, plus per window the LPs (redundancy, tightening) and one
    SDP of :func:`boundid.sets.outer_ellipsoid`. A reset whose SDP fails is skipped (the OBE
    ellipsoid is kept, which is still guaranteed) and counted in ``info["n_reset_failures"]``.
    """

    method = "Windowed OBE"

    def __init__(self, p: int, *, window: int | None = None, **kwargs):
        if window is not None and not (isinstance(window, int | np.integer) and window >= 1):
            raise InputError(f"window must be a positive integer, got {window!r}.")
        super().__init__(p, **kwargs)
        self.window = int(window) if window is not None else 20 * self.p

    def _start(self) -> None:
        super()._start()
        self.n_resets = self.n_reset_failures = 0

    def _run(self, W, y, e, k0) -> Run:
        from boundid.sets.sdp import outer_ellipsoid  # cvxpy: loaded where it is used

        N = W.shape[0]
        acc = self._acc()
        start, processed = 0, 0
        while start < N:
            k = k0 + start
            stop = min(N, start + self.window - k % self.window)
            rows = slice(start, stop)
            lo0, hi0 = self.ellipsoid.intervals()
            done = self._segment(W[rows], y[rows], e[rows], 0, k, acc)
            processed += done
            if done < stop - start:
                break
            if (k0 + stop) % self.window == 0:
                lo1, hi1 = self.ellipsoid.intervals()
                plo, phi = self.prior.intervals()
                box = (np.maximum.reduce([lo0, lo1, plo]), np.minimum.reduce([hi0, hi1, phi]))
                keep = ~np.isin(np.arange(start, stop), acc["out"][-1] - k0)
                # E's bounding box in its principal frame: |u^T (x - c)| <= sqrt(u^T S u) for each axis u
                U = np.linalg.eigh(self.ellipsoid.shape)[1]
                half = np.sqrt(np.einsum("ij,ik,kj->j", U, self.ellipsoid.shape, U)) * (1 + 1e-12)
                Wp = np.vstack([W[rows][keep], U.T])
                yp = np.concatenate([y[rows][keep], U.T @ self.ellipsoid.center])
                ep = np.concatenate([e[rows][keep], half])
                try:
                    E = outer_ellipsoid(Polytope(Wp, yp, ep, box=box)).ellipsoid
                except SolverError:
                    self.n_reset_failures += 1
                else:
                    if E.log_volume() < self.ellipsoid.log_volume():
                        self.ellipsoid = E
                        self.n_resets += 1
                        acc["c"][-1][-1], acc["lv"][-1][-1] = E.center, E.log_volume()
            start = stop
        return self._pack(processed, acc)

    def _info(self) -> dict:
        return {"window": self.window, "n_resets": self.n_resets, "n_reset_failures": self.n_reset_failures}


# ------------------------------------------------------------------------------ registry entries


@dataclass(frozen=True)
class BoxedOBEOptions:
    """What a study file may set for ``method = "obe_boxed"``."""

    box_every: int | None = option(None, "samples between the prior box's strips (default 100 p)", lo=1)


@dataclass(frozen=True)
class WindowedOBEOptions:
    """What a study file may set for ``method = "obe_windowed"``."""

    window: int | None = option(None, "samples per window before the outer-ellipsoid reset (default 20 p)", lo=1)


BOXED_METHOD = Method(
    name="obe_boxed", summary="OBE (factorized, volume) with the prior box as strips every box_every samples",
    options=BoxedOBEOptions, build=lambda pb, o: fit_problem(BoxedOBE, pb, box_every=o.box_every),
    set_family="ellipsoid", kind="guaranteed", needs_bound=True, style=Style("#88CCEE", "<", "--"))
WINDOWED_METHOD = Method(
    name="obe_windowed", summary="OBE (factorized, volume) reset per window to the SDP outer ellipsoid of its strips",
    options=WindowedOBEOptions, build=lambda pb, o: fit_problem(WindowedOBE, pb, window=o.window),
    set_family="ellipsoid", kind="guaranteed", needs_bound=True, style=Style("#DDCC77", ">", "--"))
