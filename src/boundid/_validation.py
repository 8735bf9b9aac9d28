"""Input checks shared by every layer (in the spirit of scikit-learn's ``check_array``).

Each function returns a float64 array of the required shape or raises
:class:`boundid.errors.InputError` naming the argument, the problem and the fix.
"""

from __future__ import annotations

import numpy as np

from boundid.errors import InputError


def _finite(a: np.ndarray, name: str) -> np.ndarray:
    if not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))
        raise InputError(
            f"{name} contains {len(bad)} NaN or infinite value(s), the first at index "
            f"{tuple(int(i) for i in bad[0])}; remove or interpolate those samples first."
        )
    return a


def as_float_array(x, name: str) -> np.ndarray:
    try:
        return np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be numeric, got {type(x).__name__}: {exc}") from None


def as_vector(x, name: str, length: int | None = None) -> np.ndarray:
    """A finite 1-D float array, optionally of a given length."""
    a = as_float_array(x, name)
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1:
        raise InputError(f"{name} must be 1-D, got shape {a.shape}; flatten it or pass one row.")
    if length is not None and a.shape[0] != length:
        raise InputError(f"{name} must have length {length}, got {a.shape[0]}.")
    return _finite(a, name)


def as_matrix(x, name: str, ncols: int | None = None, min_rows: int = 1) -> np.ndarray:
    """A finite 2-D float array (rows = observations), optionally with ``ncols`` columns."""
    a = as_float_array(x, name)
    if a.ndim == 1 and ncols is not None and a.shape[0] == ncols:
        a = a.reshape(1, -1)
    if a.ndim != 2:
        raise InputError(
            f"{name} must be 2-D (observations x parameters), got shape {a.shape}."
        )
    if ncols is not None and a.shape[1] != ncols:
        raise InputError(f"{name} must have {ncols} columns (one per parameter), got {a.shape[1]}.")
    if a.shape[0] < min_rows:
        raise InputError(f"{name} must have at least {min_rows} row(s), got {a.shape[0]}.")
    return _finite(a, name)


def as_regression(W, y, name_w: str = "W", name_y: str = "y") -> tuple[np.ndarray, np.ndarray]:
    """The stacked observation matrix ``W`` (N, p) and target ``y`` (N,), checked together."""
    W = as_matrix(W, name_w)
    y = as_vector(y, name_y)
    if y.shape[0] != W.shape[0]:
        raise InputError(
            f"{name_w} has {W.shape[0]} rows but {name_y} has {y.shape[0]} entries; "
            "they must describe the same observations."
        )
    return W, y


def as_bounds(e_max, n_rows: int, name: str = "e_max") -> np.ndarray:
    """Per-row positive error bounds: a scalar is broadcast to ``n_rows``."""
    e = as_float_array(e_max, name)
    if e.ndim == 0:
        e = np.full(n_rows, float(e))
    if e.shape != (n_rows,):
        raise InputError(f"{name} must be a scalar or have shape ({n_rows},), got {e.shape}.")
    _finite(e, name)
    if np.any(e <= 0):
        raise InputError(
            f"{name} must be strictly positive (a zero bound makes the strip a hyperplane); "
            f"{int(np.sum(e <= 0))} entries are <= 0."
        )
    return e


def as_spd(S, name: str, n: int | None = None) -> np.ndarray:
    """A symmetric positive definite matrix (symmetrised if asymmetric only by rounding)."""
    S = as_float_array(S, name)
    if S.ndim != 2 or S.shape[0] != S.shape[1]:
        raise InputError(f"{name} must be a square matrix, got shape {S.shape}.")
    if n is not None and S.shape[0] != n:
        raise InputError(f"{name} must be {n} x {n}, got {S.shape}.")
    _finite(S, name)
    scale = max(np.max(np.abs(S)), np.finfo(float).tiny)
    if np.max(np.abs(S - S.T)) > 1e-8 * scale:
        raise InputError(f"{name} must be symmetric; max |S - S^T| = {np.max(np.abs(S - S.T)):.3g}.")
    S = 0.5 * (S + S.T)
    try:
        np.linalg.cholesky(S)
    except np.linalg.LinAlgError:
        eig = np.linalg.eigvalsh(S)
        raise InputError(
            f"{name} must be positive definite; its smallest eigenvalue is {eig[0]:.3g}. "
            "An ellipsoid needs a strictly positive shape: add a small multiple of the identity "
            "or drop the degenerate directions."
        ) from None
    return S


class NumbersOption(float):
    """The default of an option (a field of a robot's ``Options`` dataclass) that takes one number or a
    list of numbers (e.g. one per joint, the length checked by the owner); its value is the number used
    when the option is absent. A study file's options table accepts either form
    (:meth:`boundid.studies.schema.Section.options`)."""


class TablesOption(tuple):
    """The default of an option that takes a list of tables (TOML inline tables ``{key = value, ...}``),
    each checked by the option's owner; the default is the empty list."""
