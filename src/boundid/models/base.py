"""The robot-model contract every robot implements (direct-drive arm, H4, linear toy).

Shapes: ``n`` joints, ``p`` parameters, ``N`` samples. State arrays are (N, n); the rule for a
single state (n,) is the same for every robot: the result of that state without the leading
sample axis (regressor (n, p), mass matrix (n, n), torque (n,), energy regressor (p,)), as a
batch (N, n) gives (N, n, p), (N, n, n), (N, n), (N, p). A robot writes its methods for a batch
and decorates them with :func:`per_state`. Regressors are linear in theta:

    tau      = Y(q, qd, qdd) theta                      (inverse dynamics, N x n x p)
    Y theta  = d/dt[Ya(q, qd) theta] + Yb(q, qd) theta  (momentum form, no qdd needed)
    H        = K + U = phi_H(q, qd) theta                (total energy, N x p)
    qd^T f   = phi_f(qd) theta                           (friction power, N x p)

so that the four regression models of :mod:`boundid.experiments.regression` work for any robot.
Coulomb friction is ``sign(qd)`` in the identification model; simulation may smooth it as
``tanh(qd / coulomb_width)`` (``coulomb_width`` in rad/s, 0 means the exact sign).
"""

from __future__ import annotations

import functools
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from numba import types

from boundid._validation import as_float_array
from boundid.errors import InputError
from boundid.models.limits import JointLimits

#: numba type of a model's optional compiled acceleration ``compiled_acceleration(y, u, theta,
#: coulomb_width, out)``: y (2n,) = [q, qd], u (n,) N m, theta (p,); writes qdd (n,) into ``out``.
#: The zero-order-hold simulator (boundid.experiments._hold_integrator) calls it without leaving numba.
ACCELERATION = types.void(types.float64[::1], types.float64[::1], types.float64[::1], types.float64,
                          types.float64[::1])


def coulomb(qd: np.ndarray, width: float = 0.0) -> np.ndarray:
    """sign(qd) (width 0) or its smooth approximation tanh(qd / width), width in rad/s."""
    if width < 0:
        raise InputError(f"coulomb_width must be >= 0 rad/s, got {width}.")
    return np.sign(qd) if width == 0 else np.tanh(qd / width)


def rk4_hold(acceleration, q: np.ndarray, qd: np.ndarray, dt: float, substeps: int) -> tuple[np.ndarray, np.ndarray]:
    """(q, qd) after dt s of ``substeps`` classical RK4 steps on (q, qd), with qdd = acceleration(q, qd)
    (the torque held constant inside it: a zero-order hold)."""
    hs = dt / substeps
    for _ in range(substeps):
        a1 = acceleration(q, qd)
        v2 = qd + 0.5 * hs * a1
        a2 = acceleration(q + 0.5 * hs * qd, v2)
        v3 = qd + 0.5 * hs * a2
        a3 = acceleration(q + 0.5 * hs * v2, v3)
        v4 = qd + hs * a3
        a4 = acceleration(q + hs * v3, v4)
        q, qd = q + hs / 6 * (qd + 2 * v2 + 2 * v3 + v4), qd + hs / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    return q, qd


def per_state(method):
    """A contract method written for a batch (N, n) -> (N, ...) that, given a single state (n,) as
    its first argument, returns the result of that state without the leading axis."""

    @functools.wraps(method)
    def wrapper(self, first, *args, **kwargs):
        out = method(self, first, *args, **kwargs)
        return out[0] if np.ndim(first) == 1 else out

    return wrapper


@dataclass(frozen=True)
class NoRobotOptions:
    """A robot without options."""


