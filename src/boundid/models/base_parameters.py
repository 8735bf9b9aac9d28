"""Base parameters: the identifiable combinations of a robot's standard parameters [GautierKhalil1990].

Numerical method: stack the regressor over random states into W (N n x p).

1. Rank: QR with column pivoting, W P = Q R; r counts the |R_ii| > tol |R_11| (a stated
   tolerance, :data:`RANK_TOL`; the gap is kept in :attr:`BaseParameters.r_diag`).
2. Which parameters to keep: a sweep in theta's own order (QR without pivoting), keeping each
   column not in the span of the columns before it. theta lists the bodies from the base out, so
   the parameters of the outer links regroup into those of the inner ones, as in the symbolic
   rules of [GautierKhalil1990] (the pivoted order would pick columns by norm instead). Both
   steps must find the same r.
3. Regrouping: the dropped columns are combinations of the kept ones, W P2 = W P1 Kd (least
   squares, exact to rounding, checked), hence

       Y theta = Y P1 theta_1 + Y P2 theta_2 = Y P1 (theta_1 + Kd theta_2) = Y P1 beta,
       beta = K theta,   K = P1^T + Kd P2^T   (r x p, the regrouping matrix)

   and the base regressor is Y P1, the kept columns of Y.

Each base parameter has a symbol, its kept standard parameter with the suffix R when others are
regrouped into it (``Iyy2R``, the convention of [GautierKhalil1990]), and a definition, the
combination itself, e.g. ``Iyy2 + 0.1806 m3 + 0.1806 m4`` (coefficients rounded to 4 significant
digits in the text only; they carry lengths, m or m^2, and the unit is the kept parameter's).
The state sampling is seeded: the same robot always gives the same base parameters.

:class:`BaseParameterModel` is the robot seen in base parameters: a :class:`RobotModel` whose
theta is beta, so that every estimator and the exact LP/SDP bounds run on an identifiable vector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from boundid._validation import as_vector
from boundid.errors import InputError, SolverError
from boundid.models.base import RobotModel
from boundid.sets.constraints import PhysicalConstraints

#: Default rank tolerance on |R_ii| / |R_11| (the UR5 and the Panda show a gap from ~1e-2 to ~1e-16).
RANK_TOL = 1e-10


def _combination_name(coef: np.ndarray, names: tuple[str, ...], lead: int) -> str:
    """``lead`` name then ``+ c name`` terms for the other nonzero coefficients (4 significant digits)."""
    parts = [names[lead]]
    for j in np.flatnonzero(coef):
        if j == lead:
            continue
        c = float(coef[j])
        mag = f"{abs(c):.4g}"
        parts.append(f"{'+' if c > 0 else '-'} {'' if mag == '1' else mag + ' '}{names[j]}")
    return " ".join(parts)


@dataclass(frozen=True)
class BaseParameters:
    """The regrouping beta = K theta of p standard parameters into r base parameters.

    K : (r, p)            regrouping matrix (K[:, independent] = identity)
    independent : (r,)    indices of the kept standard parameters (P1), in theta's order
    names, units : (r,)   definitions (the combinations, readable) and the units of the kept parameters
    symbols : (r,)        short names: the kept parameter, suffixed R when others regroup into it
    tol : float           rank tolerance on |R_ii| / |R_11|
    r_diag : (p,)         |R_ii| / |R_11| of the pivoted QR (the gap shows how clear the rank is)
    """

    K: np.ndarray
    independent: np.ndarray
    names: tuple[str, ...]
    units: tuple[str, ...]
    tol: float
    r_diag: np.ndarray
    symbols: tuple[str, ...]

    @property
    def rank(self) -> int:
        return int(self.K.shape[0])

    @property
    def gap(self) -> tuple[float, float]:
        """(smallest kept, largest dropped) |R_ii| / |R_11|."""
        r = self.rank
        return float(self.r_diag[r - 1]), float(self.r_diag[r]) if r < len(self.r_diag) else 0.0

    def base(self, theta) -> np.ndarray:
        """beta = K theta (r,) of standard parameters theta (p,)."""
        return self.K @ as_vector(theta, "theta", self.K.shape[1])

    def standard(self, beta, reference) -> np.ndarray:
        """A standard vector with base parameters beta: reference + P1 (beta - K reference).

        The dependent parameters keep their reference values (e.g. the URDF's), the kept ones
        absorb the difference, so K standard(beta) = beta exactly.
        """
        beta = as_vector(beta, "beta", self.rank)
        ref = as_vector(reference, "reference", self.K.shape[1])
        out = ref.copy()
        out[self.independent] += beta - self.K @ ref
        return out


def base_parameters(robot: RobotModel, n_states: int | None = None, tol: float = RANK_TOL,
                    seed: int = 0) -> BaseParameters:
    """Base parameters of ``robot`` from its regressor at random states (module docstring).

    Positions are uniform within ``robot.limits`` when the robot has them (clipped to [-pi, pi]),
    else in [-pi, pi]; velocities and accelerations uniform within the velocity and acceleration
    limits (else [-1, 1] rad/s and rad/s^2), both signs so that Coulomb and offset columns separate.
    n_states : number of random states (default max(200, 2 p)); seed : of the sampling.
    """
    if not 0 < tol < 1:
        raise InputError(f"tol must be in (0, 1), got {tol}.")
    n, p = robot.n_joints, robot.p
    n_states = max(200, 2 * p) if n_states is None else int(n_states)
    if n_states * n < p:
        raise InputError(f"{n_states} states give {n_states * n} rows for {p} parameters; use more states.")
    rng = np.random.default_rng(seed)
    limits = getattr(robot, "limits", None)
    if limits is not None:
        q = limits.sample_positions(rng, n_states)
        vmax = np.where(np.isfinite(limits.velocity), limits.velocity, 1.0)
        amax = np.where(np.isfinite(limits.acceleration), limits.acceleration, 1.0)
    else:
        q = rng.uniform(-np.pi, np.pi, (n_states, n))
        vmax = amax = np.ones(n)
    qd = rng.uniform(-1.0, 1.0, (n_states, n)) * vmax
    qdd = rng.uniform(-1.0, 1.0, (n_states, n)) * amax
    W = robot.regressor(q, qd, qdd).reshape(-1, p)
    # the rank, from the pivoted QR
    _, R, _ = scipy.linalg.qr(W, mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    if d[0] == 0:
        raise InputError(f"the regressor of {robot.name} is zero at every sampled state; nothing is identifiable.")
    r_diag = np.zeros(p)
    r_diag[:len(d)] = d / d[0]
    r = int(np.sum(r_diag > tol))
    # which parameters to keep: the sweep in theta's order (QR without pivoting), so that the
    # parameters of the outer links regroup into those of the inner ones, as in the symbolic rules
    R0 = scipy.linalg.qr(W, mode="r")[0]
    kept = np.abs(np.diag(R0))[:p] > tol * d[0]
    if int(kept.sum()) != r:
        raise SolverError(f"rank {r} by pivoted QR but {int(kept.sum())} independent columns in theta's order at "
                          f"tol = {tol:g}; the rank is ambiguous. Sample more states or change tol.")
    keep, dep = np.flatnonzero(kept), np.flatnonzero(~kept)
    Kd = scipy.linalg.lstsq(W[:, keep], W[:, dep])[0] if len(dep) else np.zeros((r, 0))
    Kd[np.abs(Kd) < 1e-10] = 0.0
    near = np.abs(Kd - np.round(Kd)) < 1e-10
    Kd[near] = np.round(Kd[near])
    if np.linalg.norm(W[:, dep] - W[:, keep] @ Kd) > 1e-8 * np.linalg.norm(W):
        raise SolverError("the regrouping W P2 = W P1 Kd does not hold to 1e-8; the rank is ambiguous. Sample more "
                          "states or change tol.")
    K = np.zeros((r, p))
    K[np.arange(r), keep] = 1.0
    K[:, dep] = Kd
    names = tuple(_combination_name(K[i], tuple(robot.param_names), keep[i]) for i in range(r))
    units = tuple(robot.param_units[j] for j in keep)
    symbols = tuple(robot.param_names[keep[i]] + ("R" if np.count_nonzero(K[i]) > 1 else "") for i in range(r))
    return BaseParameters(K, keep, names, units, float(tol), r_diag, symbols)


class BaseParameterModel(RobotModel):
    """``robot`` seen in base parameters: theta is beta = K theta_standard (r,).

    Every regressor is the standard one restricted to the kept columns, Y P1. The energy
    regressor is then exact up to a constant (parameters that do not move the torque can only shift
    U by a constant), which the energy models remove (they use H - H(0)). Dynamics (mass matrix,
    bias, forward dynamics) are those of the standard vector ``base.standard(beta,
    robot.theta_true)``, which gives the same torques as any theta with K theta = beta.
    """

    def __init__(self, robot: RobotModel, base: BaseParameters | None = None):
        self.robot = robot
        self.base = base_parameters(robot) if base is None else base
        if self.base.K.shape[1] != robot.p:
            raise InputError(f"base parameters for {self.base.K.shape[1]} standard parameters, robot has {robot.p}.")
        self.name = f"{robot.name}_base"
        self.n_joints = robot.n_joints
        self.param_names = self.base.symbols
        self.param_units = self.base.units
        self.theta_true = self.base.base(robot.theta_true)
        K, prior = self.base.K, np.asarray(robot.theta_prior, float)
        involved = K != 0  # NaN (unknown) only where an involved standard prior is unknown
        self.theta_prior = np.where(np.any(involved & np.isnan(prior), axis=1), np.nan,
                                    np.where(involved, K * np.nan_to_num(prior), 0.0).sum(axis=1))
        self._cols = self.base.independent
        self._fast_beta: list[float] | None = None
        if getattr(robot, "limits", None) is not None:
            self.limits = robot.limits

    def standard(self, beta=None) -> np.ndarray:
        """The standard vector used for the dynamics of beta (default: the robot's truth)."""
        return self.robot.theta_true if beta is None else self.base.standard(self._theta(beta), self.robot.theta_true)

    def physical_constraints(self, **options) -> PhysicalConstraints:
        """The robot's constraints on its standard parameters x, lifted to beta = K x
        [SousaCortesao2014]: the physically consistent beta are {K x : x satisfies them}, a
        projection kept in lifted form (options: those of the robot's ``physical_constraints``)."""
        own = getattr(self.robot, "physical_constraints", None)
        if own is None:
            raise InputError(f"{self.robot.name} declares no physical constraints on its standard parameters.")
        return own(**options).lifted(self.base.K, self.param_names)

    @property
    def param_definitions(self) -> tuple[str, ...]:
        """What each base parameter is, in standard parameters (``Iyy2 + 0.1806 m3 ...``)."""
        return self.base.names

    # abilities of the robot it views (its simulations run on the robot's own truth)
    @property
    def experiments(self) -> tuple[str, ...]:
        return self.robot.experiments

    def rest_position(self) -> np.ndarray:
        return self.robot.rest_position()

    def zoh_stepper(self):
        return self.robot.zoh_stepper()

    def export_identified(self, theta, folder, base=None, estimate: str = "identified parameters",
                          cov=None) -> list:
        """The robot's export of beta = theta (r,) as :meth:`standard` (theta) and ``self.base`` (any
        standard vector with these base parameters: the robot chooses the one it writes); ``cov``
        (r, r) is theta's covariance."""
        return self.robot.export_identified(self.standard(theta), folder, base=self.base, estimate=estimate, cov=cov)

    def workspace_excursion(self, q, margin: float = 0.0) -> float:
        return self.robot.workspace_excursion(q, margin)

    def outside_workspace(self, q):
        return self.robot.outside_workspace(q)

    def regressor(self, q, qd, qdd) -> np.ndarray:
        return self.robot.regressor(q, qd, qdd)[..., self._cols]

    def momentum_regressor(self, q, qd) -> np.ndarray:
        return self.robot.momentum_regressor(q, qd)[..., self._cols]

    def remainder_regressor(self, q, qd) -> np.ndarray:
        return self.robot.remainder_regressor(q, qd)[..., self._cols]

    def energy_regressor(self, q, qd) -> np.ndarray:
        return self.robot.energy_regressor(q, qd)[..., self._cols]

    def friction_power_regressor(self, qd) -> np.ndarray:
        return self.robot.friction_power_regressor(qd)[..., self._cols]

    def mass_matrix(self, q, theta=None) -> np.ndarray:
        return self.robot.mass_matrix(q, self.standard(theta))

    def bias_torque(self, q, qd, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        return self.robot.bias_torque(q, qd, self.standard(theta), coulomb_width)

    def forward_dynamics(self, q, qd, tau, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        return self.robot.forward_dynamics(q, qd, tau, self.standard(theta), coulomb_width)

    def fast_acceleration(self, q, qd, u, theta, coulomb_width: float) -> list[float]:
        """qdd for ONE state, through the robot's own fast path when it has one (simulator hook)."""
        theta = list(theta)
        if theta != self._fast_beta:  # the simulator passes the same values at every call
            self._fast_beta = theta
            self._fast_theta = self.base.standard(theta, self.robot.theta_true).tolist()
        fast = getattr(self.robot, "fast_acceleration", None)
        if fast is None:
            return self.robot.forward_dynamics(q, qd, u, self._fast_theta, coulomb_width)[0].tolist()
        return fast(q, qd, u, self._fast_theta, coulomb_width)
