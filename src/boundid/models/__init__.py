"""Layer 3, models: robots whose dynamics are linear in their parameters."""

from boundid.models.base import RobotModel, coulomb

__all__ = ["RobotModel", "coulomb"]
