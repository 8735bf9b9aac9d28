"""The robot registry: every robot a study file may name (``[robot] model = ...``), one line each.

``ROBOTS[name]`` is a :class:`~boundid.models.RobotModel` class; its ``Options`` (a frozen
dataclass) is what the study's ``robot.options`` may set, typed by each field's default, and
``from_options`` builds the robot. A new robot is its own module plus one line here.
``"urdf"`` names any URDF arm: ``robot.options = { source = "panda" }`` (an example-robot-data
name of :data:`boundid.models.urdf_options.EXAMPLE_ROBOTS`) or the path of a .urdf file.
"""

from __future__ import annotations

import dataclasses

from boundid.errors import InputError
from boundid.models.base import RobotModel
from boundid.models.direct_drive import DirectDriveArm
from boundid.models.h4 import H4Robot
from boundid.models.pendulum import Pendulum
from boundid.models.toy import LinearToy
from boundid.models.urdf_options import UrdfOptions


class UrdfEntry:
    """The ``"urdf"`` entry: any URDF arm, as :class:`boundid.models.urdf.UrdfRobot` (pinocchio is
    imported when one is built)."""

    Options = UrdfOptions

    @staticmethod
    def from_options(options: UrdfOptions) -> RobotModel:
        from boundid.models.base_parameters import BaseParameterModel
        from boundid.models.urdf import UrdfRobot

        if options.parameters not in ("base", "standard"):
            raise InputError(f"parameters must be 'base' or 'standard', got {options.parameters!r}.")
        robot = UrdfRobot.from_options(options)
        return BaseParameterModel(robot) if options.parameters == "base" else robot


ROBOTS: dict[str, type] = {  # RobotModel classes (the urdf entry builds a UrdfRobot)
    "direct_drive": DirectDriveArm,
    "h4": H4Robot,
    "linear_toy": LinearToy,
    "pendulum": Pendulum,
    "urdf": UrdfEntry,
}


def robot_options(name: str) -> dict:
    """{option: default} of ``ROBOTS[name].Options`` (the fields a study may set)."""
    return {f.name: f.default for f in dataclasses.fields(ROBOTS[name].Options) if f.init}


def make_robot(name: str, options: dict | None = None) -> RobotModel:
    """The registered robot ``name`` with ``options`` {field: value} of its Options dataclass;
    InputError naming the robots, the options or the value the model refuses."""
    if name not in ROBOTS:
        raise InputError(f"unknown robot {name!r}; choose among {', '.join(ROBOTS)}.")
    cls = ROBOTS[name]
    unknown = sorted(set(options or {}) - set(robot_options(name)))
    if unknown:
        raise InputError(f"unknown option {unknown[0]!r} for robot {name}; its options are "
                         f"{', '.join(robot_options(name)) or 'none'}.")
    return cls.from_options(cls.Options(**(options or {})))
