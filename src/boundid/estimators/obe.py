"""Recursive bounded-error estimators: the Optimal Bounding Ellipsoid (OBE) family.

Model: y_k = w_k^T theta + e_k with |e_k| <= e_max_k. Starting from an ellipsoid E0 that contains
the true theta, each observation's strip {theta : |y_k - w_k^T theta| <= e_max_k} is intersected
with the current ellipsoid and the intersection is enclosed in a new ellipsoid of the pencil of
REFERENCES §1, whose weight minimises the volume (Fogel & Huang 1982), the trace, or sigma
(Dasgupta & Huang 1987). Each strip is first clipped to the ellipsoid's extent along w_k, which
makes the volume step the exact one-step optimum. Two numerically different implementations of
the same recursion:

* ``form="standard"``: centre c, sigma and M^-1 kept by Sherman-Morrison (seed 000 eq. (28)-(30));
  cheap, but on ill-conditioned data M^-1 can lose positive definiteness (detected: SolverError)
  or, after a step that narrows the ellipsoid by orders of magnitude (a feasible set with an
  empty interior), accuracy (not detected; seen in stress tests with errors exactly at the
  bounds). Use it to reproduce the paper's comparison, not for guarantees on degenerate data.
* ``form="factorized"``: the square-root information form of Lesecq & Barraud (seed 000
  eq. (33)-(35), REFERENCES §2): M = X^T X with X upper triangular, z = X c, each update a QR
  of the appended row by Givens rotations. Stays positive definite.

The guarantee: if theta is in E0 and every |e_k| <= e_max_k, theta is in every ellipsoid of the
recursion. Strips that miss the ellipsoid (the data contradict the bounds) are outliers: they
are recorded and skipped, or raise :class:`InfeasibleDataError`.
"""

from __future__ import annotations

import time

import numpy as np

from boundid._validation import as_bounds, as_float_array, as_regression, as_spd, as_vector
from boundid.errors import InfeasibleDataError, InputError, SolverError
from boundid.estimators import _obe_kernels as K
from boundid.estimators.estimate import Estimate, History
from boundid.sets.ellipsoid import Ellipsoid, log_unit_ball_volume

FORMS = ("standard", "factorized")


def _shape_matrix(shape0, p: int) -> np.ndarray:
    S = as_float_array(shape0, "shape0")
    if S.ndim == 0:
        S = np.full(p, float(S))
    if S.ndim == 1:
        S = as_vector(S, "shape0", p)
        if np.any(S <= 0):
            raise InputError("shape0 given as a vector holds squared semi-axes; all must be > 0.")
        S = np.diag(S)
    return as_spd(S, "shape0", p)


