"""Checks shared by the sets' 2-D methods (``project(i, j)`` and ``boundary``)."""

from __future__ import annotations

import numpy as np

from boundid.errors import InputError


def plane(i, j, dim: int) -> np.ndarray:
    """The index pair [i, j] of a coordinate plane, checked against ``dim``."""
    for k in (i, j):
        if not (isinstance(k, int | np.integer) and 0 <= k < dim):
            raise InputError(f"project(i, j) needs two coordinate indices in [0, {dim}), got ({i!r}, {j!r}).")
    if i == j:
        raise InputError(f"project(i, j) needs two different coordinates, got i = j = {i}.")
    return np.array([int(i), int(j)])


def require_2d(dim: int, cls: str) -> None:
    if dim != 2:
        raise InputError(f"boundary() draws 2-D sets; project() this {dim}-D {cls} on a plane first.")


def closed(vertices: np.ndarray) -> np.ndarray:
    """A counter-clockwise vertex list (m, 2) closed by repeating its first vertex."""
    return np.vstack([vertices, vertices[:1]])
