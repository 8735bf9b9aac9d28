"""The 2-dof direct-drive arm of [DirectDrivePaper] (CICESE arm), linear in 9 parameters.

Two links moving in the vertical plane, angles measured from the downward vertical (q = 0 is
hanging at rest). The parameter vector (paper section 5, docs/models.md) is

    th1 = m1 lc1^2 + m2 l1^2 + m2 lc2^2 + I1 + I2   [kg m^2]
    th2 = l1 m2 lc2                                  [kg m^2]
    th3 = m2 lc2^2 + I2                              [kg m^2]
    th4 = g (lc1 m1 + m2 l1)                         [N m]
    th5 = g m2 lc2                                   [N m]
    b1, b2   viscous friction                        [N m s/rad]
    fc1, fc2 Coulomb friction                        [N m]

    M(q)     = [[th1 + 2 th2 cos q2, th3 + th2 cos q2], [th3 + th2 cos q2, th3]]
    C(q, qd) = th2 sin q2 [[-qd2, -(qd1 + qd2)], [qd1, 0]]
    g(q)     = [th4 sin q1 + th5 sin(q1 + q2), th5 sin(q1 + q2)]
    f(qd)    = [b1 qd1 + fc1 sgn qd1, b2 qd2 + fc2 sgn qd2]
    K        = 1/2 th1 qd1^2 + th2 cos q2 (qd1^2 + qd1 qd2) + th3 (qd1 qd2 + 1/2 qd2^2)
    U        = th4 (1 - cos q1) + th5 (1 - cos(q1 + q2))      (the paper's zero: U = 0 hanging down)
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from numba import njit

from boundid.errors import InputError
from boundid.models.base import ACCELERATION, RobotModel, coulomb, per_state
from boundid.sets.constraints import Cone, LinearRows, PhysicalConstraints, constraints, linear_rows, nonnegative


@dataclass(frozen=True)
class DirectDriveOptions:
    """robot.options of the direct-drive arm: its physical values (docs/models.md), SI units:
    masses kg, lengths m, inertias kg m^2, g m/s^2, viscous b N m s/rad, Coulomb fc N m."""

    m1: float = 23.902
    m2: float = 3.880
    l1: float = 0.45
    l2: float = 0.45
    lc1: float = 0.091
    lc2: float = 0.048
    I1: float = 1.266
    I2: float = 0.093
    g: float = 9.81
    b1: float = 2.288
    b2: float = 0.175
    fc1: float = 7.17
    fc2: float = 1.734


#: Physical values of the CICESE direct-drive arm (docs/models.md), SI units.
PHYSICAL = asdict(DirectDriveOptions())


def planar_arm_urdf(folder, P: dict = PHYSICAL, name: str = "planar_arm.urdf") -> Path:
    """The arm written as a 2-link URDF in ``folder`` (returns its path): joints about x, links hanging
    along -z at q = 0, centres of mass on the link axes, the arm's viscous and Coulomb friction in
    <dynamics>. With gravity (0, 0, -g) its dynamics are the arm's (the URDF tests check torques, mass
    matrix, energy and base parameters against this module's closed forms)."""
    def link(lname, m, lc, I):
        return (f'<link name="{lname}"><inertial><origin xyz="0 0 {-lc}"/><mass value="{m}"/>'
                f'<inertia ixx="{I}" ixy="0" ixz="0" iyy="{I}" iyz="0" izz="{I / 10}"/></inertial></link>')

    def joint(jname, parent, child, z, b, fc):
        return (f'<joint name="{jname}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="0 0 {-z}"/><axis xyz="1 0 0"/>'
                f'<limit lower="-3.14" upper="3.14" velocity="6" effort="200"/>'
                f'<dynamics damping="{b}" friction="{fc}"/></joint>')
    body = (link("l1", P["m1"], P["lc1"], P["I1"]) + link("l2", P["m2"], P["lc2"], P["I2"])
            + joint("j1", "base", "l1", 0.0, P["b1"], P["fc1"]) + joint("j2", "l1", "l2", P["l1"], P["b2"], P["fc2"]))
    path = Path(folder) / name
    path.write_text(f'<robot name="r"><link name="base"/>{body}</robot>')
    return path


