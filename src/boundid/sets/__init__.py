"""Layer 1, sets: pure geometry (ellipsoids, polytopes of strips, exact LP/SDP optima)."""

from boundid.sets.box import Box
from boundid.sets.convex import ConvexSet
from boundid.sets.ellipsoid import Ellipsoid, log_unit_ball_volume
from boundid.sets.parallelotope import Parallelotope
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
from boundid.sets.vertex_polytope import VertexPolytope, shadow
from boundid.sets.zonotope import Zonotope

__all__ = ["Ellipsoid", "log_unit_ball_volume", "Bounds", "Consistency", "Polytope", "SDPResult", "VolumeBracket",
           "enclosing_ellipsoid", "inner_ellipsoid", "john_outer", "min_volume_bracket", "outer_ellipsoid",
           "step_ellipsoid", "Box", "ConvexSet", "Parallelotope", "VertexPolytope", "Zonotope", "shadow"]
