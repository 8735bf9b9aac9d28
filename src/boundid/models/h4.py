"""The H4 parallel robot's dynamic model, linear in 14 parameters ([H4Paper] eqs. 14, 18, 19).

    Gamma = Imot qdd + J^T M (xdd - G) + Fv qd + Fs sign(qd),   xdd = J qdd + Jdot qd   (14), (19)
    M = diag(Mnac, Mnac, Mnac, Ibc),  G = (0, 0, -g, 0)
    theta = [Imot1..4, Mnac, Ibc, Fv1..4, Fs1..4]                                      (18)

The joint state is the motor angles q (rad); the nacelle pose x = FK(q) is computed inside by the
Newton forward model. Geometry, true and prior values: docs/models.md (true = the
paper's Table I ellipsoid centre, prior = its a-priori column; friction has no prior, NaN).

Derived forms used by the regression models (K = kinetic, U = potential energy):

    momentum   p = (Imot + J^T M J) qd = Imot qd + J^T M xd                       -> Ya
    remainder  Y theta - dp/dt = -Jdot^T M xd - J^T M G + Fv qd + Fs sign(qd)       -> Yb
               (d/dt(J^T M xd) = Jdot^T M xd + J^T M xdd)
    energy     H = 1/2 sum Imot_i qd_i^2 + 1/2 Mnac |Dd|^2 + 1/2 Ibc thd^2 + Mnac g z   -> phi_H

:class:`H4Truth` is the robot as simulated: rotors, motor-side arms, forearm rods, nacelle and
cogging as physical bodies. Its ``theta_true`` is expressed in the 14 parameters of eq. (18): the
part of the arms and rods that acts exactly like a motor inertia (or a nacelle mass) is in it, as
the paper says of its Table I ("motor inertias ... encompass the inertia of the fore-arm"). What
eq. (14) cannot represent (arm weight, the rods' own rotation, cogging) is the structural error
the simulated data carry, bounded as a real robot's is.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from boundid.errors import InputError, UnreachablePoseError
from boundid.models import _h4_kernels as kern
from boundid.models.base import RobotModel, coulomb
from boundid.models.h4_kinematics import H4Geometry, H4Kinematics
from boundid.sets.constraints import PhysicalConstraints, constraints, nonnegative

PARAM_NAMES = ("Imot1", "Imot2", "Imot3", "Imot4", "Mnac", "Ibc",
               "Fv1", "Fv2", "Fv3", "Fv4", "Fs1", "Fs2", "Fs3", "Fs4")
PARAM_UNITS = ("kg m^2",) * 4 + ("kg", "kg m^2") + ("N m s/rad",) * 4 + ("N m",) * 4
#: Table I, estimated ellipsoid centre (used as the simulation truth)
THETA_TRUE = np.array([0.0199, 0.0133, 0.0189, 0.0250, 0.7914, 0.0005,
                       0.3093, 0.2166, 0.1235, 0.0752, 0.8126, 0.9390, 0.5360, 0.9868])
#: Table I, a-priori values (friction unknown)
THETA_PRIOR = np.array([0.012, 0.012, 0.012, 0.012, 1.0, 0.0008] + [np.nan] * 8)


@dataclass(frozen=True)
class H4Structural:
    """The bodies and effects eq. (14) leaves out; simulated by :class:`H4Truth`.

    link_mass : kg, each motor-side arm (motor axis P_i to elbow B_i), a uniform bar of length L
        turning with its motor.
    elbow_mass : kg, the elbow joint at B_i (a point mass at distance L from the axis).
    counter_mass : kg, a point mass on the arm's extension behind the motor axis, at
        ``counter_distance`` m from it, balancing the arm's weight.
        The arm's inertia about the motor axis, m L^2 / 3 + m_e L^2 + m_c b^2, is exactly a
        motor inertia (in ``represented``); the weight left unbalanced,
        (m L / 2 + m_e L - m_c b) g cos(q_i) about the axis, is not in eq. (14).
    rod_mass : kg, each forearm (elbow B_i to nacelle attachment A_i), a uniform thin rod of length
        l. Statically equivalent to half its mass at each end (same mass and centre of mass, hence
        the same weight): the elbow half is a motor inertia (m/2) L^2, the nacelle halves add
        2 m to Mnac and 2 m d^2 to Ibc (exactly, as the four sides cancel), all in
        ``represented``. Not representable: the elbow half's weight and the rod's own rotation
        (a uniform rod has m l^2 / 12 about its centre, the two end masses m l^2 / 4).
    ripple_amplitude : N m, cogging torque -a sin(n q_i) on each motor (conservative).
    ripple_periods : n, cogging cycles per motor turn.

    Default sizes (the real H4's are not public; chosen from what the paper states, for L = 0.3 m):
    - arms balanced: eq. (14) has no gravity term for the arms, so a robot it fits has arms whose
      weight is compensated. A 0.35 kg counter-mass 6 cm behind the axis balances the bar
      (0.14 kg, an aluminium 300 x 20 x 9 mm); the elbow joint (15 g) and the rods' elbow halves
      stay unbalanced: (0.015 + 0.005) kg x 0.3 m x g = 0.059 N m, the uncompensated arm weight.
    - the arm's inertia makes the mean rotor inertia, Table I Imot minus the arm and rod shares,
      the a-priori 0.012 kg m^2 "known by design" (the paper: the identified Imot exceed it
      because they encompass the arm): share 0.0073 kg m^2 per motor.
    - rod_mass 10 g: the paper's forearms are carbon tubes whose effects it neglects; Table I's
      Ibc = 0.0005 kg m^2 must hold their nacelle halves, 2 m d^2, so m <= 17 g with d = 0.12 m.
    - cogging 0.05 N m (0.3 % of the +-15 N m range), 24 cycles per turn.
    """

    link_mass: float = 0.14
    elbow_mass: float = 0.015
    counter_mass: float = 0.35
    counter_distance: float = 0.06
    rod_mass: float = 0.010
    ripple_amplitude: float = 0.05
    ripple_periods: int = 24

    def __post_init__(self):
        vals = (self.link_mass, self.elbow_mass, self.counter_mass, self.counter_distance, self.rod_mass,
                self.ripple_amplitude, self.ripple_periods)
        if not all(np.isfinite(v) and v >= 0 for v in vals):
            raise InputError(f"H4Structural values must be finite and >= 0, got {self}.")

    def scaled(self, k: float) -> H4Structural:
        """The same error sources with masses and ripple multiplied by k >= 0 (0 = none)."""
        if not (np.isfinite(k) and k >= 0):
            raise InputError(f"structural error scale must be finite and >= 0, got {k}.")
        return replace(self, link_mass=k * self.link_mass, elbow_mass=k * self.elbow_mass,
                       counter_mass=k * self.counter_mass, rod_mass=k * self.rod_mass,
                       ripple_amplitude=k * self.ripple_amplitude)

    def arm_inertia(self, L: float) -> float:
        """Inertia of one motor-side arm (bar, elbow, counter-mass) about its motor axis, kg m^2."""
        return (self.link_mass / 3.0 + self.elbow_mass) * L**2 + self.counter_mass * self.counter_distance**2

    def arm_moment(self, L: float) -> float:
        """Static moment left unbalanced, kg m: mass x distance of the arm's centre of mass from the axis."""
        return (0.5 * self.link_mass + self.elbow_mass) * L - self.counter_mass * self.counter_distance

    def represented(self, geometry: H4Geometry) -> np.ndarray:
        """theta increment (14,) of these bodies that eq. (14) represents exactly (see the class doc).

        Imot_i += I_arm + m_rod L^2 / 2,  Mnac += 2 m_rod,  Ibc += 2 m_rod d^2  (SI units).
        """
        share = np.zeros(len(PARAM_NAMES))
        share[:4] = self.arm_inertia(geometry.L) + 0.5 * self.rod_mass * geometry.L**2
        share[4] = 2.0 * self.rod_mass
        share[5] = 2.0 * self.rod_mass * geometry.d**2
        return share

    def kernel_array(self, L: float) -> np.ndarray:
        """The ``struct`` pack of :mod:`boundid.models._h4_kernels`: [I_arm, s_arm, m_rod, ripple, periods]."""
        return np.array([self.arm_inertia(L), self.arm_moment(L), self.rod_mass, self.ripple_amplitude,
                         float(self.ripple_periods)])


NO_STRUCTURAL_ERROR = H4Structural(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0)


class H4Robot(H4Kinematics, RobotModel):
    """The 4-dof H4 parallel robot, 14-parameter identification model (eq. 14/18).

    geometry : H4Geometry (default: the project's dimensions, see h4_kinematics)
    g : gravity, m/s^2
    theta_true : parameters used to simulate (default Table I centre)
    fk_tol, fk_max_iter : Newton forward-model tolerance (rad) and iteration cap
    """

    name = "h4"
    n_joints = 4
    param_names = PARAM_NAMES
    param_units = PARAM_UNITS
    #: neglected effects simulated on top of eq. (14): none for the identification model
    structural: H4Structural = NO_STRUCTURAL_ERROR

    #: robot.options: the geometry (m, rad)
    Options = H4Geometry

    @classmethod
    def from_options(cls, options: H4Geometry) -> H4Robot:
        return cls(options)

    def __init__(self, geometry: H4Geometry | None = None, g: float = 9.81, theta_true=None,
                 fk_tol: float = 1e-12, fk_max_iter: int = 30):
        super().__init__(geometry)
        if not (np.isfinite(g) and g >= 0):
            raise InputError(f"gravity g must be finite and >= 0 m/s^2, got {g}.")
        self.g = float(g)
        self.theta_true = THETA_TRUE.copy()
        if theta_true is not None:
            self.theta_true = self._theta(theta_true).copy()
        self.theta_prior = THETA_PRIOR.copy()
        if not (fk_tol > 0 and int(fk_max_iter) >= 1):
            raise InputError(f"fk_tol must be > 0 rad and fk_max_iter >= 1, got {fk_tol}, {fk_max_iter}.")
        self.fk_tol, self.fk_max_iter = float(fk_tol), int(fk_max_iter)
        geo = self.geometry
        self._geo = (geo.P, geo.V, geo.W, np.asarray(geo.side, float), np.asarray(geo.updown, float),
                     np.array([geo.L, geo.l, geo.d, geo.h]))

    # -- kinematics of joint states ---------------------------------------------------------
    def pose(self, q, x0=None) -> np.ndarray:
        """Nacelle poses x (N, 4) for motor angles q (N, 4) (Newton forward model, eq. 10)."""
        return self.forward_kinematics(q, x0, self.fk_tol, self.fk_max_iter)

    def kinematic_state(self, q, qd, x0=None):
        """(x, J, xd, Jdot) at joint states (q, qd): poses (N,4), J (N,4,4), xd = J qd (N,4), Jdot (N,4,4)."""
        (q, qd), _ = self._states(q, qd, names=("q", "qd"))
        ck = self.chains(self._converged_fk(q, x0, self.fk_tol, self.fk_max_iter), q)  # raises near singularities
        xd = np.einsum("nij,nj->ni", ck.J, qd)
        return ck.x, ck.J, xd, self._jdot(ck, qd)

    # -- regressors -------------------------------------------------------------------------
    def regressor_from_jacobians(self, qd, qdd, J, jdot_qd) -> np.ndarray:
        """Y (N, 4, 14) of eq. (14) given J (N,4,4) and Jdot qd (N,4) (e.g. Jdot by central differences)."""
        (qd, qdd), _ = self._states(qd, qdd, names=("qd", "qdd"))
        J, jdot_qd = np.asarray(J, float), np.asarray(jdot_qd, float)
        if J.shape != (len(qd), 4, 4) or jdot_qd.shape != (len(qd), 4):
            raise InputError(f"J must be ({len(qd)}, 4, 4) and jdot_qd ({len(qd)}, 4); got {J.shape}, "
                             f"{jdot_qd.shape}.")
        xdd = np.einsum("nij,nj->ni", J, qdd) + jdot_qd  # eq. (19)
        N = len(qd)
        Y = np.zeros((N, 4, 14))
        r = np.arange(4)
        Y[:, r, r] = qdd
        acc = xdd[:, :3].copy()
        acc[:, 2] += self.g  # xdd - G
        Y[:, :, 4] = np.einsum("nki,nk->ni", J[:, :3, :], acc)
        Y[:, :, 5] = J[:, 3, :] * xdd[:, 3, None]
        Y[:, r, 6 + r] = qd
        Y[:, r, 10 + r] = np.sign(qd)
        return Y

    def regressor(self, q, qd, qdd) -> np.ndarray:
        (q, qd, qdd), single = self._states(q, qd, qdd)
        _, J, _, Jd = self.kinematic_state(q, qd)
        Y = self.regressor_from_jacobians(qd, qdd, J, np.einsum("nij,nj->ni", Jd, qd))
        return Y[0] if single else Y

    def momentum_regressor(self, q, qd) -> np.ndarray:
        (q, qd), single = self._states(q, qd, names=("q", "qd"))
        _, J, xd, _ = self.kinematic_state(q, qd)
        Y = np.zeros((len(q), 4, 14))
        r = np.arange(4)
        Y[:, r, r] = qd
        Y[:, :, 4] = np.einsum("nki,nk->ni", J[:, :3, :], xd[:, :3])
        Y[:, :, 5] = J[:, 3, :] * xd[:, 3, None]
        return Y[0] if single else Y

    def remainder_regressor(self, q, qd) -> np.ndarray:
        (q, qd), single = self._states(q, qd, names=("q", "qd"))
        _, J, xd, Jd = self.kinematic_state(q, qd)
        Y = np.zeros((len(q), 4, 14))
        r = np.arange(4)
        Y[:, :, 4] = -np.einsum("nki,nk->ni", Jd[:, :3, :], xd[:, :3]) + self.g * J[:, 2, :]
        Y[:, :, 5] = -Jd[:, 3, :] * xd[:, 3, None]
        Y[:, r, 6 + r] = qd
        Y[:, r, 10 + r] = np.sign(qd)
        return Y[0] if single else Y

    def energy_regressor(self, q, qd) -> np.ndarray:
        (q, qd), single = self._states(q, qd, names=("q", "qd"))
        x, _, xd, _ = self.kinematic_state(q, qd)
        phi = np.zeros((len(q), 14))
        phi[:, :4] = 0.5 * qd**2
        phi[:, 4] = 0.5 * np.sum(xd[:, :3] ** 2, axis=1) + self.g * x[:, 2]
        phi[:, 5] = 0.5 * xd[:, 3] ** 2
        return phi[0] if single else phi

    def friction_power_regressor(self, qd) -> np.ndarray:
        (qd,), single = self._states(qd, names=("qd",))
        phi = np.zeros((len(qd), 14))
        phi[:, 6:10] = qd**2
        phi[:, 10:] = np.abs(qd)
        return phi[0] if single else phi

    # -- physical consistency -------------------------------------------------------------
    def physical_constraints(self) -> PhysicalConstraints:
        """Imot_i, Mnac, Ibc, Fv_i, Fs_i >= 0: every one of the 14 parameters of eq. (18).

        Derivations ([H4Paper] eq. (14)): Imot_i is the inertia about motor axis i of the rotor and
        of what turns rigidly with it (the integral of r^2 dm over those bodies, r the distance to
        the axis); Mnac is a mass (the nacelle's, with the rods' nacelle halves); Ibc is the
        nacelle's inertia about its vertical axis (again an integral of r^2 dm); friction
        dissipates: the power qd_i (Fv_i qd_i + Fs_i sign qd_i) = Fv_i qd_i^2 + Fs_i |qd_i| is >= 0
        for every qd_i iff Fv_i >= 0 (large |qd_i|) and Fs_i >= 0 (small |qd_i|). Together they
        make M(q) = diag(Imot) + J^T diag(Mnac, Mnac, Mnac, Ibc) J positive semidefinite at every
        pose, but are not implied by it: they come from what each parameter is.
        """
        why = (["a rotor's inertia about its motor axis (with the arm share): the integral of r^2 dm"] * 4
               + ["the nacelle's mass", "the nacelle's inertia about its vertical axis: the integral of r^2 dm"]
               + ["viscous friction dissipates: Fv qd^2 >= 0 for every qd"] * 4
               + ["Coulomb friction dissipates: Fs |qd| >= 0 for every qd"] * 4)
        return constraints(self.param_names, nonnegative(self.param_names, range(14), why))

    # -- joint-space dynamics (compiled kernel, includes the structural terms of H4Truth) ---
    def joint_dynamics(self, q, qd, theta=None, coulomb_width: float = 0.0, x0=None):
        """M(q) (N,4,4) and bias b(q, qd) (N,4) with tau = M qdd + b, and the poses x (N,4)."""
        (q, qd), _ = self._states(q, qd, names=("q", "qd"))
        coulomb(np.zeros(1), coulomb_width)  # validates the width
        theta = self._theta(theta)
        x0 = np.broadcast_to(np.asarray(self.geometry.home if x0 is None else x0, float), q.shape)
        M, b, x, ok = kern.dynamics_batch(q, qd, np.ascontiguousarray(x0), *self._geo, self._kernel_theta(theta),
                                          self.structural.kernel_array(self.geometry.L), self.g, float(coulomb_width),
                                          self.fk_tol, self.fk_max_iter)
        if not ok.all():
            n = int(np.argmin(ok))
            raise UnreachablePoseError(
                f"forward kinematics did not converge for q = {np.array2string(q[n], precision=4)} rad "
                f"(sample {n}; {int((~ok).sum())} of {len(q)} samples): motor angles outside the reachable set."
            )
        return M, b, x

    def mass_matrix(self, q, theta=None) -> np.ndarray:
        """Imot + J^T M J (N, 4, 4) (for H4Truth: of all its bodies, the rods' rotation included)."""
        (q,), single = self._states(q, names=("q",))
        M = self.joint_dynamics(q, np.zeros_like(q), theta)[0]
        return M[0] if single else M

    def bias_torque(self, q, qd, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        """J^T M (Jdot qd - G) + Fv qd + Fs c(qd) (N, 4) (plus the structural terms for H4Truth)."""
        (q, qd), single = self._states(q, qd, names=("q", "qd"))
        b = self.joint_dynamics(q, qd, theta, coulomb_width)[1]
        return b[0] if single else b

    def forward_dynamics(self, q, qd, tau, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        (q, qd, tau), single = self._states(q, qd, tau, names=("q", "qd", "tau"))
        M, b, _ = self.joint_dynamics(q, qd, theta, coulomb_width)
        qdd = np.linalg.solve(M, (tau - b)[..., None])[..., 0]
        return qdd[0] if single else qdd

    def inverse_dynamics(self, q, qd, qdd, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        """tau = M qdd + b (N, 4); equals Y theta for this model when coulomb_width = 0."""
        (q, qd, qdd), single = self._states(q, qd, qdd)
        M, b, _ = self.joint_dynamics(q, qd, theta, coulomb_width)
        tau = np.einsum("nij,nj->ni", M, qdd) + b
        return tau[0] if single else tau

    def step_kernel_args(self, theta=None) -> tuple:
        """Arguments after (q, qd, tau, x_hint, dt, substeps) of ``_h4_kernels.rk4_zoh`` for this robot."""
        return (*self._geo, self._kernel_theta(theta), self.structural.kernel_array(self.geometry.L), self.g)

    # -- abilities (boundid.models.base.RobotModel) -----------------------------------------
    @property
    def experiments(self) -> tuple[str, ...]:
        """The H4 paper's closed-loop PI experiment (its parallel structure has no open-loop one here)."""
        return ("closed_loop",)

    def rest_position(self) -> np.ndarray:
        """The motor angles of the home pose (inverse kinematics, eq. 9)."""
        return self.inverse_kinematics(np.asarray(self.geometry.home))

    def zoh_stepper(self):
        """The compiled RK4 stepper of ``_h4_kernels.rk4_zoh`` (warm-started Newton forward model;
        ``hint`` is the pose, the home pose at first); raises UnreachablePoseError when the robot
        leaves its reachable set."""
        args = self.step_kernel_args()

        def step(q, qd, tau, dt, substeps, coulomb_width, hint):
            x0 = np.asarray(self.geometry.home if hint is None else hint, float)
            q1, qd1, x1, ok = kern.rk4_zoh(q, qd, tau, x0, dt, substeps, *args, float(coulomb_width), self.fk_tol,
                                           self.fk_max_iter)
            if not ok:
                raise UnreachablePoseError(
                    f"the simulated robot left its reachable set near q = {np.array2string(q, precision=4)} rad; "
                    "lower the trajectory amplitude or stiffen the controller.")
            return q1, qd1, x1

        return step

    def compiled_closed_loop(self):
        """The closed loop compiled around ``_h4_kernels.rk4_zoh`` (``_h4_kernels.closed_loop``),
        from the home pose; raises UnreachablePoseError like :meth:`zoh_stepper`."""
        args = self.step_kernel_args()
        home = np.asarray(self.geometry.home, float)

        def run(q0, q_des, qd_des, feedforward, kp, ki, kd, h, gain, v_max, step, substeps, coulomb_width):
            Q, QD, QM, V, SAT, failed = kern.closed_loop(
                np.asarray(q0, float), *(np.ascontiguousarray(a, float) for a in (q_des, qd_des, feedforward)),
                *(np.ascontiguousarray(a, float) for a in (kp, ki, kd)), float(h),
                *(np.ascontiguousarray(a, float) for a in (gain, v_max)), float(step), int(substeps), home, *args,
                float(coulomb_width), self.fk_tol, self.fk_max_iter)
            if failed >= 0:
                raise UnreachablePoseError(
                    f"the simulated robot left its reachable set near q = {np.array2string(Q[failed], precision=4)} "
                    "rad; lower the trajectory amplitude or stiffen the controller.")
            return Q, QD, QM, V, SAT

        return run

    def workspace_excursion(self, q, margin: float = 0.0) -> float:
        """Sum of squared excursions (relative to the box width) of the poses of q (N, 4) outside the
        workspace box shrunk by ``margin`` (a fraction of its width), plus 1 per sample where the
        forward model fails (Newton to 1e-10 rad, 30 iterations)."""
        geo = self.geometry
        lo, hi = np.asarray(geo.workspace_low), np.asarray(geo.workspace_high)
        pad = margin * (hi - lo)
        q = np.asarray(q, float)
        x, ok = self._fk(q, np.tile(np.asarray(geo.home, float), (len(q), 1)), 1e-10, 30)
        x = x[ok]
        out = np.maximum(x - (hi - pad), 0.0) + np.maximum((lo + pad) - x, 0.0)
        return float(np.sum((out / (hi - lo)) ** 2) + np.sum(~ok))

    def outside_workspace(self, q) -> tuple[int, np.ndarray] | None:
        """(first index, pose) of q (N, 4) outside the workspace box; raises UnreachablePoseError
        where the forward model does not converge or meets a singularity."""
        x = self.pose(q)
        inside = self.in_workspace(x)
        if inside.all():
            return None
        k = int(np.argmin(inside))
        return k, x[k]

    def _kernel_theta(self, theta) -> np.ndarray:
        """The theta the compiled kernels take: eq. (18)'s own for the identification model."""
        return self._theta(theta)


class H4Truth(H4Robot):
    """The H4 robot as simulated: rotors, motor-side arms, forearm rods, nacelle and cogging.

    structural : H4Structural (default sizes) or a float k meaning ``H4Structural().scaled(k)``.
    theta_true : the simulated robot in eq. (18)'s parameters (default Table I centre): Imot_i
        includes the arms' and rods' motor-inertia share, Mnac and Ibc the rods' nacelle share
        (``H4Structural.represented``). ``body_parameters`` gives what is left for the rotors and
        the nacelle body. Raises InputError if that is not physical (e.g. structural too large).

    The regressors stay those of the identification model (what one identifies with); mass
    matrix, bias, forward/inverse dynamics and energy are the simulated robot's, so that
    ``inverse_dynamics - regressor @ theta_true`` is exactly the structural error.
    """

    name = "h4_truth"

    def __init__(self, geometry: H4Geometry | None = None, structural: H4Structural | float = 1.0, **kw):
        super().__init__(geometry, **kw)
        if not isinstance(structural, H4Structural):
            structural = H4Structural().scaled(float(structural))
        self.structural = structural
        self.body_parameters()  # the truth must be physical

    @property
    def represented_share(self) -> np.ndarray:
        """theta increment (14,) of the arms and rods that eq. (14) represents exactly."""
        return self.structural.represented(self.geometry)

    def body_parameters(self, theta=None) -> np.ndarray:
        """theta (14,) minus the arms' and rods' share: rotor inertias, nacelle body mass and inertia.

        Raises InputError unless rotors > 0, nacelle mass > 0 and nacelle inertia >= 0.
        """
        body = self._theta(theta) - self.represented_share
        physical = np.append(body[:5] > 0, body[5] >= 0)
        if not physical.all():
            bad = [f"{n} = {v:.4g}" for n, v, ok in zip(PARAM_NAMES, body, physical, strict=False) if not ok]
            raise InputError(
                f"the arms and rods of {self.structural} need more inertia than theta gives: the rotor and "
                f"nacelle-body values left ({', '.join(bad)}) are not physical. Lower the structural scale or "
                "the link/rod masses, or raise theta's Imot, Mnac, Ibc."
            )
        return body

    def _kernel_theta(self, theta) -> np.ndarray:
        return self.body_parameters(theta)

    def energy(self, q, qd, theta=None) -> np.ndarray:
        """H (N,) of the simulated robot: rotors and nacelle body + arms + forearm rods + cogging potential."""
        (q, qd), single = self._states(q, qd, names=("q", "qd"))
        H = super().energy(q, qd, self.body_parameters(theta))
        s, geo = self.structural, self.geometry
        x, J, xd, _ = self.kinematic_state(q, qd)
        A, dA = self.attachments(x)
        B, dB = self.elbows(q)
        Ad = np.einsum("nijk,nk->nij", dA, xd)
        Bd = dB * qd[..., None]
        kin = 0.5 * s.arm_inertia(geo.L) * np.sum(qd**2, axis=1)
        kin += s.rod_mass / 6.0 * np.sum(Ad * Ad + Ad * Bd + Bd * Bd, axis=(1, 2))
        arm_z = s.arm_moment(geo.L) / geo.L * (B[..., 2] - geo.P[:, 2])  # (mass x height) of each arm's centre
        pot = self.g * (arm_z.sum(1) + 0.5 * s.rod_mass * (A[..., 2] + B[..., 2]).sum(1))
        if s.ripple_amplitude > 0:
            pot += s.ripple_amplitude / s.ripple_periods * np.cos(s.ripple_periods * q).sum(1)
        H = H + kin + pot
        return H[0] if single else H
