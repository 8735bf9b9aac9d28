"""`boundid certify`: check an ellipsoid from any recursive estimator against the exact optima of
the same regression data, both read from files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from boundid.errors import InputError
from boundid.estimators.certify import Certificate, validate
from boundid.sets import Ellipsoid, Polytope


def certificate_row(cert: Certificate) -> dict:
    """The headline numbers of a certificate, as one flat row (tables and JSON)."""
    return {
        "contains polytope": "yes" if cert.contains_polytope else "NO",
        "vertices checked": f"{cert.n_vertices} ({cert.vertex_kind})",
        "vertices outside": cert.n_outside,
        "max (x-c)^T S^-1 (x-c)": cert.max_mahalanobis2,
        "mean width / exact": float(np.mean(cert.width_ratio)),
        "max width / exact": float(np.max(cert.width_ratio)),
        "ln-vol excess / dim over SDP outer": cert.excess_outer,
        "ln-vol excess / dim over inner": cert.excess_inner,
    }


def read_regression(path: str | Path, e_max: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """W (N, p), y (N,), e_max (N,) from a CSV/Parquet with columns w1..wp, y and e_max."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"regression file {path} not found.")
    df = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    wcols = sorted((c for c in df.columns if c.startswith("w") and c[1:].isdigit()), key=lambda c: int(c[1:]))
    if not wcols or "y" not in df.columns:
        raise InputError(f"{path}: needs columns w1..wp and y (and e_max, or pass --e-max); got {list(df.columns)}.")
    if e_max is None and "e_max" not in df.columns:
        raise InputError(f"{path}: no e_max column; add one (the bound of each row) or pass --e-max.")
    e = np.full(len(df), float(e_max)) if e_max is not None else df["e_max"].to_numpy(float)
    return df[wcols].to_numpy(float), df["y"].to_numpy(float), e


def read_ellipsoid(path: str | Path) -> Ellipsoid:
    """JSON {"center", "shape"} or {"center", "information", "sigma"}; or CSV: centre row, then shape rows."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"ellipsoid file {path} not found.")
    if path.suffix == ".json":
        try:
            d = json.loads(path.read_text())
        except json.JSONDecodeError as exc:
            raise InputError(f"{path}: not valid JSON: {exc}") from None
        if "center" not in d or not ({"shape"} <= set(d) or {"information"} <= set(d)):
            raise InputError(f'{path}: expected keys "center" and "shape" (or "information" [and "sigma"]).')
        if "shape" in d:
            return Ellipsoid(d["center"], d["shape"])
        return Ellipsoid.from_information(d["center"], d["information"], d.get("sigma", 1.0))
    a = np.loadtxt(path, delimiter=",", ndmin=2)
    if a.shape[0] != a.shape[1] + 1:
        raise InputError(f"{path}: a CSV ellipsoid is p + 1 rows of p numbers (centre, then the p x p shape); "
                         f"got {a.shape}.")
    return Ellipsoid(a[0], a[1:])


def certify_files(regression: str | Path, ellipsoid: str | Path, e_max: float | None = None,
                  sdp: bool = True) -> Certificate:
    W, y, e = read_regression(regression, e_max)
    E = read_ellipsoid(ellipsoid)
    if E.dim != W.shape[1]:
        raise InputError(f"the ellipsoid has dimension {E.dim} but the regression {W.shape[1]} columns.")
    return validate(E, Polytope.from_strips(W, y, e), volumes=sdp)