@njit(ACCELERATION, cache=True)
def _acceleration(y, u, theta, coulomb_width, out):
    """out = qdd (2,) at the state y = [q1, q2, qd1, qd2] under the torque u (2,) N m: M^-1 (u - C qd
    - g - f) by the 2 x 2 closed form, Coulomb friction as tanh(qd / width) (sign(qd) for width 0)."""
    t1, t2, t3, t4, t5, b1, b2, f1, f2 = theta[0], theta[1], theta[2], theta[3], theta[4], theta[5], theta[6], \
        theta[7], theta[8]
    v1, v2 = y[2], y[3]
    s2, c2 = math.sin(y[1]), math.cos(y[1])
    if coulomb_width > 0:
        g1, g2 = math.tanh(v1 / coulomb_width), math.tanh(v2 / coulomb_width)
    else:
        g1, g2 = np.sign(v1), np.sign(v2)
    s12 = math.sin(y[0] + y[1])
    r1 = u[0] - (-t2 * s2 * (2 * v1 * v2 + v2 * v2) + t4 * math.sin(y[0]) + t5 * s12 + b1 * v1 + f1 * g1)
    r2 = u[1] - (t2 * s2 * v1 * v1 + t5 * s12 + b2 * v2 + f2 * g2)
    m11, m12 = t1 + 2 * t2 * c2, t3 + t2 * c2
    det = m11 * t3 - m12 * m12
    out[0] = (t3 * r1 - m12 * r2) / det
    out[1] = (m11 * r2 - m12 * r1) / det


