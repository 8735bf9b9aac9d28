"""Ellipsoids E = {x : (x - c)^T S^-1 (x - c) <= 1}, the common currency of every estimator."""

from __future__ import annotations

import numpy as np
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
    def ball(cls, center, radius) -> Ellipsoid:
        """A ball, or an axis-aligned ellipsoid when ``radius`` is a vector of half-axes."""
        c = as_vector(center, "center")
        r = np.broadcast_to(as_float_array(radius, "radius"), c.shape)
        return cls(c, np.diag(r**2))

    @property
    def dim(self) -> int:
        return self.center.shape[0]

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
        return closed(self.center + (self._chol @ np.vstack([np.cos(t), np.sin(t)])).T)

    def __repr__(self) -> str:
        c = np.array2string(self.center, precision=4)
        return f"Ellipsoid(dim={self.dim}, log_volume={self.log_volume():.4g}, center={c})"
