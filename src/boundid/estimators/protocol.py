"""The estimator protocol: how every recursive estimator of boundid is built and fed.

Construction: ``Estimator(p, *, prior=None, center0=None, shape0=None, <options>, names=None)``.
``p`` is the number of parameters; every other argument is keyword-only. The prior (the set that
holds the true parameters before any data; for RLS and the Kalman filter, the Gaussian prior) is
given in one vocabulary, either as

* ``prior=`` a :class:`~boundid.sets.ConvexSet`: a :class:`~boundid.sets.Box` (centre +-
  half-widths, what a designer knows) or an :class:`~boundid.sets.Ellipsoid`; or
* ``center0=`` (p,) or a scalar (every parameter) and ``shape0=`` a scalar s (s I), a vector (the
  diagonal) or a (p, p) matrix: the ellipsoidal spelling, the ellipsoid
  E0 = {x : (x - center0)^T shape0^-1 (x - center0) <= 1} (shape0 in parameter units squared).

Each estimator takes the prior into its own family by the smallest enclosing conversion, so a
truth inside the prior stays inside: an ellipsoidal estimator (OBE, RLS, Kalman) reads a box
center +- h as the ellipsoid circumscribing it, semi-axes sqrt(p) h through the box's corners
(:func:`ellipsoid_prior`); a box-based one (box, parallelotope, zonotope, polytope recursions)
reads any other set as its interval hull (:func:`box_prior`). For RLS and Kalman the ellipsoid's
centre is the prior mean theta(0) and its shape the prior covariance P(0).

Feeding (every recursive estimator; batch estimators are functions, e.g. ``ols(W, y)``):

* ``fit(W, y, *bounds)`` starts from the prior (forgetting every row seen before), processes the
  rows of W (N, p) and y (N,) and returns the :class:`~boundid.estimators.Estimate`;
* ``partial_fit(W, y, *bounds)`` continues from the current state and returns the Estimate;
* ``update(w, y, *bounds)`` processes one row w (p,), y (scalar), continuing; returns the Estimate;
* ``estimate()`` the current Estimate; ``reset()`` back to the prior.

``*bounds`` is what the rows need besides (w, y): the error bound e_max (scalar or (N,)) of a
set-membership estimator, an optional per-row noise variance R of the Kalman filter, nothing for RLS.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from boundid._validation import as_float_array, as_spd, as_vector
from boundid.errors import InputError
from boundid.estimators.estimate import Estimate
from boundid.sets.box import Box
from boundid.sets.convex import ConvexSet
from boundid.sets.ellipsoid import Ellipsoid


def check_p(p) -> int:
    if isinstance(p, bool) or not (isinstance(p, int | np.integer) and p >= 1):
        raise InputError(f"p must be a positive integer (number of parameters), got {p!r}.")
    return int(p)


def check_names(names, p: int) -> tuple[str, ...] | None:
    """``None`` or a tuple of ``p`` parameter names."""
    if names is None:
        return None
    names = tuple(str(n) for n in names)
    if len(names) != p:
        raise InputError(f"{len(names)} parameter names given for {p} parameters; give one name per column of W.")
    return names


#: the range of the squared semi-axes (eigenvalues of shape0, parameter units squared) of an
#: ellipsoidal prior: the recursions multiply two of them and invert them, which stays within
#: floating point (normal numbers, about 1e-308 to 1e308) only between these
SHAPE_LIMITS = (1e-150, 1e150)


def _shape_matrix(shape0, p: int) -> np.ndarray:
    """shape0 as a (p, p) symmetric positive definite matrix: s -> s I, a vector -> its diagonal;
    its eigenvalues within :data:`SHAPE_LIMITS`."""
    S = as_float_array(shape0, "shape0")
    if S.ndim == 0:
        if not (np.isfinite(S) and S > 0):
            raise InputError(f"shape0 must be > 0 (a scalar s means s * I, squared radius s), got {float(S)}.")
        S = np.full(p, float(S))
    if S.ndim == 1:
        S = as_vector(S, "shape0", p)
        if np.any(S <= 0):
            raise InputError("shape0 given as a vector holds squared semi-axes; all must be > 0.")
        S = np.diag(S)
    S = as_spd(S, "shape0", p)
    eig = np.linalg.eigvalsh(S)
    lo, hi = SHAPE_LIMITS
    if eig[0] < lo or eig[-1] > hi:
        raise InputError(f"shape0 (the prior's squared semi-axes, in parameter units squared) must lie between "
                         f"{lo:g} and {hi:g}, got eigenvalues from {eig[0]:.3g} to {eig[-1]:.3g}: the recursions "
                         "multiply and invert them past floating point, so rescale the parameters (their units) "
                         "until the prior's half-widths are nearer 1.")
    return S


def _center(center0, p: int) -> np.ndarray:
    c = as_float_array(0.0 if center0 is None else center0, "center0")
    return np.full(p, float(c)) if c.ndim == 0 else as_vector(c, "center0", p).copy()


def _checked_prior(p: int, prior, center0, shape0) -> ConvexSet | None:
    if prior is None:
        return None
    if center0 is not None or shape0 is not None:
        raise InputError("give the prior once: either prior= (a Box or an Ellipsoid) or center0= and shape0= "
                         "(its ellipsoidal spelling), not both.")
    if not isinstance(prior, ConvexSet):
        raise InputError(f"prior must be a ConvexSet (a Box or an Ellipsoid), got {type(prior).__name__}.")
    if prior.dim != p:
        raise InputError(f"the prior has dimension {prior.dim} but the estimator {p} parameters.")
    return prior


def ellipsoid_prior(p: int, prior, center0, shape0, default_shape: float) -> tuple[np.ndarray, np.ndarray]:
    """The prior as an ellipsoid: (center (p,), shape (p, p)). A box center +- h becomes the
    ellipsoid circumscribing it, shape diag(p h^2); another set, the one circumscribing its
    interval hull; without a prior, center0 (default 0) and shape0 (default ``default_shape`` I)."""
    prior = _checked_prior(p, prior, center0, shape0)
    if prior is None:
        return _center(center0, p), _shape_matrix(default_shape if shape0 is None else shape0, p)
    if isinstance(prior, Ellipsoid):
        return prior.center.copy(), _shape_matrix(prior.shape, p)
    box = prior if isinstance(prior, Box) else Box(*prior.intervals())
    h = box.half_widths
    if np.any(h <= 0):
        raise InputError("the prior box must have every half-width > 0 (a zero range pins the parameter: "
                         "remove it instead).")
    return box.center.copy(), _shape_matrix(p * h**2, p)


def box_prior(p: int, prior, center0, shape0, default_shape: float) -> Box:
    """The prior as a box: a Box as it is, another set as its interval hull; without a prior, the
    bounding box of E0 = (center0, shape0), center0 +- sqrt(diag shape0)."""
    prior = _checked_prior(p, prior, center0, shape0)
    if prior is None:
        c = _center(center0, p)
        box = Box.from_center(c, np.sqrt(np.diag(_shape_matrix(default_shape if shape0 is None else shape0, p))))
    else:
        box = prior if isinstance(prior, Box) else Box(*prior.intervals())
    if not np.all(np.isfinite(box.half_widths) & (box.half_widths > 0)):
        raise InputError("the prior box must be finite with every half-width > 0 (the prior must have an interior).")
    return box


class RecursiveEstimator(ABC):
    """Base of the recursive estimators: ``fit`` = ``reset`` + ``partial_fit``; ``update`` = one row
    of ``partial_fit`` (subclasses may override it with a readable one-row reference)."""

    def __init__(self, p, names):
        self.p = check_p(p)
        self.names = check_names(names, self.p)

    @abstractmethod
    def reset(self) -> None:
        """Forget every row: back to the prior."""

    @abstractmethod
    def partial_fit(self, W, y, *args, **kwargs) -> Estimate:
        """Continue from the current state with the rows of W (N, p), y (N,)."""

    @abstractmethod
    def estimate(self) -> Estimate:
        """The current state as an Estimate."""

    def fit(self, W, y, *args, **kwargs) -> Estimate:
        """Start from the prior and process the rows of W (N, p), y (N,)."""
        self.reset()
        return self.partial_fit(W, y, *args, **kwargs)

    def update(self, w, y, *args, **kwargs) -> Estimate:
        """Process one row w (p,) with measurement y, continuing from the current state."""
        w = as_vector(w, "w", self.p)
        return self.partial_fit(w.reshape(1, -1), as_vector(y, "y", 1), *args, **kwargs)
