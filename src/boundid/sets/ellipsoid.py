"""Ellipsoids E = {x : (x - c)^T S^-1 (x - c) <= 1}, the common currency of every estimator.

Two representations of the same set:

* :class:`Ellipsoid` holds the shape matrix S and its Cholesky factor;
* :class:`RootInformationEllipsoid` holds the square-root information form
  E = {x : |X x - z|^2 <= sigma}, X upper triangular (S = sigma X^-1 X^-T, c = X^-1 z), the form
  the factorized OBE computes ([refs §QR]). It answers every question by triangular solves with
  X and never forms S, so it stays exact where S's condition number passes 1/eps and S cannot be
  held in double precision.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_triangular
from scipy.special import gammaln

from boundid._validation import as_float_array, as_matrix, as_spd, as_vector
from boundid.errors import InputError
from boundid.sets._plane import closed, plane, require_2d


def log_unit_ball_volume(n: int) -> float:
    """ln of the volume of the unit ball in R^n: (n/2) ln pi - ln Gamma(n/2 + 1)."""
    return 0.5 * n * np.log(np.pi) - gammaln(0.5 * n + 1.0)


class Ellipsoid:
    """The ellipsoid {x : (x - c)^T shape^-1 (x - c) <= 1}.

    Parameters
    ----------
    center : (n,) array
        Centre c, in the parameters' units.
    shape : (n, n) array
        Symmetric positive definite shape matrix S (units: parameter units squared).
        The semi-axes are the square roots of its eigenvalues.
    """

    __slots__ = ("center", "shape", "_chol")

    def __init__(self, center, shape):
        self.center = as_vector(center, "center").copy()  # own the data: callers keep mutating theirs
        self.shape = as_spd(shape, "shape", self.center.shape[0])
        self._chol = np.linalg.cholesky(self.shape)  # S = L L^T

    @classmethod
    def from_information(cls, center, information, sigma: float = 1.0) -> Ellipsoid:
        """E = {x : (x - c)^T M (x - c) <= sigma} from the information matrix M."""
        M = as_spd(information, "information")
        if not (np.isfinite(sigma) and sigma > 0):
            raise InputError(f"sigma must be finite and > 0 (got {sigma}); sigma <= 0 is an empty set.")
        return cls(center, sigma * np.linalg.inv(M))

    @classmethod
    def from_factor(cls, center, factor) -> Ellipsoid:
        """E = {c + L u : |u| <= 1} from a lower-triangular square root L of the shape (S = L L^T, a
        positive diagonal): the caller's own factorisation, so no second one can fail at the margin
        of positive definiteness where the caller's succeeded."""
        c = as_vector(center, "center")
        L = as_matrix(factor, "factor", c.shape[0])
        if L.shape[0] != c.shape[0] or np.any(np.triu(L, 1)) or not np.all(np.diag(L) > 0):
            raise InputError(f"factor must be a {c.shape[0]} x {c.shape[0]} lower-triangular matrix with a positive "
                             "diagonal (a Cholesky factor of the shape matrix).")
        E = cls.__new__(cls)
        E.center, E._chol = c.copy(), L.copy()
        E.shape = L @ L.T
        return E

    @classmethod
    def ball(cls, center, radius) -> Ellipsoid:
        """A ball, or an axis-aligned ellipsoid when ``radius`` is a vector of half-axes."""
        c = as_vector(center, "center")
        r = np.broadcast_to(as_float_array(radius, "radius"), c.shape)
        return cls(c, np.diag(r**2))

    @property
    def dim(self) -> int:
        return self.center.shape[0]

    @property
    def factor(self) -> np.ndarray:
        """A square root L of the shape matrix, S = L L^T (n, n): x = c + L u maps the unit ball onto E."""
        return self._chol

    @property
    def information(self) -> np.ndarray:
        """shape^-1 (the information matrix for sigma = 1)."""
        Linv = np.linalg.inv(self._chol)
        return Linv.T @ Linv

    def log_volume(self) -> float:
        """ln vol(E) = ln vol(unit ball) + (1/2) ln det S."""
        return log_unit_ball_volume(self.dim) + np.sum(np.log(np.diag(self._chol)))

    def volume(self) -> float:
        return float(np.exp(self.log_volume()))

    def semi_axes(self) -> np.ndarray:
        """Semi-axis lengths, largest first."""
        return np.sqrt(np.linalg.eigvalsh(self.shape))[::-1]

    def mahalanobis2(self, points) -> np.ndarray:
        """(x - c)^T S^-1 (x - c) for each row of ``points`` (m, n); <= 1 means inside."""
        X = np.atleast_2d(as_float_array(points, "points"))
        if X.shape[-1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {X.shape}.")
        Z = np.linalg.solve(self._chol, (X - self.center).T)
        return np.sum(Z * Z, axis=0)

    def gauge(self, points) -> np.ndarray | float:
        """The Mahalanobis^2 (x - c)^T S^-1 (x - c) of each point (<= 1 inside); a float for one point."""
        d2 = self.mahalanobis2(points)
        return float(d2[0]) if np.ndim(points) == 1 else d2

    def contains(self, points, rtol: float = 1e-9) -> np.ndarray | bool:
        """Whether each point lies in E (vectorised; a single point gives a bool).

        ``rtol`` absorbs rounding only: a point is inside when its squared Mahalanobis
        distance is at most 1 + rtol.
        """
        d2 = self.mahalanobis2(points) <= 1.0 + rtol
        return bool(d2[0]) if np.ndim(points) == 1 else d2

    def support(self, direction) -> float:
        """max over E of d^T x = d^T c + sqrt(d^T S d)."""
        d = as_vector(direction, "direction", self.dim)
        return float(d @ self.center + np.linalg.norm(self._chol.T @ d))

    def supports(self, directions) -> np.ndarray:
        """max over E of d^T x for each row d of ``directions`` (m, p)."""
        D = as_matrix(directions, "directions", self.dim)
        return D @ self.center + np.linalg.norm(D @ self._chol, axis=1)

    def extent(self, direction) -> tuple[float, float]:
        """(min, max) of d^T x over E."""
        d = as_vector(direction, "direction", self.dim)
        r = float(np.linalg.norm(self._chol.T @ d))
        m = float(d @ self.center)
        return m - r, m + r

    def intervals(self) -> tuple[np.ndarray, np.ndarray]:
        """Per-coordinate projections (lo, hi): c_j -+ sqrt(S_jj)."""
        r = np.sqrt(np.diag(self.shape))
        return self.center - r, self.center + r

    def project(self, i: int, j: int) -> Ellipsoid:
        """The shadow of E on the plane of coordinates (i, j): the 2-D ellipsoid of rows and columns
        (i, j) of c and S (exact)."""
        idx = plane(i, j, self.dim)
        return Ellipsoid(self.center[idx], self.shape[np.ix_(idx, idx)])

    def scaled(self, k: float) -> Ellipsoid:
        """The ellipsoid scaled by k about its centre (axes multiplied by k)."""
        if not (np.isfinite(k) and k > 0):
            raise InputError(f"scale factor must be finite and > 0, got {k}.")
        return Ellipsoid(self.center, k * k * self.shape)

    def boundary(self, n_points: int = 200) -> np.ndarray:
        """Points on the boundary of a 2-D ellipsoid, (n_points, 2), counter-clockwise and closed
        (the last point is the first), for plotting."""
        require_2d(self.dim, "ellipsoid")
        t = np.linspace(0.0, 2.0 * np.pi, n_points)[:-1]
        return closed(self.center + (self.factor @ np.vstack([np.cos(t), np.sin(t)])).T)

    def __repr__(self) -> str:
        c = np.array2string(self.center, precision=4)
        return f"Ellipsoid(dim={self.dim}, log_volume={self.log_volume():.4g}, center={c})"


class RootInformationEllipsoid(Ellipsoid):
    """The ellipsoid {x : |X x - z|^2 <= sigma} in square-root information form ([refs §QR]).

    Parameters
    ----------
    X : (n, n) array
        Upper triangular with a positive diagonal: the information matrix is M = X^T X (units:
        1 / parameter units).
    z : (n,) array
        X c, the centre in X's coordinates (dimensionless).
    sigma : float
        The level, > 0: S = sigma M^-1.

    Membership, support and the interval hull come from triangular solves with X, so they stay
    accurate when S = sigma X^-1 X^-T is too ill-conditioned to be held in double precision
    (nearly collinear regressors, a wide prior met by narrow strips). :attr:`shape` and
    :attr:`factor` are formed on request, for callers that need a matrix.
    """

    __slots__ = ("X", "z", "sigma", "_root")

    def __init__(self, X, z, sigma: float):
        self.z = as_vector(z, "z").copy()
        n = self.z.shape[0]
        self.X = as_matrix(X, "X", n).copy()
        if self.X.shape[0] != n:
            raise InputError(f"X must be {n} x {n} (z has {n} entries), got shape {self.X.shape}.")
        diag = np.diag(self.X)
        if np.any(np.tril(self.X, -1)) or not np.all(diag > 0):
            raise InputError("X must be upper triangular with a positive diagonal (M = X^T X positive definite); "
                             f"smallest diagonal entry {diag.min():.3g}. Take X from a QR or Cholesky factorisation.")
        if not (np.isfinite(sigma) and sigma > 0):
            raise InputError(f"sigma must be finite and > 0 (got {sigma}); sigma <= 0 is an empty set.")
        self.sigma = float(sigma)
        self.center = solve_triangular(self.X, self.z)
        self._root = None

    def __reduce__(self):  # pickled as its defining triple (the base's slots hold nothing here)
        return RootInformationEllipsoid, (self.X, self.z, self.sigma)

    @property
    def shape(self) -> np.ndarray:
        """S = L L^T (n, n), formed from :attr:`factor` (rounded: prefer the methods, which do not form it)."""
        L = self.factor
        return L @ L.T

    @property
    def factor(self) -> np.ndarray:
        """L = sqrt(sigma) X^-1 (upper triangular), S = L L^T."""
        if self._root is None:
            self._root = np.sqrt(self.sigma) * solve_triangular(self.X, np.eye(self.dim))
        return self._root

    @property
    def information(self) -> np.ndarray:
        """S^-1 = X^T X / sigma."""
        return (self.X.T @ self.X) / self.sigma

    def log_volume(self) -> float:
        """ln vol(E) = ln vol(unit ball) + (n/2) ln sigma - sum ln X_ii."""
        return log_unit_ball_volume(self.dim) + 0.5 * self.dim * np.log(self.sigma) - np.sum(np.log(np.diag(self.X)))

    def semi_axes(self) -> np.ndarray:
        """Semi-axis lengths, largest first: sqrt(sigma) over X's singular values."""
        return np.sqrt(self.sigma) / np.linalg.svd(self.X, compute_uv=False)[::-1]

    def mahalanobis2(self, points) -> np.ndarray:
        """|X x - z|^2 / sigma for each row x of ``points`` (m, n); <= 1 means inside. No inverse is taken."""
        P = np.atleast_2d(as_float_array(points, "points"))
        if P.shape[-1] != self.dim:
            raise InputError(f"points must have {self.dim} columns, got shape {P.shape}.")
        R = P @ self.X.T - self.z
        return np.sum(R * R, axis=1) / self.sigma

    def _half_widths(self, D: np.ndarray) -> np.ndarray:
        """sqrt(d^T S d) = sqrt(sigma) |X^-T d| for each row d of D (m, n)."""
        V = solve_triangular(self.X, D.T, trans="T")
        return np.sqrt(self.sigma) * np.linalg.norm(V, axis=0)

    def support(self, direction) -> float:
        """max over E of d^T x = d^T c + sqrt(sigma) |X^-T d|."""
        d = as_vector(direction, "direction", self.dim)
        return float(d @ self.center + self._half_widths(d[None, :])[0])

    def supports(self, directions) -> np.ndarray:
        D = as_matrix(directions, "directions", self.dim)
        return D @ self.center + self._half_widths(D)

    def extent(self, direction) -> tuple[float, float]:
        d = as_vector(direction, "direction", self.dim)
        r = float(self._half_widths(d[None, :])[0])
        m = float(d @ self.center)
        return m - r, m + r

    def intervals(self) -> tuple[np.ndarray, np.ndarray]:
        """c_j -+ sqrt(sigma) |X^-T e_j| (the row norms of L = sqrt(sigma) X^-1)."""
        r = np.linalg.norm(self.factor, axis=1)
        return self.center - r, self.center + r

    def project(self, i: int, j: int) -> Ellipsoid:
        """The shadow on the plane (i, j): the 2-D ellipsoid of rows (i, j) of L, shape L_ij L_ij^T (exact)."""
        idx = plane(i, j, self.dim)
        L = self.factor[idx]
        return Ellipsoid(self.center[idx], L @ L.T)

    def scaled(self, k: float) -> RootInformationEllipsoid:
        if not (np.isfinite(k) and k > 0):
            raise InputError(f"scale factor must be finite and > 0, got {k}.")
        return RootInformationEllipsoid(self.X, self.z, k * k * self.sigma)
