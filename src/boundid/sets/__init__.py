"""Layer 1, sets: pure geometry (ellipsoids, polytopes of strips, exact LP/SDP optima)."""

from boundid.sets.ellipsoid import Ellipsoid, log_unit_ball_volume
from boundid.sets.polytope import Bounds, Consistency, Polytope
from boundid.sets.sdp import (
    SDPResult,
    VolumeBracket,
    enclosing_ellipsoid,
    inner_ellipsoid,
    john_outer,
    min_volume_bracket,
    outer_ellipsoid,
    step_ellipsoid,
)

__all__ = ["Ellipsoid", "log_unit_ball_volume", "Bounds", "Consistency", "Polytope", "SDPResult", "VolumeBracket",
           "enclosing_ellipsoid", "inner_ellipsoid", "john_outer", "min_volume_bracket", "outer_ellipsoid",
           "step_ellipsoid"]
