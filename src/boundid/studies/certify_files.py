"""`boundid certify`: check an ellipsoid from any recursive estimator against the exact optima of
the same regression data, both read from files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from boundid.errors import InputError
from boundid.estimators.certify import Certificate, validate
from boundid.experiments.recording import numeric_columns, read_table
from boundid.sets import Ellipsoid, Polytope


def certificate_row(cert: Certificate) -> dict:
    """The headline numbers of a certificate, as one flat row (tables and JSON)."""
    return {
        "contains polytope": "yes" if cert.contains_polytope else "NO",
        "vertices checked": f"{cert.n_vertices} ({cert.vertex_kind})",
        "vertices outside": cert.n_outside,
        "support >= exact": "yes" if cert.support_ok else "NO",
        "max gauge (ellipsoid: (x-c)^T S^-1 (x-c))": cert.max_gauge,
        "mean width / exact": float(np.mean(cert.width_ratio)),
        "max width / exact": float(np.max(cert.width_ratio)),
        "ln-vol excess / dim over SDP outer": cert.excess_outer,
        "ln-vol excess / dim over inner": cert.excess_inner,
    }


def read_regression(path: str | Path, e_max: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """W (N, p), y (N,), e_max (N,) from a CSV/Parquet with columns w1..wp, y and e_max.

    InputError naming the file, column and row for an unreadable file or a cell that is not a number.
    """
    path = Path(path)
    df = read_table(path, "regression file")
    wcols = sorted((c for c in df.columns if c.startswith("w") and c[1:].isdigit()), key=lambda c: int(c[1:]))
    if not wcols or "y" not in df.columns:
        raise InputError(f"{path}: needs columns w1..wp and y (and e_max, or pass --e-max); got {list(df.columns)}.")
    if e_max is None and "e_max" not in df.columns:
        raise InputError(f"{path}: no e_max column; add one (the bound of each row) or pass --e-max.")
    data = numeric_columns(df, [*wcols, "y"] + ([] if e_max is not None else ["e_max"]), path, "regression file")
    p = len(wcols)
    e = np.full(len(df), float(e_max)) if e_max is not None else data[:, p + 1]
    return data[:, :p], data[:, p], e


def _is_number(x) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _json_array(d: dict, key: str, path: Path, ndim: int) -> np.ndarray:
    """``d[key]`` as a list of numbers (ndim 1) or of rows of numbers (ndim 2); InputError naming the key."""
    v = d[key]
    if ndim == 1:
        ok, what = isinstance(v, list) and all(map(_is_number, v)), "a list of numbers"
    else:
        ok = (isinstance(v, list) and all(isinstance(row, list) and all(map(_is_number, row)) for row in v)
              and len({len(row) for row in v}) <= 1)
        what = "a list of rows of equal length, each a list of numbers"
    if not ok:
        raise InputError(f'{path}: "{key}" must be {what}, got {json.dumps(v)[:80]}.')
    return np.asarray(v, dtype=float)


def read_ellipsoid(path: str | Path) -> Ellipsoid:
    """JSON {"center", "shape"} or {"center", "information", "sigma"}; or CSV: centre row, then shape rows."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"ellipsoid file {path} not found.")
    if path.suffix == ".json":
        try:
            d = json.loads(path.read_bytes().decode("utf-8"))
        except UnicodeDecodeError:
            raise InputError(f"{path}: not UTF-8 text; save the JSON file as UTF-8.") from None
        except json.JSONDecodeError as exc:
            raise InputError(f"{path}: not valid JSON: {exc}") from None
        if not isinstance(d, dict) or "center" not in d or not ({"shape"} <= set(d) or {"information"} <= set(d)):
            raise InputError(f'{path}: expected an object with keys "center" and "shape" (or "information" '
                             '[and "sigma"]).')
        center = _json_array(d, "center", path, 1)
        if "shape" in d:
            return Ellipsoid(center, _json_array(d, "shape", path, 2))
        sigma = d.get("sigma", 1.0)
        if not _is_number(sigma):
            raise InputError(f'{path}: "sigma" must be a positive number, got {json.dumps(sigma)[:80]}.')
        return Ellipsoid.from_information(center, _json_array(d, "information", path, 2), float(sigma))
    try:
        a = np.loadtxt(path, delimiter=",", ndmin=2)
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: a CSV ellipsoid is p + 1 rows of p numbers; reading it failed: "
                         f"{' '.join(str(exc).split())}") from None
    if a.shape[0] != a.shape[1] + 1:
        raise InputError(f"{path}: a CSV ellipsoid is p + 1 rows of p numbers (centre, then the p x p shape); "
                         f"got {a.shape}.")
    return Ellipsoid(a[0], a[1:])


def certify_files(regression: str | Path, ellipsoid: str | Path, e_max: float | None = None,
                  sdp: bool = True) -> Certificate:
    """``boundid certify``: the :class:`~boundid.estimators.Certificate` of the ellipsoid in the file
    ``ellipsoid`` (:func:`read_ellipsoid`) against the exact polytope of the regression in the file
    ``regression`` (:func:`read_regression`; ``e_max`` one bound for every row instead of its
    e_max column); ``sdp=False`` skips the SDP volume comparison. Raises InputError on a file
    that cannot be read or an ellipsoid of another dimension than the regression."""
    W, y, e = read_regression(regression, e_max)
    E = read_ellipsoid(ellipsoid)
    if E.dim != W.shape[1]:
        raise InputError(f"the ellipsoid has dimension {E.dim} but the regression {W.shape[1]} columns.")
    return validate(E, Polytope.from_strips(W, y, e), volumes=sdp)