class RobotModel(ABC):
    """A rigid robot whose dynamics are linear in a parameter vector theta (p,)."""

    #: short identifier used in study files, e.g. "direct_drive"
    name: str
    #: number of actuated joints n
    n_joints: int
    #: parameter names (p,), in the order of theta
    param_names: tuple[str, ...]
    #: SI units of each parameter, e.g. "kg m^2", "N m s/rad"
    param_units: tuple[str, ...]
    #: the values used to simulate ("truth"), (p,)
    theta_true: np.ndarray
    #: a-priori (design) values, (p,), NaN where unknown
    theta_prior: np.ndarray

    #: per-joint limits: position range, velocity, acceleration and effort (the torque limit of
    #: each joint, N m), or None when the robot declares none (UrdfRobot reads them from its URDF)
    limits: JointLimits | None = None
    #: the typed options a study's robot.options may set (a frozen dataclass; see :meth:`from_options`)
    Options: type = NoRobotOptions
    #: qdd for one state as a numba function of type :data:`ACCELERATION`, or None: the open-loop
    #: simulator then runs every hold interval in one compiled call (DirectDriveArm declares one)
    compiled_acceleration = None

    @property
    def p(self) -> int:
        return len(self.param_names)

    @classmethod
    def from_options(cls, options) -> RobotModel:
        """The robot built from an instance of :attr:`Options` (default: its fields as keywords)."""
        return cls(**{f: getattr(options, f) for f in options.__dataclass_fields__})

    @property
    def param_definitions(self) -> tuple[str, ...]:
        """What each parameter is, when its name is a short symbol (base parameters: the
        regrouped combination of standard ones); default: the names themselves."""
        return tuple(self.param_names)

    # -- abilities (defaults; a robot overrides what it offers) ----------------------------
    def export_identified(self, theta, folder, base=None, estimate: str = "identified parameters",
                          cov=None) -> list:
        """Write identified parameters theta (p,) in the robot's own description formats into
        ``folder`` (a URDF robot: a copy of its URDF that simulators load, an MJCF fragment of the
        joints and YAML/CSV tables, with the base parameters ``base``
        (:class:`boundid.models.base_parameters.BaseParameters`) beside); ``estimate`` says what theta
        is, ``cov`` (p, p) is its covariance, for a projection onto the physical set when theta
        cannot be written as it is. Returns the paths written (default: none, the study's tables
        already hold theta)."""
        return []

    @property
    def experiments(self) -> tuple[str, ...]:
        """The simulated experiments this robot supports: "open_loop" (the direct-drive paper's
        torques (31)-(32), two joints) and/or "closed_loop" (the H4 paper's PI experiment)."""
        return ("open_loop",) if self.n_joints == 2 else ()

    def fast_acceleration(self, q, qd, u, theta, coulomb_width: float) -> list[float]:
        """qdd for ONE state in plain floats (the simulator's inner loop): q, qd, u (n,), theta (p,)
        sequences. Default: M(q)^-1 (u - bias); robots override it with a faster closed form."""
        qq, vv, th = np.asarray(q, float)[None], np.asarray(qd, float)[None], np.asarray(theta, float)
        acc = np.linalg.solve(self.mass_matrix(qq, th)[0],
                              np.asarray(u, float) - self.bias_torque(qq, vv, th, coulomb_width)[0])
        return acc.tolist()

    def physical_constraints(self):
        """The inequalities every physically meaningful theta satisfies (non-negative masses,
        inertias and friction, pseudo-inertia LMIs ...) as a
        :class:`boundid.sets.constraints.PhysicalConstraints`, or None when the robot states none."""
        return None

    def rest_position(self) -> np.ndarray:
        """Joint angles (n,) an exciting trajectory starts and ends at (default: zeros)."""
        return np.zeros(self.n_joints)

    def zoh_stepper(self):
        """A compiled stepper ``step(q, qd, tau, dt, substeps, coulomb_width, hint) -> (q, qd, hint)``
        advancing one state under a held torque, or None: the caller integrates
        :meth:`forward_dynamics` (``hint`` is the robot's own warm start, None at first)."""
        return None

    def compiled_closed_loop(self):
        """The sample loop of :func:`boundid.experiments.closed_loop.simulate_closed_loop` compiled
        for this robot, or None (the loop then runs in Python around :meth:`zoh_stepper`):
        ``run(q0, q_des, qd_des, feedforward, kp, ki, kd, h, gain, v_max, step, substeps,
        coulomb_width) -> (Q, QD, QM, V, SAT)`` with the same operations in the same order, hence
        the same numbers. q0 (n,) rad; q_des (N, n) rad, qd_des (N, n) rad/s; feedforward (N, n)
        N m, added to the PID torque before saturation (zeros: none); kp, ki, kd, gain, v_max (n,)
        (PID gains, amplifier gain, current-reference limit); h s; step rad per encoder count.
        Raises like the stepper when the robot leaves its reachable set."""
        return None

    def workspace_excursion(self, q, margin: float = 0.0) -> float:
        """How far joint positions q (N, n) take the robot out of its workspace (0 = inside; a
        robot without a workspace gives 0)."""
        return 0.0

    def outside_workspace(self, q) -> tuple[int, np.ndarray] | None:
        """(first sample index, its pose) where q (N, n) leaves the workspace, or None (inside, or
        no workspace)."""
        return None

    # -- input handling ---------------------------------------------------------------
    def _states(self, *arrays, names=("q", "qd", "qdd")) -> tuple[list[np.ndarray], bool]:
        """Check and reshape state arrays to (N, n); returns them and whether input was 1-D."""
        out, single = [], None
        for a, nm in zip(arrays, names, strict=False):
            a = as_float_array(a, nm)
            s = a.ndim == 1
            a = np.atleast_2d(a)
            if a.ndim != 2 or a.shape[1] != self.n_joints:
                raise InputError(
                    f"{nm} must have shape (N, {self.n_joints}) or ({self.n_joints},) for the "
                    f"{self.n_joints}-joint {self.name} model, got {np.shape(a)}."
                )
            if not np.all(np.isfinite(a)):
                raise InputError(f"{nm} contains NaN or infinite values; clean the data first.")
            single = s if single is None else single
            out.append(a)
        if len({a.shape[0] for a in out}) > 1:
            raise InputError(f"state arrays {names[: len(out)]} must have the same number of samples.")
        return out, bool(single)

    # -- the contract -------------------------------------------------------------------
    @abstractmethod
    def regressor(self, q, qd, qdd) -> np.ndarray:
        """Inverse-dynamics regressor Y (N, n, p): tau = Y theta (Coulomb as sign(qd))."""

    @abstractmethod
    def momentum_regressor(self, q, qd) -> np.ndarray:
        """Ya (N, n, p): generalized momentum M(q) qd = Ya theta."""

    @abstractmethod
    def remainder_regressor(self, q, qd) -> np.ndarray:
        """Yb (N, n, p) with Y theta = d/dt(Ya theta) + Yb theta."""

    @abstractmethod
    def energy_regressor(self, q, qd) -> np.ndarray:
        """phi_H (N, p): total energy H = K + U = phi_H theta (U up to a constant)."""

    @abstractmethod
    def friction_power_regressor(self, qd) -> np.ndarray:
        """phi_f (N, p): dissipated power qd^T f(qd) = phi_f theta."""

    @abstractmethod
    def mass_matrix(self, q, theta=None) -> np.ndarray:
        """Joint-space inertia M(q) (N, n, n) for parameters theta (default: truth)."""

    @abstractmethod
    def bias_torque(self, q, qd, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        """Everything but M(q) qdd in the torque (N, n): Coriolis, gravity, friction."""

    # -- derived ------------------------------------------------------------------------
    def _theta(self, theta) -> np.ndarray:
        if theta is None:
            return self.theta_true
        t = as_float_array(theta, "theta")
        if t.shape != (self.p,):
            raise InputError(f"theta must have shape ({self.p},) for {self.name}, got {t.shape}.")
        return t

    def inverse_dynamics(self, q, qd, qdd, theta=None) -> np.ndarray:
        """tau = Y(q, qd, qdd) theta, shape (N, n) ((n,) for one state)."""
        return self.regressor(q, qd, qdd) @ self._theta(theta)

    def forward_dynamics(self, q, qd, tau, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        """qdd = M(q)^-1 (tau - bias), shape (N, n) ((n,) for one state)."""
        (q2, qd2, tau2), single = self._states(q, qd, tau, names=("q", "qd", "tau"))
        rhs = tau2 - self.bias_torque(q2, qd2, theta, coulomb_width)
        qdd = np.linalg.solve(self.mass_matrix(q2, theta), rhs[..., None])[..., 0]
        return qdd[0] if single else qdd

    def energy(self, q, qd, theta=None) -> np.ndarray:
        """H = K + U (N,)."""
        return self.energy_regressor(q, qd) @ self._theta(theta)

    def describe(self) -> str:
        rows = [f"{self.name}: {self.n_joints} joints, {self.p} parameters"]
        for nm, u, t, a in zip(self.param_names, self.param_units, self.theta_true, self.theta_prior, strict=True):
            rows.append(f"  {nm:<8} [{u}]  true {t:.6g}  prior {a:.6g}")
        return "\n".join(rows)
