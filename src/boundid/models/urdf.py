"""Serial arms from a URDF, through pinocchio [Pinocchio]: regressors, dynamics and limits.

A :class:`UrdfRobot` is built from a URDF file or from the name of a robot shipped by the
``example-robot-data`` package (``"ur5"``, ``"panda"``, ...: :data:`EXAMPLE_ROBOTS`). Links joined
by fixed joints are merged into one rigid body by pinocchio's parser; joints left out of ``joints=``
(e.g. the Panda's fingers) are locked at a reference configuration and merged the same way. Every
remaining joint must be a 1-dof revolute (also continuous) or prismatic joint, and the joints must
form one serial chain from the fixed base.

Parameters theta (p,), in this order:

    10 per body j = 1..n, pinocchio's order, about the origin of joint j's frame (the child
        link's frame), expressed in it:  m, m cx, m cy, m cz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz
        (I = I_C + m S(c)^T S(c), with I_C about the centre of mass c)
    Ia_j    armature (motor inertia seen at the joint), only with ``with_armature=True``
    fv_j    viscous friction
    fc_j    Coulomb friction (sign(qd) in the identification model)
    off_j   torque offset, only with ``with_offset=True``
    Iam_m, fvm_m, fsm_m    per coupled motor m (``coupled_motors``, :class:`CoupledMotor`): its rotor
        inertia, viscous and Coulomb friction, joint-side scaled, acting on its velocity seen at its
        own joint w_m = r_m . qd, r_m = R[m, :] / R[m, m] the motor's row of the transmission
        q_m = R q (the TX40's motor 6: r = e5 + e6, w = qd5 + qd6); by virtual work (tau = R^T tau_m)

    tau = M(q) qdd + C(q, qd) qd + g(q) + Ia qdd + fv qd + fc sign(qd) + off
          + sum_m r_m (Iam_m r_m . qdd + fvm_m w_m + fsm_m sign(w_m))

so the coupled motors add sum_m Iam_m r_m r_m^T to the mass matrix and their friction to the bias.

Regressors (all batched over N samples, shapes as in :mod:`boundid.models.base`):

- inverse dynamics ``pin.computeJointTorqueRegressor`` [Pinocchio], plus the joint-wise columns;
- momentum (the filtered dynamic model): M(q) qd is the torque that accelerates the robot at rest
  by qd without gravity, so Ya(q, qd) = Y_{g=0}(q, 0, qd), the torque regressor of a gravity-free
  copy of the model;
- remainder: by Lagrange's equation tau = d/dt(dK/dqd) - dK/dq + dU/dq + f, with M qd = dK/dqd,
  Yb theta = g(q) - dK/dq + f(qd) (+ off); g is the torque regressor at (q, 0, 0). The gradient of
  K comes from the subtree momenta: with S_j the axis of joint j, v_j the spatial velocity of body
  j and h_j = sum_{i >= j} I_i v_i the momentum of the bodies joint j carries (world frame, linear
  in theta: h_i = G_i(q, qd) theta_i),

      dK/dq_j = (v_j x S_j)^T h_j

  (turning joint j by e moves the bodies i >= j rigidly by the twist e S_j; the derivative of
  1/2 sum v_i^T I_i v_i is then -(S_j x v_j)^T h_j). dK/dq = C^T qd for pinocchio's Coriolis matrix,
  checked in tests/test_urdf.py, with finite differences of the kinetic energy;
- energy ``pin.computeKineticEnergyRegressor`` + ``computePotentialEnergyRegressor`` (+ Ia qd^2 / 2
  + Iam_m w_m^2 / 2), potential energy U = -sum_i m_i g . c_i, zero at the world origin;
- friction power qd^T (fv qd + fc sign qd + off) = fv qd^2 + fc |qd| + off qd (the offset's power
  is not dissipated, but it belongs to the same side of the power balance), + fvm_m w_m^2 + fsm_m |w_m|
  (qd^T r_m = w_m).
- a coupled motor's columns: Iam_m r_m (r_m . qdd) in Y, r_m w_m in Ya; fvm_m r_m w_m and fsm_m
  r_m sign(w_m) in Y and Yb (its inertia is constant: no dK/dq).

Mass matrix by CRBA, bias torque by RNEA at zero acceleration, forward dynamics by ABA (with coupled
motors: solve(M + sum_m Iam_m r_m r_m^T, tau - bias), the added inertia not being diagonal), each
with pinocchio's model rebuilt from theta (the body masses must then be > 0).
"""

from __future__ import annotations

import importlib.metadata
import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from boundid._validation import as_float_array, as_vector
from boundid.errors import InputError, SolverError
from boundid.models.base import RobotModel, coulomb, per_state, rk4_hold
from boundid.models.limits import JointLimits
from boundid.models.urdf_export import export_files, link_inertial_parameters
from boundid.models.urdf_options import EXAMPLE_ROBOTS, CoupledMotor, UrdfOptions
from boundid.sets.constraints import PhysicalConstraints, constraints, linear_rows
from boundid.sets.constraints import pseudo_inertia as pseudo_inertia_lmi

#: Names of the 10 inertial parameters of a body, pinocchio's order (suffixed with the joint number).
INERTIAL_NAMES = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
INERTIAL_UNITS = ("kg", "kg m", "kg m", "kg m", "kg m^2", "kg m^2", "kg m^2", "kg m^2", "kg m^2", "kg m^2")

