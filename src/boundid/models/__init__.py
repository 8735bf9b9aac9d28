"""Layer 3, models: robots whose dynamics are linear in their parameters."""

from boundid.models.base import RobotModel, coulomb

__all__ = ["RobotModel", "coulomb"]
from boundid.models.direct_drive import DirectDriveArm  # noqa: E402
from boundid.models.toy import LinearToy  # noqa: E402

__all__ += ["DirectDriveArm", "LinearToy"]
from boundid.models.h4 import H4Robot, H4Structural, H4Truth  # noqa: E402
from boundid.models.h4_kinematics import H4Geometry  # noqa: E402

__all__ += ["H4Geometry", "H4Robot", "H4Structural", "H4Truth"]
