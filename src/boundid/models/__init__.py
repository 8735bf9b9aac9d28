"""Layer 3, models: robots whose dynamics are linear in their parameters."""

from boundid.models.base import RobotModel, coulomb

__all__ = ["RobotModel", "coulomb"]
from boundid.models.direct_drive import DirectDriveArm  # noqa: E402
from boundid.models.toy import LinearToy  # noqa: E402

__all__ += ["DirectDriveArm", "LinearToy"]
from boundid.models.h4 import H4Robot, H4Structural, H4Truth  # noqa: E402
from boundid.models.h4_kinematics import H4Geometry  # noqa: E402

__all__ += ["H4Geometry", "H4Robot", "H4Structural", "H4Truth"]
from boundid.models.base_parameters import BaseParameterModel, BaseParameters, base_parameters  # noqa: E402
from boundid.models.limits import JointLimits  # noqa: E402

__all__ += ["BaseParameterModel", "BaseParameters", "JointLimits", "UrdfRobot", "base_parameters"]


def __getattr__(name: str):
    """``UrdfRobot`` is imported on first use: pinocchio takes ~0.5 s to import."""
    if name == "UrdfRobot":
        from boundid.models.urdf import UrdfRobot

        return UrdfRobot
    raise AttributeError(f"module 'boundid.models' has no attribute {name!r}")
