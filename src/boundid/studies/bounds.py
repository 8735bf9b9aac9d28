"""Choosing the error bound: gamma*, the smallest bound the data allow, three ways, and bound rules.

A set-membership guarantee is exactly as good as its bound e_max: on a recording there is no
truth to check it against. What the data do say is the smallest bound they are consistent with
([refs §gamma*]): for rows y_k = w_k^T theta + e_k and positive scales s_k,

    gamma* = min over theta in the prior box of max_k |y_k - w_k^T theta| / s_k        (one LP),

and the feasible set {theta : |y_k - w_k^T theta| <= e s_k for every k} is non-empty iff
e >= gamma*. Its minimiser is the Chebyshev (minimax) fit, and at e = gamma* the set is generically
one point. gamma* is a lower bound on the true errors' largest value, never an estimate of it
(on a MuJoCo UR5 recording the truth's largest error was 1.7 gamma*). Three scalings:

* ``one``: s_k = 1, one bound on every row (units of y);
* ``per_joint``: gamma*_j of joint j's rows alone, a lower bound on joint j's own bound (a
  joint-wise bound e_j >= gamma*_j for each j does not make the whole set non-empty: that needs
  the joint-wise LP, which is the ``one`` LP on bounds proportional to gamma*_j);
* ``wls_spread``: s_k = sigma_j, the residual standard deviation of joint j's rows (the
  IDIM-WLS weights [GautierKhalil1992]): gamma* then counts standard deviations.

A :class:`BoundRule` turns one of them into per-row bounds: e_k = factor x gamma* x s_k, with
s_k = 1, gamma*_j / gamma* or sigma_j by scaling.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from boundid.errors import InputError
from boundid.estimators.least_squares import wls
from boundid.experiments.regression import Regression
from boundid.sets import Polytope

SCALINGS = ("one", "per_joint", "wls_spread")


@dataclass(frozen=True)
class GammaStar:
    """gamma* of one regression with the prior box, three ways (see the module docstring).

    groups : (n,) the row groups (joints, 0-based; -1 for the scalar rows of the energy models), sorted
    one : gamma* with one bound on every row [unit]
    per_group : (n,) gamma*_j of each group's rows alone [unit]
    spread : (n,) each group's residual standard deviation sigma_j (IDIM-WLS) [unit]
    per_joint, scaled : gamma* with row bounds proportional to gamma*_j, and to sigma_j
        (dimensionless, >= 1 for per_joint: the joints' own gamma* are not jointly consistent)
    active : indices of the rows at the level of ``one`` at the Chebyshev fit (they decide it)
    chebyshev : (p,) the Chebyshev fit of ``one``
    unit : the unit of y
    """

    groups: np.ndarray
    one: float
    per_group: np.ndarray
    spread: np.ndarray
    per_joint: float
    scaled: float
    active: np.ndarray
    chebyshev: np.ndarray
    unit: str

    def smallest(self, scaling: str, group: np.ndarray) -> np.ndarray:
        """The smallest consistent per-row bounds (N,) [unit] under a scaling, for rows of the given
        groups: gamma* (one), gamma*_per_joint x gamma*_j, or gamma*_scaled x sigma_j. Every
        factor >= 1 of them leaves a non-empty feasible set."""
        if scaling not in SCALINGS:
            raise InputError(f"scaling must be one of {SCALINGS}, got {scaling!r}.")
        idx = np.searchsorted(self.groups, np.asarray(group))
        if scaling == "one":
            return np.full(idx.shape[0], self.one)
        if scaling == "per_joint":
            return self.per_joint * self.per_group[idx]
        return self.scaled * self.spread[idx]

    def table(self) -> list[dict]:
        """One row per group [unit]: gamma*_j of its rows, sigma_j, and the smallest consistent bound of its
        rows under each scaling (columns named by the scaling)."""
        return [{"joint": int(g) + 1 if g >= 0 else "all", "gamma*_j (own rows)": float(self.per_group[i]),
                 "sigma_j (WLS)": float(self.spread[i]), "one": self.one,
                 "per_joint": self.per_joint * float(self.per_group[i]),
                 "wls_spread": self.scaled * float(self.spread[i])}
                for i, g in enumerate(self.groups)]


@dataclass(frozen=True)
class BoundRule:
    """e_k = factor x the smallest consistent bound of row k under ``scaling``
    (:meth:`GammaStar.smallest`); factor 1 leaves a single point, a larger factor a margin."""

    factor: float
    scaling: str = "one"

    def __post_init__(self):
        if not (np.isfinite(self.factor) and self.factor >= 1.0):
            raise InputError(f"a bound rule's factor must be finite and >= 1 (below 1 no parameter vector is "
                             f"consistent with the data), got {self.factor}.")
        if self.scaling not in SCALINGS:
            raise InputError(f"a bound rule's scaling must be one of {SCALINGS}, got {self.scaling!r}.")

    def rows(self, gs: GammaStar, group) -> np.ndarray:
        """The per-row bounds (N,) [unit] for rows of the given groups."""
        return self.factor * gs.smallest(self.scaling, group)

    def describe(self) -> str:
        how = {"one": "one bound on every row", "per_joint": "in proportion to each joint's own gamma*",
               "wls_spread": "in proportion to each joint's WLS spread"}[self.scaling]
        return f"{self.factor:g} x gamma*, {how}"


#: the rule a study takes with ``e_max_rule = {}``: twice gamma*, one bound on every row. On MuJoCo recordings of
#: a UR5 (tests/test_bound_rule.py) the truth's largest row error was 1.25-1.71 gamma* on 5 seeds.
DEFAULT_RULE = BoundRule(2.0, "one")


def _gamma(W, y, scale, box) -> tuple[float, np.ndarray, np.ndarray]:
    c = Polytope.from_strips(W, y, scale, box=box).consistency()
    return float(c.gamma), c.active, c.theta


def gamma_star(reg: Regression, box: tuple[np.ndarray, np.ndarray]) -> GammaStar:
    """gamma* of ``reg`` within the prior ``box`` (lo, hi), three ways: n + 3 LPs and one WLS fit."""
    groups = np.unique(reg.joint)
    idx = np.searchsorted(groups, reg.joint)
    one, active, theta = _gamma(reg.W, reg.y, 1.0, box)
    per_group = np.array([_gamma(reg.W[reg.joint == g], reg.y[reg.joint == g], 1.0, box)[0] for g in groups])
    if groups.size > 1:
        spread = np.asarray(wls(reg.W, reg.y, reg.joint).info["sigma_group_values"], float)
    else:
        r = reg.y - reg.W @ np.linalg.lstsq(reg.W, reg.y)[0]
        spread = np.array([float(np.sqrt(r @ r / max(reg.n_rows - reg.W.shape[1], 1)))])
    floor = 1e-12 * max(one, np.finfo(float).tiny)  # a group fitted exactly (gamma*_j = 0): a positive scale
    per_joint = _gamma(reg.W, reg.y, np.maximum(per_group[idx], floor), box)[0]
    scaled = _gamma(reg.W, reg.y, np.maximum(spread[idx], floor), box)[0]
    return GammaStar(groups, one, per_group, spread, per_joint, scaled, active, theta, reg.unit)


def where_rows_sit(reg: Regression, t: np.ndarray, q: np.ndarray, tau: np.ndarray, rows) -> list[dict]:
    """Where each of ``rows`` (indices into ``reg``) sits in the recording (t (M,) [s], q, tau (M, n)):
    its time [s], joint (1-based), speed |qd| [rad/s] and torque |tau| [N m] at its sample, and a place:
    "reversal or stop" (speed below 5 % of the joint's largest), "torque extreme" (|tau| above 95 % of
    the joint's largest), "start or end" (the first or last 5 % of the recording), else "elsewhere"."""
    qd = np.gradient(q, t, axis=0)
    top_speed, top_tau = np.abs(qd).max(axis=0), np.abs(tau).max(axis=0)
    span = t[-1] - t[0]
    out = []
    for k in np.asarray(rows, int):
        i, j = int(min(np.searchsorted(t, reg.t[k]), t.size - 1)), int(reg.joint[k])
        speed = float(abs(qd[i, j])) if j >= 0 else float(np.linalg.norm(qd[i]))
        torque = float(abs(tau[i, j])) if j >= 0 else float(np.linalg.norm(tau[i]))
        if j >= 0 and speed < 0.05 * top_speed[j]:
            place = "reversal or stop"
        elif j >= 0 and torque > 0.95 * top_tau[j]:
            place = "torque extreme"
        elif min(t[i] - t[0], t[-1] - t[i]) < 0.05 * span:
            place = "start or end"
        else:
            place = "elsewhere"
        out.append({"row": int(k), "time [s]": float(reg.t[k]), "joint": j + 1 if j >= 0 else "all",
                    "|qd| [rad/s]": speed, "|tau| [N m]": torque, "where": place})
    return out


#: multiples of the smallest consistent bounds the page's sweep shows
SWEEP_FACTORS = (1.1, 1.5, 2.0, 3.0, 5.0)


def bound_sweep(reg: Regression, box: tuple[np.ndarray, np.ndarray], gs: GammaStar, scaling: str,
                reference: dict[str, np.ndarray], factors=SWEEP_FACTORS) -> list[dict]:
    """What the choice of the bound changes, over ``factors`` x the smallest consistent bounds of
    ``scaling``: the exact feasible set's interval widths over the prior box's (mean and median over
    the parameters; 2p LPs per factor), the parameters the data narrow below the prior box, and the
    rows each ``reference`` point (e.g. the WLS centre) violates at that bound (the Chebyshev fit of
    :attr:`GammaStar.chebyshev` violates none under the "one" scaling from factor 1)."""
    smallest = gs.smallest(scaling, reg.joint)
    prior_width = box[1] - box[0]
    out = []
    for f in factors:
        e = f * smallest
        b = Polytope.from_strips(reg.W, reg.y, e, box=box).bounds()
        ratio = (b.hi - b.lo) / prior_width
        row = {"factor": float(f), "mean width / prior": float(np.mean(ratio)),
               "median width / prior": float(np.median(ratio)),
               "parameters narrowed": int(np.sum(ratio < 1.0 - 1e-6))}
        for name, theta in reference.items():
            row[f"rows {name} violates"] = int(np.sum(np.abs(reg.y - reg.W @ theta) > e))
        out.append(row)
    return out
