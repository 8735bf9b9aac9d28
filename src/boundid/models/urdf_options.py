"""What a study may say about a URDF robot, without loading pinocchio (~0.5 s): the names of the
example-robot-data arms and the options dataclass of :class:`boundid.models.urdf.UrdfRobot`."""

from __future__ import annotations

from dataclasses import dataclass

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


@dataclass(frozen=True)
class UrdfOptions:
    """robot.options of ``model = "urdf"``.

    source : a name of :data:`EXAMPLE_ROBOTS` (e.g. "ur5", "panda") or the path of a .urdf file
        (relative to the folder the command runs in)
    joints : names of the joints to identify (default []: every arm joint); the others are locked
        at their neutral position and their links merged into the ones carrying them
    parameters : "base" (identifiable base parameters, :class:`boundid.models.base_parameters.BaseParameterModel`:
        what a study identifies) or "standard" (10 per link + friction, rank deficient)
    viscous, coulomb : true friction of every joint, N m s/rad and N m (URDFs rarely carry it;
        0 keeps the file's <dynamics damping=... friction=...>)
    armature : true motor inertia seen at every joint, kg m^2 (> 0 adds the parameters Ia_j)
    velocity_limit : rad/s (m/s) for every joint, for a file without <limit velocity=...> (0: the
        file's); the acceleration limit follows it (5 x the velocity limit per second)
    """

    source: str = "ur5"
    joints: tuple = ()
    parameters: str = "base"
    viscous: float = 0.0
    coulomb: float = 0.0
    armature: float = 0.0
    velocity_limit: float = 0.0