class OBE:
    """Recursive Optimal Bounding Ellipsoid estimator (guaranteed set).

    Parameters
    ----------
    p : int
        Number of parameters.
    center0 : (p,) array, default 0
        Centre of the initial ellipsoid E0 (a-priori parameter values).
    shape0 : float, (p,) or (p, p) array, default 1e6
        Shape of E0 = {theta : (theta - c0)^T shape0^-1 (theta - c0) <= 1} (units: parameter
        units squared). A scalar s means s * I (a ball of radius sqrt(s)); a vector the diagonal.
        The guarantee needs the true parameters inside E0.
    criterion : "volume" | "trace" | "dasgupta-huang"
        What each step's weight minimises: the volume (Fogel-Huang), the trace of the shape
        matrix (sum of squared semi-axes), or sigma (Dasgupta-Huang, capped at ``alpha_max``).
        Every rule sees the strip clipped to the ellipsoid's extent and normalised to a unit
        half-width (sigma, and so the Dasgupta-Huang weight, depends on that normalisation).
    form : "standard" | "factorized"
        Information-matrix recursion, or square-root information (QR by Givens rotations).
    on_outlier : "skip" | "raise"
        What to do with a strip that misses the current ellipsoid.
    record_every : int
        Record the centre and ln volume every ``record_every`` samples (and after the last one).
    record_shapes : bool
        Also record the shape matrices (for small-p teaching pictures; O(p^3) per record).
    selective : bool
        True (default): a strip that contains the whole ellipsoid, or whose optimal weight is 0,
        costs only the O(p^2) test. False: the full update runs on every sample (weight possibly
        0), the classic non-selective recursion, for benchmarks and comparisons.
    alpha_max : float
        Upper bound on the Dasgupta-Huang weight, in (0, 1).
    names : sequence of str, optional
        Parameter names for the Estimate.

    Notes
    -----
    ``info`` of the returned Estimate: n_samples, n_updates (update steps computed), n_skipped
    (strips with no information), n_outliers, time_s (compiled loops only), criterion, form,
    selective, sigma; for the standard form also n_breakdowns (steps where rounding made
    w^T M^-1 w <= 0: skipped; the form then raises SolverError when the Estimate is built).
    The factorized form keeps sigma separately instead of normalising it to 1 (seed eq. (35)
    divides [X, z] by sqrt(sigma)); the ellipsoid is the same.
    """

    def __init__(self, p: int, center0=None, shape0=1e6, *, criterion: str = "volume", form: str = "factorized",
                 on_outlier: str = "skip", record_every: int = 1, record_shapes: bool = False,
                 selective: bool = True, alpha_max: float = 0.9, names=None):
        if not (isinstance(p, int | np.integer) and p >= 1):
            raise InputError(f"p must be a positive integer (number of parameters), got {p!r}.")
        self.p = int(p)
        if criterion not in K.CRITERIA:
            raise InputError(f"criterion must be one of {tuple(K.CRITERIA)}, got {criterion!r}.")
        if form not in FORMS:
            raise InputError(f"form must be one of {FORMS}, got {form!r}.")
        if on_outlier not in ("skip", "raise"):
            raise InputError(f"on_outlier must be 'skip' or 'raise', got {on_outlier!r}.")
        if not (isinstance(record_every, int | np.integer) and record_every >= 1):
            raise InputError(f"record_every must be an integer >= 1, got {record_every!r}.")
        if not (0.0 < alpha_max < 1.0):
            raise InputError(f"alpha_max must lie in (0, 1), got {alpha_max!r}.")
        if names is not None:
            names = tuple(str(s) for s in names)
            if len(names) != self.p:
                raise InputError(f"names must hold {self.p} names, got {len(names)}.")
        self.criterion, self.form, self.on_outlier = criterion, form, on_outlier
        self.record_every, self.record_shapes = int(record_every), bool(record_shapes)
        self.selective, self.alpha_max, self.names = bool(selective), float(alpha_max), names

        c0 = np.zeros(self.p) if center0 is None else as_vector(center0, "center0", self.p)
        S0 = _shape_matrix(shape0, self.p)
        self.center = c0.copy()
        M0 = np.linalg.inv(S0)
        M0 = 0.5 * (M0 + M0.T)
        # state = [sigma, ln det M, tr M^-1]
        self._state = np.array([1.0, np.linalg.slogdet(M0)[1], np.trace(S0)])
        if form == "standard":
            self._P = S0.copy()
        else:
            self._X = np.ascontiguousarray(np.linalg.cholesky(M0).T)  # M = X^T X, X upper
            self._z = self._X @ c0
        self.n_samples = self.n_updates = self.n_skipped = self.n_breakdowns = 0
        self.time_s = 0.0
        self._hist: list[tuple] = []
        self._outliers: list[np.ndarray] = []
        self._outlier_res: list[np.ndarray] = []

    @classmethod
    def from_prior(cls, center, half_widths, **kwargs) -> OBE:
        """An OBE starting from prior values and ranges: E0 = the ellipsoid circumscribing the box
        center +- half_widths, i.e. semi-axes sqrt(p) * half_widths (the H4 paper starts from its
        design values). Other keyword arguments go to :class:`OBE`."""
        c = as_vector(center, "center")
        h = np.broadcast_to(as_float_array(half_widths, "half_widths"), c.shape).astype(float)
        as_vector(h, "half_widths", c.shape[0])
        if np.any(h <= 0):
            raise InputError("half_widths must all be > 0 (a zero range pins the parameter: remove it instead).")
        p = c.shape[0]
        return cls(p, c, p * h**2, **kwargs)

    # ------------------------------------------------------------------ recursion
    def fit(self, W, y, e_max) -> Estimate:
        """Process the rows of W (N, p), y (N,) with bounds e_max (scalar or (N,)), continuing
        from the current state, in one compiled loop. Returns :meth:`estimate`."""
        W, y = as_regression(W, y)
        if W.shape[1] != self.p:
            raise InputError(f"W must have {self.p} columns (one per parameter), got {W.shape[1]}.")
        e = as_bounds(e_max, W.shape[0])
        W = np.ascontiguousarray(W)
        N, p = W.shape
        n_rec_max = N // self.record_every + 2
        hist_idx = np.empty(n_rec_max, np.int64)
        hist_c = np.empty((n_rec_max, p))
        hist_lv = np.empty(n_rec_max)
        hist_S = np.empty((n_rec_max if self.record_shapes else 0, p, p))
        out_idx = np.empty(N, np.int64)
        out_res = np.empty(N)
        counts = np.zeros(6, np.int64)
        crit = K.CRITERIA[self.criterion]
        stop = self.on_outlier == "raise"
        args = (self._state, W, y, e, crit, self.selective, self.alpha_max, stop, self.n_samples,
                self.record_every, log_unit_ball_volume(p), hist_idx, hist_c, hist_lv, hist_S, out_idx, out_res,
                counts)
        t0 = time.perf_counter()
        if self.form == "standard":
            K.run_standard(self._P, self.center, *args)
        else:
            K.run_factorized(self._X, self._z, self.center, *args)
        self.time_s += time.perf_counter() - t0
        processed, n_upd, n_skip, n_out, n_rec, n_brk = (int(v) for v in counts)
        self.n_samples += processed + (1 if processed < N else 0)
        self.n_updates += n_upd
        self.n_skipped += n_skip
        self.n_breakdowns += n_brk
        self._hist.append((hist_idx[:n_rec].copy(), hist_c[:n_rec].copy(), hist_lv[:n_rec].copy(),
                           hist_S[:n_rec].copy() if self.record_shapes else None))
        self._outliers.append(out_idx[:n_out].copy())
        self._outlier_res.append(out_res[:n_out].copy())
        if processed < N:
            k = int(out_idx[n_out - 1])
            raise InfeasibleDataError(
                f"observation {k} contradicts the bounds: its strip misses the current ellipsoid "
                f"(innovation {out_res[n_out - 1]:.6g}, bound {e[processed]:.6g}). The data are inconsistent "
                "with e_max (raise the bounds) or that sample is an outlier (use on_outlier='skip')."
            )
        return self.estimate()

    def update(self, w, y, e_max) -> Estimate:
        """Process one observation y = w^T theta + e, |e| <= e_max."""
        w = as_vector(w, "w", self.p)
        return self.fit(w.reshape(1, -1), as_vector(y, "y", 1), e_max)

    # ------------------------------------------------------------------ results
    @property
    def sigma(self) -> float:
        return float(self._state[0])

    def shape(self) -> np.ndarray:
        """The current shape matrix sigma M^-1 (p, p)."""
        if self.form == "standard":
            S = self.sigma * self._P
        else:
            Xi = K.upper_inverse(self._X)
            S = self.sigma * (Xi @ Xi.T)
        return 0.5 * (S + S.T)

    def information(self) -> np.ndarray:
        """The current information matrix M (p, p), E = {(theta - c)^T M (theta - c) <= sigma}."""
        if self.form == "standard":
            return np.linalg.inv(self._P)
        return self._X.T @ self._X

    def ellipsoid(self) -> Ellipsoid:
        try:
            return Ellipsoid(self.center, self.shape())
        except InputError as exc:
            raise SolverError(
                f"the standard-form OBE lost positive definiteness after {self.n_samples} samples "
                f"({self.n_breakdowns} breakdown steps): ill-conditioned regressors. Use form='factorized'. ({exc})"
            ) from None

    def estimate(self) -> Estimate:
        """The current guaranteed set as an :class:`Estimate` (kind="guaranteed")."""
        E = self.ellipsoid()
        idx, cs, lvs, Ss = zip(*self._hist, strict=True) if self._hist else ((), (), (), ())
        p = self.p
        history = History(
            index=np.concatenate(idx) if idx else np.zeros(0, np.int64),
            centers=np.concatenate(cs) if cs else np.zeros((0, p)),
            log_volumes=np.concatenate(lvs) if lvs else np.zeros(0),
            shapes=np.concatenate(Ss) if self.record_shapes and Ss else None,
        )
        outliers = np.concatenate(self._outliers) if self._outliers else np.zeros(0, np.int64)
        residuals = np.concatenate(self._outlier_res) if self._outlier_res else np.zeros(0)
        info = {
            "n_samples": self.n_samples, "n_updates": self.n_updates, "n_skipped": self.n_skipped,
            "n_outliers": int(outliers.size), "time_s": self.time_s, "criterion": self.criterion,
            "form": self.form, "selective": self.selective, "sigma": self.sigma,
        }
        if self.form == "standard":
            info["n_breakdowns"] = self.n_breakdowns
        return Estimate(
            method=f"OBE-{self.form} ({self.criterion})", center=E.center.copy(), ellipsoid=E,
            intervals=E.intervals(), kind="guaranteed", names=self.names, history=history,
            outliers=outliers, outlier_residuals=residuals, info=info,
        )
