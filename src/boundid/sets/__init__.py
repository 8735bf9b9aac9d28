"""Layer 1, sets: pure geometry (ellipsoids, polytopes of strips, exact LP/SDP optima)."""

from boundid.sets.ellipsoid import Ellipsoid, log_unit_ball_volume
from boundid.sets.polytope import Bounds, Consistency, Polytope

__all__ = ["Ellipsoid", "log_unit_ball_volume", "Bounds", "Consistency", "Polytope"]
