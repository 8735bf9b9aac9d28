"""What a study may say about a URDF robot, without loading pinocchio (~0.5 s): the names of the
example-robot-data arms, the options dataclass of :class:`boundid.models.urdf.UrdfRobot` and its
coupled motors (:class:`CoupledMotor`)."""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, fields

from boundid._validation import NumbersOption, TablesOption
from boundid.errors import InputError

#: Fixed-base arms of ``example-robot-data``: name -> (URDF path under its ``robots`` folder,
#: default joint selection, None for every movable joint).
EXAMPLE_ROBOTS: dict[str, tuple[str, tuple[str, ...] | None]] = {
    "ur3": ("ur_description/urdf/ur3_robot.urdf", None),
    "ur5": ("ur_description/urdf/ur5_robot.urdf", None),
    "ur10": ("ur_description/urdf/ur10_robot.urdf", None),
    "panda": ("panda_description/urdf/panda.urdf", tuple(f"panda_joint{i}" for i in range(1, 8))),
    "kinova": ("kinova_description/robots/kinova.urdf", None),
    "xarm7": ("xarm_description/urdf/xarm7.urdf", None),
    "z1": ("z1_description/urdf/z1.urdf", tuple(f"joint{i}" for i in range(1, 7))),
    "so100": ("so_arm_description/urdf/so100.urdf",
              ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll")),
    "so101": ("so_arm_description/urdf/so101.urdf",
              ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll")),
    "double_pendulum": ("double_pendulum_description/urdf/double_pendulum.urdf", None),
}


def _is_number(x) -> bool:
    return isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x)


def _is_index(x) -> bool:
    """A 1-based joint number (an integer >= 1, numpy's included; not a bool)."""
    return isinstance(x, numbers.Integral) and not isinstance(x, bool) and x >= 1


@dataclass(frozen=True)
class CoupledMotor:
    """A motor that turns with several joints (a coupled wrist), with its own rotor inertia and friction.

    motor : its own joint (1-based, the model's joint order): the joint it drives through its gear
    joints, ratios : the joints it turns with (its own among them) and its turns per joint turn: its
        row of the transmission matrix, q_m = sum_i ratios_i q_{joints_i} (q_m = R q, virtual work
        tau = R^T tau_m). The Staubli TX40's motor 6: motor = 6, joints = [5, 6], ratios = [32, 32].
    armature, viscous, coulomb : true Iam [kg m^2], fvm [N m s/rad], fsm [N m] (prismatic own joint:
        kg, N s/m, N), joint-side scaled, >= 0 (default 0)

    Joint-side scaling (the convention of the TX40's Iam6, fvm6, fsm6 in [FIGAROH]'s configuration): with
    N = R[motor, motor] the ratio on its own joint and r = R[motor, :] / N (the TX40's r = e5 + e6),
    the motor's velocity seen at its own joint is w = r . qd = qd_m / N, and its torque
    tau_m = J qdd_m + b qd_m + c sign(qd_m) gives the joint torques

        tau += R[motor, :]^T tau_m = r (Iam r . qdd + fvm w + fsm sign(w)),
        Iam = N^2 J,  fvm = N^2 b,  fsm = |N| c,

    so that for a single joint (r = e_motor) they would be that joint's armature and friction.
    FIGAROH's TX40 model keeps only the cross terms of r Iam r^T (tau5 += Iam6 qdd6, tau6 += Iam6
    qdd5; the same for fvm6; fsm6 sign(qd5 + qd6) on both), the diagonal ones going to its Ia and fv:
    the same Iam6, fvm6, fsm6, and its Ia5, Ia6, fv5, fv6 are these + Iam6 or fvm6.
    """

    motor: int
    joints: tuple[int, ...]
    ratios: tuple[float, ...]
    armature: float = 0.0
    viscous: float = 0.0
    coulomb: float = 0.0

    def __post_init__(self):
        if not _is_index(self.motor):
            raise InputError(f"coupled motor: motor must be a joint number >= 1 (1-based), got {self.motor!r}.")
        where = f"coupled motor {self.motor}"
        joints, ratios = tuple(self.joints), tuple(self.ratios)
        if not all(_is_index(j) for j in joints) or len(set(joints)) != len(joints):
            raise InputError(f"{where}: joints must be distinct joint numbers >= 1 (1-based), got {list(joints)}.")
        if len(ratios) != len(joints) or not all(_is_number(x) and x != 0 for x in ratios):
            raise InputError(f"{where}: ratios must be {len(joints)} finite nonzero numbers, one per joint of joints "
                             f"{list(joints)} (motor turns per joint turn), got {list(ratios)}.")
        if self.motor not in joints:
            raise InputError(f"{where}: joints {list(joints)} must include the motor's own joint {self.motor} (its "
                             "gear ratio there scales the parameters to the joint side).")
        if len(joints) < 2:
            raise InputError(f"{where} turns with its own joint only: that is the per-joint armature, viscous and "
                             "coulomb; a coupled motor turns with two joints or more.")
        for name in ("armature", "viscous", "coulomb"):
            v = getattr(self, name)
            if not (_is_number(v) and v >= 0):
                raise InputError(f"{where}: {name} must be a finite number >= 0 (joint side), got {v!r}.")
            object.__setattr__(self, name, float(v))
        object.__setattr__(self, "motor", int(self.motor))
        object.__setattr__(self, "joints", tuple(int(j) for j in joints))
        object.__setattr__(self, "ratios", tuple(float(x) for x in ratios))

    @classmethod
    def from_table(cls, table: Mapping, index: int) -> CoupledMotor:
        """The motor of one table of ``coupled_motors`` (entry ``index``, 1-based, for the messages)."""
        known = [f.name for f in fields(cls)]
        if not isinstance(table, Mapping):
            raise InputError(f"coupled_motors entry {index} must be a table {{{', '.join(known)}}}, got {table!r}.")
        unknown = sorted(set(table) - set(known))
        missing = [k for k in known[:3] if k not in table]
        if unknown or missing:
            raise InputError(f"coupled_motors entry {index}: " + (f"unknown key {unknown[0]!r}" if unknown else
                                                                 f"missing key {missing[0]!r}")
                             + "; its keys are motor, joints, ratios (required), armature, viscous, coulomb.")
        if not isinstance(table["joints"], list | tuple) or not isinstance(table["ratios"], list | tuple):
            raise InputError(f"coupled_motors entry {index}: joints and ratios must be lists, got "
                             f"{table['joints']!r} and {table['ratios']!r}.")
        return cls(**{**table, "joints": tuple(table["joints"]), "ratios": tuple(table["ratios"])})


@dataclass(frozen=True)
class UrdfOptions:
    """robot.options of ``model = "urdf"``.

    source : a name of :data:`EXAMPLE_ROBOTS` (e.g. "ur5", "panda") or the path of a .urdf file
        (relative to the folder the command runs in)
    joints : names of the joints to identify (default []: every arm joint); the others are locked
        at their neutral position and their links merged into the ones carrying them
    parameters : "base" (identifiable base parameters, :class:`boundid.models.base_parameters.BaseParameterModel`:
        what a study identifies) or "standard" (10 per link + friction, rank deficient)
    viscous, coulomb, armature, offset : one number for every joint, or a list of one per joint (in
        the model's joint order); a list is used as given, the number 0 (the default) means "not given"
    viscous, coulomb : true friction, N m s/rad and N m, >= 0 (URDFs rarely carry it; not given: the
        file's <dynamics damping=... friction=...>)
    armature : true motor inertia seen at each joint, kg m^2, >= 0; given, it adds the parameters Ia_j
    offset : true torque offset of each joint, N m, any sign; given, it adds the parameters off_j
    velocity_limit : rad/s (m/s) for every joint, for a file without <limit velocity=...> (0: the
        file's); the acceleration limit follows it (5 x the velocity limit per second)
    coupled_motors : motors that turn with several joints (:class:`CoupledMotor`), each a table
        {motor, joints, ratios, armature, viscous, coulomb} adding the parameters Iam, fvm, fsm of that
        motor; the Staubli TX40's wrist: [{motor = 6, joints = [5, 6], ratios = [32, 32],
        armature = 9.64e-3, viscous = 0.616, coulomb = 1.95}] (joint-side values, FIGAROH's)
    """

    source: str = "ur5"
    joints: tuple = ()
    parameters: str = "base"
    viscous: float | tuple = NumbersOption(0.0)
    coulomb: float | tuple = NumbersOption(0.0)
    armature: float | tuple = NumbersOption(0.0)
    offset: float | tuple = NumbersOption(0.0)
    velocity_limit: float = 0.0
    coupled_motors: tuple = TablesOption()
