"""Layer 1, sets: pure geometry (ellipsoids, boxes, zonotopes, polytopes; exact LP/SDP optima).

The SDP ellipsoids (:mod:`boundid.sets.sdp`) need cvxpy, which takes a second to import: their
names are loaded from here on first use.
"""

from boundid.sets.box import Box
from boundid.sets.convex import ConvexSet, support_values
from boundid.sets.ellipsoid import Ellipsoid, RootInformationEllipsoid, log_unit_ball_volume
from boundid.sets.outliers import OutlierCount, RelaxedBounds, min_outliers, relaxed_bounds
from boundid.sets.parallelotope import Parallelotope
from boundid.sets.polytope import Bounds, Consistency, Polytope
from boundid.sets.vertex_polytope import VertexPolytope, shadow
from boundid.sets.zonotope import Zonotope

_SDP = ("SDPResult", "VolumeBracket", "enclosing_ellipsoid", "inner_ellipsoid", "john_outer", "min_volume_bracket",
        "outer_ellipsoid", "polytope_ellipsoids", "step_ellipsoid")

__all__ = ["Ellipsoid", "RootInformationEllipsoid", "log_unit_ball_volume", "Bounds", "Consistency", "Polytope", "Box",
           "ConvexSet", "Parallelotope", "VertexPolytope", "Zonotope", "shadow", "support_values", "OutlierCount",
           "RelaxedBounds", "min_outliers", "relaxed_bounds", *_SDP]


def __getattr__(name: str):
    if name in _SDP:
        from boundid.sets import sdp

        return getattr(sdp, name)
    raise AttributeError(f"module 'boundid.sets' has no attribute {name!r}")