#: Parameter blocks of the coupled motors, one entry per motor (the others are one entry per joint).
MOTOR_KEYS = ("Iam", "fvm", "fsm")

#: Rule for the acceleration limit URDFs do not carry: this many times the velocity limit, per
#: second (the velocity limit is reached from rest in 0.2 s). Override with ``acceleration_limit``.
ACCELERATION_PER_VELOCITY = 5.0  # 1/s


def example_robots_dir() -> Path:
    """The ``robots`` folder of the installed ``example-robot-data`` package."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise InputError("the example-robot-data package is not installed; run `make install` (or pip install "
                         "example-robot-data), or give the path of a URDF file instead of a robot name.") from None
    folder = Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))
    if not folder.is_dir():
        raise InputError(f"example-robot-data is installed but its robots folder {folder} is missing; reinstall it.")
    return folder


def resolve_urdf(source: str | Path) -> tuple[Path, tuple[str, ...] | None, str]:
    """(URDF path, default joint selection, short name) of a path or an :data:`EXAMPLE_ROBOTS` name."""
    text = str(source)
    if text in EXAMPLE_ROBOTS:
        rel, joints = EXAMPLE_ROBOTS[text]
        return example_robots_dir() / rel, joints, text
    path = Path(text).expanduser()
    if path.suffix.lower() == ".urdf" or path.exists() or "/" in text:
        if not path.is_file():
            raise InputError(f"URDF file {path} not found; check the path (robot names are {sorted(EXAMPLE_ROBOTS)}).")
        return path, None, path.stem
    raise InputError(f"unknown robot {text!r}: give the path of a .urdf file or one of the example-robot-data "
                     f"arms {sorted(EXAMPLE_ROBOTS)}.")


def _per_joint(x, what: str, n: int, default, signed: bool = False, finite: bool = True) -> np.ndarray:
    """(n,) values from a scalar or one per joint (``default`` when x is None); >= 0 unless ``signed``,
    finite unless not ``finite`` (a limit may be inf). InputError naming ``what`` and the count."""
    if x is None:
        return np.asarray(default, float).copy()
    v = as_float_array(x, what)
    if v.ndim == 0:
        v = np.full(n, float(v))
    if v.shape != (n,):
        got = f"{v.shape[0]} numbers" if v.ndim == 1 else f"shape {v.shape}"
        raise InputError(f"{what} must be one number or a list of {n} (one per joint), got {got}: {x!r}.")
    bad = np.isnan(v) | (np.isinf(v) if finite else False) | (False if signed else v < 0)
    if np.any(bad):
        j = int(np.flatnonzero(bad)[0])
        rule = ("finite" if finite else "not NaN") + ("" if signed else " and >= 0")
        raise InputError(f"{what} must be {rule}; entry {j + 1} of {n} is {v[j]:g}.")
    return v.copy()


def _coupled_motors(motors, n: int) -> tuple[CoupledMotor, ...]:
    """:class:`CoupledMotor` of each entry (a CoupledMotor, or a mapping: a study file's table), checked
    against the n joints of the model: joint numbers within 1..n, one entry per motor."""
    out = tuple(m if isinstance(m, CoupledMotor) else CoupledMotor.from_table(m, k)
                for k, m in enumerate(motors or (), start=1))
    for m in out:
        if max(m.joints) > n:
            raise InputError(f"coupled motor {m.motor}: joints {list(m.joints)} must be joint numbers in 1..{n} "
                             "(the model's joint order).")
    owners = [m.motor for m in out]
    if len(set(owners)) != len(owners):
        raise InputError(f"coupled_motors names motor(s) {sorted({o for o in owners if owners.count(o) > 1})} twice: "
                         "give one entry per motor.")
    return out


def _joint_kind(jmodel) -> str:
    """'revolute', 'continuous' or 'prismatic' for a 1-dof joint; pinocchio's type name for any other."""
    short = jmodel.shortname()
    if jmodel.nv != 1 or "Mimic" in short:
        return short
    if "Prismatic" in short or short.startswith("JointModelP"):
        return "prismatic"
    if "Unbounded" in short or short.startswith("JointModelRUB"):
        return "continuous"
    return "revolute" if "Revolute" in short or short.startswith("JointModelR") else short


def _load_chain(path: Path, joints: Sequence[str] | None) -> tuple[pin.Model, list[str]]:
    """The pinocchio model of the selected serial chain (other joints locked at their neutral value)."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise InputError(f"{path} is not well-formed XML ({exc}); fix the URDF.") from None
    for link in root.iter("link"):
        link_inertial_parameters(link.find("inertial"), link.get("name"))
    parent_joints: dict[str, list[str]] = {}
    for joint in root.iter("joint"):
        child = joint.find("child")
        if child is not None:
            parent_joints.setdefault(child.get("link"), []).append(joint.get("name"))
    loops = {link: js for link, js in parent_joints.items() if len(js) > 1}
    if loops:
        raise InputError(f"{path.name} describes a closed kinematic chain (link(s) with several parent joints: "
                         f"{loops}); URDF robots must be trees, and boundid takes serial chains only. A parallel "
                         "robot needs a hand-written model like the H4's.")
    try:
        full = pin.buildModelFromUrdf(str(path))
    except (RuntimeError, ValueError) as exc:
        raise InputError(f"pinocchio could not read {path} as a URDF ({exc}); fix the file.") from None
    names = list(full.names)[1:]
    for j, nm in enumerate(names, start=1):
        kind = _joint_kind(full.joints[j])
        if kind not in ("revolute", "continuous", "prismatic") and (joints is None or nm in joints):
            what = "a floating base" if "FreeFlyer" in kind else f"a {kind} joint"
            raise InputError(f"joint {nm!r} of {path.name} is {what}; only fixed-base serial chains of revolute, "
                             "continuous and prismatic joints are supported. Fix the base in the URDF, or select "
                             "the arm's joints with joints=[...].")
    if joints is None:  # every movable joint but the mimic ones (driven by another joint, not actuated)
        mimic = {j.get("name") for j in root.iter("joint") if j.find("mimic") is not None}
        keep = [nm for nm in names if nm not in mimic]
    else:
        keep = [str(j) for j in joints]
        unknown = [j for j in keep if j not in names]
        if unknown or len(set(keep)) != len(keep) or not keep:
            raise InputError(f"joints={keep} must be distinct names among the movable joints of {path.name}: "
                             f"{names}" + (f" (unknown: {unknown})" if unknown else "") + ".")
    lock = [full.getJointId(nm) for nm in names if nm not in keep]
    model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
    chain = list(model.names)[1:]
    parents = list(model.parents)[1:]
    if any(parents[k] != k for k in range(len(chain))):
        branches = [f"{chain[k]} <- {model.names[parents[k]]}" for k in range(len(chain))]
        raise InputError(f"the joints of {path.name} do not form one serial chain ({', '.join(branches)}); select "
                         "one chain with joints=[...].")
    return model, chain


class UrdfRobot(RobotModel):
    """A fixed-base serial arm read from a URDF with pinocchio; theta = URDF inertias + friction.

    source : path of a .urdf file, or a name of :data:`EXAMPLE_ROBOTS` (e.g. "ur5", "panda")
    joints : names of the joints to keep (default: every movable joint but <mimic> ones, or the
        arm joints for the named robots); the others are locked at their neutral position. The
        model orders them along the chain (``joint_names``).
    viscous, coulomb : (n,) or scalar, true friction [N m s/rad, N m] (default: the URDF's
        <dynamics damping=... friction=...>, 0 when absent)
    with_armature, armature : add the armature parameters Ia_j, true values [kg m^2] (default 0)
    with_offset, offset : add the torque offsets off_j, true values [N m] (default 0)
    coupled_motors : motors that turn with several joints, :class:`CoupledMotor` or tables {motor,
        joints, ratios, armature, viscous, coulomb}: add Iam_m, fvm_m, fsm_m per motor (module docstring)
    gravity : (3,) m/s^2 in the base frame (default (0, 0, -9.81))
    velocity_limit, acceleration_limit : (n,) or scalar overrides of the URDF velocity limit and of
        the acceleration rule (:data:`ACCELERATION_PER_VELOCITY` x velocity limit)
    name : short identifier (default: the robot name or the file's stem)

    ``theta_true`` and ``theta_prior`` are both the URDF values plus the friction given (a designer
    who knows the CAD model). ``limits`` holds the :class:`JointLimits` read from the URDF: a
    limit the file does not give is inf (position limits 0, 0 are urdfdom's default for "none").
    """

    #: robot.options: the URDF (an example-robot-data name or a .urdf path)
    Options = UrdfOptions

    @classmethod
    def from_options(cls, options: UrdfOptions) -> UrdfRobot:
        """The robot of a study's robot.options (its standard parameters): a per-joint option is "not
        given" when it is the number 0 (a list is used as given); a given armature or offset adds its
        parameters."""
        def given(x):
            return None if isinstance(x, int | float) and x == 0 else x

        armature, offset = given(options.armature), given(options.offset)
        return cls(options.source, joints=options.joints or None, viscous=given(options.viscous),
                   coulomb=given(options.coulomb), with_armature=armature is not None, armature=armature,
                   with_offset=offset is not None, offset=offset, velocity_limit=given(options.velocity_limit),
                   coupled_motors=options.coupled_motors)

    def __init__(self, source: str | Path, joints: Sequence[str] | None = None, *, viscous=None, coulomb=None,
                 with_armature: bool = False, armature=None, with_offset: bool = False, offset=None,
                 coupled_motors=(), gravity=None, velocity_limit=None, acceleration_limit=None,
                 name: str | None = None):
        path, default_joints, default_name = resolve_urdf(source)
        self.urdf_path = path
        self._model, chain = _load_chain(path, default_joints if joints is None else joints)
        self.joint_names = tuple(chain)
        model, n = self._model, self._model.nv
        self.name = default_name if name is None else str(name)
        self.n_joints = n
        if gravity is not None:
            model.gravity = pin.Motion(np.concatenate([as_vector(gravity, "gravity", 3), np.zeros(3)]))
        self.link_names = tuple(model.frames[f].name for f in self._body_frames())
        kinds = [_joint_kind(model.joints[j]) for j in range(1, n + 1)]
        self.joint_kinds = tuple(kinds)
        prismatic = [k == "prismatic" for k in kinds]

        # configuration map: a continuous joint's angle is stored by pinocchio as (cos, sin)
        self._idx_q = np.array([model.joints[j].idx_q for j in range(1, n + 1)])
        self._unbounded = np.array([k == "continuous" for k in kinds])

        fv = _per_joint(viscous, "viscous", n, model.damping)
        fc = _per_joint(coulomb, "coulomb", n, model.friction)
        self.with_armature, self.with_offset = bool(with_armature), bool(with_offset)
        if armature is not None and not with_armature:
            raise InputError("armature values given without with_armature=True; set the flag to identify them.")
        if offset is not None and not with_offset:
            raise InputError("offset values given without with_offset=True; set the flag to identify them.")
        ia = _per_joint(armature, "armature", n, np.zeros(n))
        off = _per_joint(offset, "offset", n, np.zeros(n), signed=True)
        model.armature = ia.copy()
        self.coupled_motors = _coupled_motors(coupled_motors, n)
        # r_m (k, n): each coupled motor's row of R over its ratio on its own joint
        self._motor_rows = np.zeros((len(self.coupled_motors), n))
        for c, m in enumerate(self.coupled_motors):
            own = m.ratios[m.joints.index(m.motor)]
            for j, ratio in zip(m.joints, m.ratios, strict=True):
                self._motor_rows[c, j - 1] = ratio / own

        # parameter layout: [10 n inertial | Ia | fv | fc | off | Iam | fvm | fsm]
        names, units = [], []
        for j in range(1, n + 1):
            names += [f"{s}{j}" for s in INERTIAL_NAMES]
            units += list(INERTIAL_UNITS)
        each, motors = list(range(1, n + 1)), [m.motor for m in self.coupled_motors]  # joint numbers of a block
        inertia, viscous_, coulomb_ = ("kg", "kg m^2"), ("N s/m", "N m s/rad"), ("N", "N m")
        blocks = [("Ia", self.with_armature, each, inertia), ("fv", True, each, viscous_), ("fc", True, each, coulomb_),
                  ("off", self.with_offset, each, coulomb_), ("Iam", bool(motors), motors, inertia),
                  ("fvm", bool(motors), motors, viscous_), ("fsm", bool(motors), motors, coulomb_)]
        self._slices, start = {}, 10 * n
        for key, on, numbers, (u_pr, u_rev) in blocks:
            if on:
                self._slices[key] = slice(start, start + len(numbers))
                start += len(numbers)
                names += [f"{key}{j}" for j in numbers]
                units += [u_pr if prismatic[j - 1] else u_rev for j in numbers]
        self.param_names, self.param_units = tuple(names), tuple(units)
        inertial = np.concatenate([model.inertias[j].toDynamicParameters() for j in range(1, n + 1)])
        values = {"Ia": ia, "fv": fv, "fc": fc, "off": off,
                  "Iam": [m.armature for m in self.coupled_motors], "fvm": [m.viscous for m in self.coupled_motors],
                  "fsm": [m.coulomb for m in self.coupled_motors]}
        self.theta_true = np.concatenate([inertial] + [np.asarray(values[k], float) for k in self._slices])
        self.theta_prior = self.theta_true.copy()
        self.limits = self._read_limits(velocity_limit, acceleration_limit)

        self._data = model.createData()
        self._still = pin.Model(model)  # the same chain without gravity, for the momentum regressor
        self._still.gravity = pin.Motion.Zero()
        self._still_data = self._still.createData()
        self._dyn_key: np.ndarray | None = None
        self._dyn: tuple[pin.Model, object, np.ndarray | None] | None = None
        self._fast_theta: list[float] | None = None

    # -- physical consistency -------------------------------------------------------------
    def physical_constraints(self, pseudo_inertia: bool = True, triangle: bool = False,
                             cad: float | None = None) -> PhysicalConstraints:
        """What theta can be for rigid links, dissipative friction and motor inertias.

        pseudo_inertia : per body j the 4 x 4 LMI J_j = [[Sigma_j, h_j], [h_j^T, m_j]] >= 0 with
            Sigma_j = 1/2 tr(I_j) 1 - I_j, linear in the body's 10 parameters (pinocchio's order;
            :func:`boundid.sets.constraints.pseudo_inertia`). J_j is the integral of [r; 1][r; 1]^T dm
            over the body, so it is >= 0 for every body, and a body with these parameters exists iff
            J_j >= 0 [WensingKimSlotine2018]. It implies m_j >= 0, I_j >= 0 and the triangle
            inequalities of the principal moments [SousaCortesao2014].
        triangle : also the linear necessary conditions m_j >= 0 and Iyy + Izz >= Ixx, Ixx + Izz >= Iyy,
            Ixx + Iyy >= Izz (the diagonal of Sigma_j >= 0), for an LP relaxation without the LMIs.
        cad : None, or a fraction (e.g. 0.2): each inertial parameter within +- cad of its URDF
            value, |x - x_urdf| <= cad s with s = |x_urdf|, or, for a value 0 in the URDF (a product
            of inertia of a symmetric body), s = the largest |value| of its group in the same body
            (mass, first moments, inertias); a group all 0 in the URDF gets no bound.
        Always: friction dissipates, fv_j qd^2 + fc_j |qd| >= 0 for every qd iff fv_j, fc_j >= 0;
        the armature Ia_j (motor inertia reflected through the gear, >= 0) when identified; a coupled
        motor's Iam_m, fvm_m, fsm_m >= 0 (its rotor inertia, and friction dissipating for every
        motor velocity w_m). Offsets are unconstrained.

        ``scale`` of the result: per body a mass m (the URDF's) and a length l (the RMS distance of
        its mass from the joint frame, sqrt(tr Sigma / m)), giving m, m l, m l^2 for the mass, first
        moments and inertias; |value| or 1 for friction, armature and offsets.
        """
        n, names, ref = self.n_joints, self.param_names, self.theta_true
        lmis, rows_A, rows_b, labels, reasons = [], [], [], [], []
        scale = np.ones(self.p)
        link_reason = ("the integral of [r; 1][r; 1]^T dm over the body: >= 0 for every body, and a body with "
                       "these parameters exists iff it is >= 0 [WensingKimSlotine2018]")
        for j in range(n):
            s0 = 10 * j
            pi = ref[s0:s0 + 10]
            m = pi[0] if pi[0] > 0 else 1.0
            Ij = np.array([[pi[4], pi[5], pi[7]], [pi[5], pi[6], pi[8]], [pi[7], pi[8], pi[9]]])
            tr_sigma = 0.5 * np.trace(Ij)          # tr Sigma = tr(I) / 2
            length = np.sqrt(tr_sigma / m) if pi[0] > 0 and tr_sigma > 0 else 1.0
            scale[s0:s0 + 10] = np.r_[m, [m * length] * 3, [m * length ** 2] * 6]
            body = f"body {j + 1} ({self.link_names[j]})"
            if pseudo_inertia:
                lmis.append(pseudo_inertia_lmi(self.p, s0, f"J{j + 1} >= 0", f"pseudo-inertia of {body}: "
                                               + link_reason))
            if triangle:
                e = np.eye(self.p)
                ixx, iyy, izz = e[s0 + 4], e[s0 + 6], e[s0 + 9]
                b = j + 1
                for row, lab in ((-e[s0], f"m{b} >= 0"), (ixx - iyy - izz, f"Iyy{b} + Izz{b} >= Ixx{b}"),
                                 (iyy - ixx - izz, f"Ixx{b} + Izz{b} >= Iyy{b}"),
                                 (izz - ixx - iyy, f"Ixx{b} + Iyy{b} >= Izz{b}")):
                    rows_A.append(row)
                    rows_b.append(0.0)
                    labels.append(lab)
                    reasons.append(f"{body}: a mass, or a diagonal entry of Sigma (the integral of r r^T dm) >= 0")
            if cad is not None:
                if not (np.isfinite(cad) and cad > 0):
                    raise InputError(f"cad must be a fraction > 0 (e.g. 0.2 for +-20 %), got {cad}.")
                for group in (range(0, 1), range(1, 4), range(4, 10)):
                    big = max(abs(pi[k]) for k in group)
                    for k in group:
                        s = abs(pi[k]) if pi[k] != 0 else big
                        if s == 0:
                            continue
                        e = np.zeros(self.p)
                        e[s0 + k] = 1.0
                        rows_A += [e, -e]
                        rows_b += [pi[k] + cad * s, -(pi[k] - cad * s)]
                        nm = names[s0 + k]
                        labels += [f"{nm} <= {pi[k] + cad * s:.4g}", f"{nm} >= {pi[k] - cad * s:.4g}"]
                        reasons += [f"CAD bound: the URDF value {pi[k]:.4g} +- {100 * cad:g} % of {s:.4g}"] * 2
        for key, why in (("Ia", "a motor inertia reflected through its gear: >= 0"),
                         ("fv", "viscous friction dissipates: fv qd^2 >= 0 for every qd"),
                         ("fc", "Coulomb friction dissipates: fc |qd| >= 0 for every qd"),
                         ("Iam", "a coupled motor's rotor inertia reflected through its gear: >= 0"),
                         ("fvm", "a coupled motor's viscous friction dissipates: fvm w^2 >= 0 for every w"),
                         ("fsm", "a coupled motor's Coulomb friction dissipates: fsm |w| >= 0 for every w")):
            if key not in self._slices:
                continue
            for k in range(self._slices[key].start, self._slices[key].stop):
                e = np.zeros(self.p)
                e[k] = -1.0
                rows_A.append(e)
                rows_b.append(0.0)
                labels.append(f"{names[k]} >= 0")
                reasons.append(why)
        for key in ("Ia", "fv", "fc", "off", *MOTOR_KEYS):
            if key in self._slices:
                sl = self._slices[key]
                scale[sl] = np.where(ref[sl] != 0, np.abs(ref[sl]), 1.0)
        rows = linear_rows(np.array(rows_A).reshape(-1, self.p), rows_b, labels, reasons, self.p)
        return constraints(names, rows, lmis=lmis, scale=scale)

    # -- construction helpers ------------------------------------------------------------
    def _body_frames(self) -> list[int]:
        """Index of the frame of the link carried by each joint (its child link)."""
        model = self._model
        out = []
        for j in range(1, model.njoints):
            frames = [f for f in range(model.nframes)
                      if model.frames[f].parentJoint == j and model.frames[f].type == pin.FrameType.BODY]
            out.append(frames[0])
        return out

    def _read_limits(self, velocity_limit, acceleration_limit) -> JointLimits:
        model, n = self._model, self.n_joints
        iv = np.arange(n)
        lo = np.where(self._unbounded, -np.inf, model.lowerPositionLimit[self._idx_q])
        hi = np.where(self._unbounded, np.inf, model.upperPositionLimit[self._idx_q])
        unset = (np.abs(lo) > 1e10) | (np.abs(hi) > 1e10) | ((lo == 0) & (hi == 0))  # urdfdom's 0, 0: not given
        lo, hi = np.where(unset, -np.inf, lo), np.where(unset, np.inf, hi)
        vel = model.velocityLimit[iv].astype(float)
        vel = _per_joint(velocity_limit, "velocity_limit", n, np.where(vel > 0, vel, np.inf), finite=False)
        acc = _per_joint(acceleration_limit, "acceleration_limit", n, ACCELERATION_PER_VELOCITY * vel,
                         finite=False)
        eff = model.effortLimit[iv].astype(float)
        return JointLimits(lo, hi, vel, acc, np.where(eff > 0, eff, np.inf))

    def _config(self, q: np.ndarray) -> np.ndarray:
        """pinocchio configurations (N, nq) of joint positions q (N, n)."""
        Q = np.empty((q.shape[0], self._model.nq))
        bounded = ~self._unbounded
        Q[:, self._idx_q[bounded]] = q[:, bounded]
        Q[:, self._idx_q[self._unbounded]] = np.cos(q[:, self._unbounded])
        Q[:, self._idx_q[self._unbounded] + 1] = np.sin(q[:, self._unbounded])
        return Q

    def _motor_velocity(self, qd: np.ndarray) -> np.ndarray:
        """w (N, k) = qd r_m^T: each coupled motor's velocity seen at its own joint, of qd (N, n) (or of qdd)."""
        return qd @ self._motor_rows.T

    def _joint_columns(self, Y: np.ndarray, cols: dict[str, np.ndarray]) -> np.ndarray:
        """Write the columns of block ``key`` into Y (N, n, p): a per-joint block's ``cols[key]`` (N, n) on its
        diagonal; a coupled-motor block's (N, k), one scalar x_m per motor, as the column r_m x_m."""
        j = np.arange(self.n_joints)
        for key, val in cols.items():
            if key not in self._slices:
                continue
            if key in MOTOR_KEYS:
                Y[:, :, self._slices[key]] = val[:, None, :] * self._motor_rows.T
            else:
                Y[:, j, self._slices[key].start + j] = val
        return Y

    def _empty(self, N: int) -> np.ndarray:
        return np.zeros((N, self.n_joints, self.p))

    # -- regressors ----------------------------------------------------------------------
    @per_state
    def regressor(self, q, qd, qdd) -> np.ndarray:
        """Y (N, n, p): tau = Y theta, inertial part by ``pin.computeJointTorqueRegressor``."""
        (q, qd, qdd), _ = self._states(q, qd, qdd)
        Q, n = self._config(q), self.n_joints
        Y = self._empty(q.shape[0])
        for k in range(q.shape[0]):
            Y[k, :, :10 * n] = pin.computeJointTorqueRegressor(self._model, self._data, Q[k], qd[k], qdd[k])
        w = self._motor_velocity(qd)
        return self._joint_columns(Y, {"Ia": qdd, "fv": qd, "fc": np.sign(qd), "off": np.ones_like(qd),
                                       "Iam": self._motor_velocity(qdd), "fvm": w, "fsm": np.sign(w)})

    def _kinetic_gradient(self, q, qd) -> np.ndarray:
        """dK/dq regressor, inertial block (N, n, 10 n): (v_j x S_j)^T h_j (module docstring)."""
        Q, n = self._config(q), self.n_joints
        N = q.shape[0]
        model, data = self._model, self._data
        S = np.empty((N, n, 6))          # joint axes, world frame (pinocchio's spatial convention)
        V = np.empty((N, n, 6))          # body velocities, world frame
        G = np.empty((N, n, 6, 10))      # h_i = G_i theta_i, world frame
        zero = pin.Motion.Zero()
        for k in range(N):
            pin.forwardKinematics(model, data, Q[k], qd[k])
            S[k] = pin.computeJointJacobians(model, data).T
            for i in range(1, n + 1):
                oMi, vi = data.oMi[i], data.v[i]
                V[k, i - 1] = oMi.act(vi).vector
                G[k, i - 1] = oMi.toDualActionMatrix() @ pin.bodyRegressor(zero, vi)
        # motion cross product (v, w) x (s_lin, s_ang) = (w x s_lin + v x s_ang, w x s_ang)
        v_lin, w_ang = V[..., :3], V[..., 3:]
        vxS = np.concatenate([np.cross(w_ang, S[..., :3]) + np.cross(v_lin, S[..., 3:]),
                              np.cross(w_ang, S[..., 3:])], axis=-1)
        carries = np.triu(np.ones((n, n)))[None, :, :, None]    # body i is carried by joint j iff i >= j
        return (np.einsum("Nja,Niak->Njik", vxS, G) * carries).reshape(N, n, 10 * n)

    @per_state
    def momentum_regressor(self, q, qd) -> np.ndarray:
        """Ya (N, n, p): M(q) qd = Ya theta, the gravity-free torque regressor at (q, 0, qd) (plus Ia qd and
        r_m w_m for Iam_m)."""
        (q, qd), _ = self._states(q, qd)
        Q, n = self._config(q), self.n_joints
        Y = self._empty(q.shape[0])
        zero = np.zeros(n)
        for k in range(q.shape[0]):
            Y[k, :, :10 * n] = pin.computeJointTorqueRegressor(self._still, self._still_data, Q[k], zero, qd[k])
        return self._joint_columns(Y, {"Ia": qd, "Iam": self._motor_velocity(qd)})

    @per_state
    def remainder_regressor(self, q, qd) -> np.ndarray:
        """Yb (N, n, p) = g(q) - dK/dq + friction (+ offset, + the coupled motors' friction), so that
        Y theta = d/dt(Ya theta) + Yb theta."""
        (q, qd), _ = self._states(q, qd)
        Q, n = self._config(q), self.n_joints
        Y = self._empty(q.shape[0])
        Y[:, :, :10 * n] = -self._kinetic_gradient(q, qd)
        zero = np.zeros(n)
        for k in range(q.shape[0]):
            Y[k, :, :10 * n] += pin.computeJointTorqueRegressor(self._model, self._data, Q[k], zero, zero)
        w = self._motor_velocity(qd)
        return self._joint_columns(Y, {"fv": qd, "fc": np.sign(qd), "off": np.ones_like(qd), "fvm": w,
                                       "fsm": np.sign(w)})

    @per_state
    def energy_regressor(self, q, qd) -> np.ndarray:
        """phi_H (N, p): H = K + U = phi_H theta (pinocchio's kinetic and potential energy regressors, + Ia qd^2 / 2
        + Iam_m w_m^2 / 2)."""
        (q, qd), _ = self._states(q, qd)
        Q, n = self._config(q), self.n_joints
        phi = np.zeros((q.shape[0], self.p))
        for k in range(q.shape[0]):
            phi[k, :10 * n] = (pin.computeKineticEnergyRegressor(self._model, self._data, Q[k], qd[k])
                               + pin.computePotentialEnergyRegressor(self._model, self._data, Q[k]))
        for key, val in (("Ia", qd), ("Iam", self._motor_velocity(qd))):
            if key in self._slices:
                phi[:, self._slices[key]] = 0.5 * val ** 2
        return phi

    @per_state
    def friction_power_regressor(self, qd) -> np.ndarray:
        """phi_f (N, p): qd^T (fv qd + fc sign qd + off) + sum_m (fvm_m w_m^2 + fsm_m |w_m|) = phi_f theta."""
        (qd,), _ = self._states(qd, names=("qd",))
        phi = np.zeros((qd.shape[0], self.p))
        w = self._motor_velocity(qd)
        for key, val in (("fv", qd ** 2), ("fc", np.abs(qd)), ("off", qd), ("fvm", w ** 2), ("fsm", np.abs(w))):
            if key in self._slices:
                phi[:, self._slices[key]] = val
        return phi

    # -- dynamics with pinocchio's algorithms -------------------------------------------------
    def _dynamics(self, theta) -> tuple[pin.Model, object, np.ndarray | None]:
        """pinocchio model and data with the inertias and armature of theta, and the coupled motors' inertia
        A = sum_m Iam_m r_m r_m^T (n, n) [kg m^2] (None without coupled motors); cached for the last theta."""
        th = self._theta(theta)
        if self._dyn_key is not None and np.array_equal(th, self._dyn_key):
            return self._dyn
        n = self.n_joints
        model = pin.Model(self._model)
        for j in range(1, n + 1):
            pi = th[10 * (j - 1):10 * j]
            if not pi[0] > 0:
                raise InputError(f"body {j} ({self.link_names[j - 1]}) has mass {pi[0]:.4g} kg in theta; pinocchio's "
                                 "CRBA/RNEA/ABA need positive masses. Use the regressor (Y theta) for such a theta.")
            model.inertias[j] = pin.Inertia.FromDynamicParameters(pi)
        model.armature = th[self._slices["Ia"]].copy() if "Ia" in self._slices else np.zeros(n)
        rows = self._motor_rows
        A = rows.T @ (th[self._slices["Iam"], None] * rows) if "Iam" in self._slices else None
        self._dyn_key, self._dyn = th.copy(), (model, model.createData(), A)
        return self._dyn

    def _joint_torque(self, qd: np.ndarray, th: np.ndarray, coulomb_width: float) -> np.ndarray:
        """Friction and offset torques (N, n) for parameters th, the coupled motors' friction
        sum_m r_m (fvm_m w_m + fsm_m sign(w_m)) included (tanh(w / width) for sign with a width)."""
        tau = th[self._slices["fv"]] * qd + th[self._slices["fc"]] * coulomb(qd, coulomb_width)
        if "off" in self._slices:
            tau = tau + th[self._slices["off"]]
        if "fvm" in self._slices:
            w = self._motor_velocity(qd)
            motor = th[self._slices["fvm"]] * w + th[self._slices["fsm"]] * coulomb(w, coulomb_width)  # (N, k)
            tau = tau + motor @ self._motor_rows
        return tau

    @staticmethod
    def _accelerate(model, data, A, Q, v, u) -> np.ndarray:
        """qdd (n,) for torque u (n,) net of friction at configuration Q, velocity v: ABA, or with coupled
        motors (A, their inertia) solve(M(q) + A, u - C(q, qd) qd - g(q)), M by CRBA."""
        if A is None:
            return pin.aba(model, data, Q, v, u).copy()
        U = np.triu(pin.crba(model, data, Q))
        return np.linalg.solve(U + np.triu(U, 1).T + A, u - pin.nonLinearEffects(model, data, Q, v))

    @per_state
    def mass_matrix(self, q, theta=None) -> np.ndarray:
        """M(q) (N, n, n) by CRBA (armature on the diagonal), + sum_m Iam_m r_m r_m^T with coupled motors."""
        (q,), _ = self._states(q, names=("q",))
        model, data, A = self._dynamics(theta)
        Q = self._config(q)
        M = np.empty((q.shape[0], self.n_joints, self.n_joints))
        for k in range(q.shape[0]):
            U = np.triu(pin.crba(model, data, Q[k]))
            M[k] = U + np.triu(U, 1).T
        return M if A is None else M + A

    @per_state
    def bias_torque(self, q, qd, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        """C(q, qd) qd + g(q) (RNEA at zero acceleration) + friction (+ offset, + the coupled motors'
        friction), (N, n)."""
        (q, qd), _ = self._states(q, qd)
        th = self._theta(theta)
        model, data, _ = self._dynamics(th)
        Q = self._config(q)
        b = np.array([pin.nonLinearEffects(model, data, Q[k], qd[k]).copy() for k in range(q.shape[0])])
        return b.reshape(q.shape) + self._joint_torque(qd, th, coulomb_width)

    @per_state
    def forward_dynamics(self, q, qd, tau, theta=None, coulomb_width: float = 0.0) -> np.ndarray:
        """qdd (N, n) by ABA on tau minus friction (and offset); with coupled motors, solve(M + A, tau - bias)."""
        (q, qd, tau), _ = self._states(q, qd, tau, names=("q", "qd", "tau"))
        th = self._theta(theta)
        model, data, A = self._dynamics(th)
        Q, u = self._config(q), tau - self._joint_torque(qd, th, coulomb_width)
        return np.array([self._accelerate(model, data, A, Q[k], qd[k], u[k]) for k in range(q.shape[0])]).reshape(
            q.shape)

    def fast_acceleration(self, q, qd, u, theta, coulomb_width: float) -> list[float]:
        """qdd for ONE state (plain sequences), no input checks: ABA (with coupled motors, the solve of
        :meth:`forward_dynamics`), for the simulator's inner loop."""
        theta = list(theta)
        if theta != self._fast_theta:  # the simulator passes the same values at every call: cache their parts
            th = np.asarray(theta, float)
            model, data, A = self._dynamics(th)
            off = th[self._slices["off"]] if "off" in self._slices else np.zeros(self.n_joints)
            self._fast_theta = theta
            self._fast = (model, data, A, th, th[self._slices["fv"]].tolist(), th[self._slices["fc"]].tolist(),
                          off.tolist())
        model, data, A, th, fv, fc, off = self._fast
        Q = self._config(np.array([q], float))[0] if self._unbounded.any() else np.array(q, float)
        vel = np.array(qd, float)
        if A is not None:
            u_net = np.asarray(u, float) - self._joint_torque(vel[None], th, coulomb_width)[0]
            return self._accelerate(model, data, A, Q, vel, u_net).tolist()
        w = coulomb_width
        rhs = [ui - b * v - c * (math.tanh(v / w) if w > 0 else (v > 0) - (v < 0)) - o
               for ui, v, b, c, o in zip(u, qd, fv, fc, off, strict=True)]
        return pin.aba(model, data, Q, vel, np.array(rhs)).tolist()

    # -- abilities -------------------------------------------------------------------------
    def export_identified(self, theta, folder, base=None, estimate: str = "identified parameters",
                          cov=None) -> list[Path]:
        """A copy of the URDF that pinocchio and MuJoCo load, an MJCF fragment with the joints' armature
        and friction, and YAML/CSV tables, of the estimate theta (p,) or, when it has no physically
        consistent standard vector, of its projection (needs ``cov``; theta then goes to the tables
        only); see :func:`boundid.models.urdf_export.export_files`."""
        return export_files(self, theta, folder, base, estimate, cov)

    @property
    def experiments(self) -> tuple[str, ...]:
        """The tracking experiment (:mod:`boundid.experiments.tracking`): an arm with joint limits."""
        return ("tracking",)

    def rest_position(self) -> np.ndarray:
        """The middle of each joint range (0 for a joint without position limits)."""
        return self.limits.middle()

    def zoh_stepper(self):
        """RK4 under a held torque with pinocchio's ABA on the true parameters (with coupled motors, the
        solve of :meth:`forward_dynamics`), ``substeps`` steps per hold interval; friction as in
        :meth:`forward_dynamics` (tanh of width ``coulomb_width``)."""
        model, data, A = self._dynamics(self.theta_true)
        th = self.theta_true
        fv, fc = th[self._slices["fv"]], th[self._slices["fc"]]
        off = th[self._slices["off"]] if "off" in self._slices else np.zeros(self.n_joints)
        unbounded = self._unbounded.any()

        def acceleration(q, v, tau, width):
            friction = (fv * v + fc * coulomb(v, width) + off if A is None
                        else self._joint_torque(v[None], th, width)[0])
            Q = self._config(q[None])[0] if unbounded else q
            return self._accelerate(model, data, A, Q, v, tau - friction)

        def step(q, qd, tau, dt, substeps, coulomb_width, hint):
            q, qd = rk4_hold(lambda q_, v_: acceleration(q_, v_, tau, coulomb_width), q, qd, dt, substeps)
            if not math.isfinite(q.sum() + qd.sum()):
                raise SolverError(f"the simulated {self.name} diverged (non-finite state) within {dt:g} s; lower "
                                  "the controller gains, raise substeps or widen coulomb_width.")
            return q, qd, None

        return step