class DirectDriveArm(RobotModel):
    """The 9-parameter direct-drive arm; ``theta_true`` computed from the physical values.

    Keyword arguments override entries of :data:`PHYSICAL` (masses kg, lengths m, inertias kg m^2,
    g m/s^2, b N m s/rad, fc N m). ``theta_prior`` is the same physical vector: it stands for the
    paper's Table I (direct measurement), which the paper uses as the reference the identified
    values are compared with. (The paper's RLS starts from theta = 0, not from this prior.)
    """

    name = "direct_drive"
    n_joints = 2
    Options = DirectDriveOptions
    param_names = ("th1", "th2", "th3", "th4", "th5", "b1", "b2", "fc1", "fc2")
    param_units = ("kg m^2", "kg m^2", "kg m^2", "N m", "N m", "N m s/rad", "N m s/rad", "N m", "N m")

    def __init__(self, **physical: float):
        unknown = set(physical) - set(PHYSICAL)
        if unknown:
            raise InputError(f"unknown physical parameter(s) {sorted(unknown)}; choose from {sorted(PHYSICAL)}.")
        v = {**PHYSICAL, **{k: float(x) for k, x in physical.items()}}
        if any(not np.isfinite(x) or x < 0 for x in v.values()):
            raise InputError(f"physical parameters must be finite and >= 0, got {v}.")
        self.physical = v
        self.theta_true = np.array([
            v["m1"] * v["lc1"] ** 2 + v["m2"] * v["l1"] ** 2 + v["m2"] * v["lc2"] ** 2 + v["I1"] + v["I2"],
            v["l1"] * v["m2"] * v["lc2"],
            v["m2"] * v["lc2"] ** 2 + v["I2"],
            v["g"] * (v["lc1"] * v["m1"] + v["m2"] * v["l1"]),
            v["g"] * v["m2"] * v["lc2"],
            v["b1"], v["b2"], v["fc1"], v["fc2"],
        ])
        self.theta_prior = self.theta_true.copy()

    # -- regressors (N, n, p) ------------------------------------------------------------
    @per_state
    def regressor(self, q, qd, qdd) -> np.ndarray:
        (q, qd, qdd), _ = self._states(q, qd, qdd)
        s1, c2, s2, s12 = np.sin(q[:, 0]), np.cos(q[:, 1]), np.sin(q[:, 1]), np.sin(q[:, 0] + q[:, 1])
        v1, v2, a1, a2 = qd[:, 0], qd[:, 1], qdd[:, 0], qdd[:, 1]
        Y = np.zeros((q.shape[0], 2, 9))
        Y[:, 0, 0] = a1
        Y[:, 0, 1] = c2 * (2 * a1 + a2) - s2 * (2 * v1 * v2 + v2 ** 2)
        Y[:, 0, 2] = a2
        Y[:, 0, 3] = s1
        Y[:, 0, 4] = s12
        Y[:, 0, 5] = v1
        Y[:, 0, 7] = np.sign(v1)
        Y[:, 1, 1] = c2 * a1 + s2 * v1 ** 2
        Y[:, 1, 2] = a1 + a2
        Y[:, 1, 4] = s12
        Y[:, 1, 6] = v2
        Y[:, 1, 8] = np.sign(v2)
        return Y

    @per_state
    def momentum_regressor(self, q, qd) -> np.ndarray:
        (q, qd), _ = self._states(q, qd)
        c2, v1, v2 = np.cos(q[:, 1]), qd[:, 0], qd[:, 1]
        Ya = np.zeros((q.shape[0], 2, 9))
        Ya[:, 0, 0] = v1
        Ya[:, 0, 1] = c2 * (2 * v1 + v2)
        Ya[:, 0, 2] = v2
        Ya[:, 1, 1] = c2 * v1
        Ya[:, 1, 2] = v1 + v2
        return Ya

    @per_state
    def remainder_regressor(self, q, qd) -> np.ndarray:
        """Yb = -dK/dq + dU/dq + f: row 2 carries th2 sin q2 qd1 (qd1 + qd2) (paper's filtered regressor)."""
        (q, qd), _ = self._states(q, qd)
        s1, s2, s12 = np.sin(q[:, 0]), np.sin(q[:, 1]), np.sin(q[:, 0] + q[:, 1])
        v1, v2 = qd[:, 0], qd[:, 1]
        Yb = np.zeros((q.shape[0], 2, 9))
        Yb[:, 0, 3] = s1
        Yb[:, 0, 4] = s12
        Yb[:, 0, 5] = v1
        Yb[:, 0, 7] = np.sign(v1)
        Yb[:, 1, 1] = s2 * v1 * (v1 + v2)
        Yb[:, 1, 4] = s12
        Yb[:, 1, 6] = v2
        Yb[:, 1, 8] = np.sign(v2)
        return Yb

    @per_state
    def energy_regressor(self, q, qd) -> np.ndarray:
        (q, qd), _ = self._states(q, qd)
        c1, c2, c12 = np.cos(q[:, 0]), np.cos(q[:, 1]), np.cos(q[:, 0] + q[:, 1])
        v1, v2 = qd[:, 0], qd[:, 1]
        phi = np.zeros((q.shape[0], 9))
        phi[:, 0] = 0.5 * v1 ** 2
        phi[:, 1] = c2 * (v1 ** 2 + v1 * v2)
        phi[:, 2] = v1 * v2 + 0.5 * v2 ** 2
        phi[:, 3] = 1.0 - c1
        phi[:, 4] = 1.0 - c12
        return phi

    @per_state
    def friction_power_regressor(self, qd) -> np.ndarray:
        (qd,), _ = self._states(qd, names=("qd",))
        phi = np.zeros((qd.shape[0], 9))
        phi[:, 5:7] = qd ** 2
        phi[:, 7:9] = np.abs(qd)
        return phi

    # -- matrices --------------------------------------------------------------------------
    @per_state
    def mass_matrix(self, q, theta=None) -> np.ndarray:
        (q,), _ = self._states(q, names=("q",))
        th = self._theta(theta)
        c2 = np.cos(q[:, 1])
        M = np.empty((q.shape[0], 2, 2))
        M[:, 0, 0] = th[0] + 2 * th[1] * c2
        M[:, 0, 1] = M[:, 1, 0] = th[2] + th[1] * c2
        M[:, 1, 1] = th[2]
        return M

    @per_state
    def bias_torque(self, q, qd, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        """C(q, qd) qd + g(q) + f(qd), Coulomb as tanh(qd / coulomb_width) (sign if width 0)."""
        (q, qd), _ = self._states(q, qd)
        th = self._theta(theta)
        s1, s2, s12 = np.sin(q[:, 0]), np.sin(q[:, 1]), np.sin(q[:, 0] + q[:, 1])
        v1, v2 = qd[:, 0], qd[:, 1]
        sg = coulomb(qd, coulomb_width)
        b = np.empty((q.shape[0], 2))
        b[:, 0] = (-th[1] * s2 * (2 * v1 * v2 + v2 ** 2) + th[3] * s1 + th[4] * s12
                   + th[5] * v1 + th[7] * sg[:, 0])
        b[:, 1] = th[1] * s2 * v1 ** 2 + th[4] * s12 + th[6] * v2 + th[8] * sg[:, 1]
        return b

    # -- physical consistency -------------------------------------------------------------
    def physical_constraints(self, com_on_links: bool = True) -> PhysicalConstraints:
        """What the 9 parameters of physical links can be (module docstring for their definitions).

        With m1, m2 >= 0, I1, I2 >= 0 (inertias about the centres of mass) and l1 > 0:

        * th3 = m2 lc2^2 + I2 >= 0 and th1 - th3 = m1 lc1^2 + m2 l1^2 + I1 >= 0 (sums of squares
          times masses, and inertias);
        * th3 (th1 - th3) >= th2^2, a rotated second-order cone, written ||(2 th2, 2 th3 - th1)|| <= th1:
          (m2 lc2^2 + I2)(m1 lc1^2 + m2 l1^2 + I1) >= (m2 lc2^2)(m2 l1^2) = (l1 m2 lc2)^2. It is
          exactly "M(q) >= 0 at every q": det M(q) = th3 (th1 - th3) - th2^2 cos^2 q2, smallest at
          q2 = 0 or pi, and M22 = th3. It is also tight for the triple: any (th1, th2, th3) in the
          cone with th2 > 0 is realised, for the arm's l1, by lc2 in [th2 l1 / (th1 - th3), th3 l1 / th2]
          (non-empty iff th2^2 <= th3 (th1 - th3)), m2 = th2 / (l1 lc2) and I1, I2 >= 0. (The cone
          implies the two rows above; they are kept as readable rows. Left out: th5 = g th2 / l1,
          an equality through the known l1, and th3 th4 >= th2 th5, valid but not convex.)
        * with ``com_on_links`` (the centre of mass of each link on its own side of the joint,
          lc1, lc2 >= 0, true of this arm; false for a link counterweighted past its joint):
          th2 = l1 m2 lc2 >= 0, th4 = g (lc1 m1 + m2 l1) >= 0, th5 = g m2 lc2 >= 0;
        * friction dissipates: qd (b qd + fc sign qd) = b qd^2 + fc |qd| >= 0 for every qd iff
          b >= 0 and fc >= 0 (large and small |qd|), for each joint.
        """
        names = self.param_names
        mass_rows = linear_rows([[0, 0, -1] + [0] * 6, [-1, 0, 1] + [0] * 6], [0.0, 0.0],
                                ["th3 >= 0", "th1 - th3 >= 0"],
                                ["th3 = m2 lc2^2 + I2", "th1 - th3 = m1 lc1^2 + m2 l1^2 + I1"], 9)
        com = [1, 3, 4] if com_on_links else []
        why_com = ["th2 = l1 m2 lc2 with lc2 >= 0", "th4 = g (lc1 m1 + m2 l1) with lc1 >= 0",
                   "th5 = g m2 lc2 with lc2 >= 0"]
        rows = nonnegative(names, com + [5, 6, 7, 8], (why_com if com_on_links else [])
                           + ["viscous friction dissipates: b qd^2 >= 0 for every qd"] * 2
                           + ["Coulomb friction dissipates: fc |qd| >= 0 for every qd"] * 2)
        G = np.zeros((2, 9))
        G[0, 1], G[1, 0], G[1, 2] = 2.0, -1.0, 2.0
        f = np.zeros(9)
        f[0] = 1.0
        cone = Cone(G, np.zeros(2), f, 0.0, "th3 (th1 - th3) >= th2^2",
                    "(m2 lc2^2 + I2)(m1 lc1^2 + m2 l1^2 + I1) >= (l1 m2 lc2)^2; equivalent to M(q) >= 0 "
                    "for every q (det M = th3 (th1 - th3) - th2^2 cos^2 q2)")
        lin = LinearRows(np.vstack([mass_rows.A, rows.A]), np.concatenate([mass_rows.b, rows.b]),
                         mass_rows.labels + rows.labels, mass_rows.reasons + rows.reasons)
        return constraints(names, lin, cones=[cone])

    # -- simulation hooks ------------------------------------------------------------------
    #: qdd for one state, compiled (boundid.experiments._hold_integrator.ACCELERATION): the simulator's
    #: inner loop runs it without leaving numba
    compiled_acceleration = staticmethod(_acceleration)

    def fast_acceleration(self, q, qd, u, theta, coulomb_width: float) -> list[float]:
        """qdd for ONE state, as a list of floats, without input checks (the solve_ivp path's hook).

        q, qd, u, theta : sequences of floats (2, 2, 2, 9); same result as :meth:`forward_dynamics`
        (M^-1 by the 2 x 2 closed form, :func:`_acceleration`).
        """
        out = np.empty(2)
        _acceleration(np.array([q[0], q[1], qd[0], qd[1]], dtype=float), np.asarray(u, dtype=float),
                      np.asarray(theta, dtype=float), float(coulomb_width), out)
        return out.tolist()
