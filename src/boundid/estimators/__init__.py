"""Layer 2, estimators: recursive set-membership (OBE), RLS, batch LS, Kalman.

Input: a regression (W, y) with error bounds or noise levels. Output: an :class:`Estimate`.
"""

from boundid.estimators.estimate import Estimate, History

__all__ = ["Estimate", "History"]

from boundid.estimators.obe import OBE  # noqa: E402

__all__ += ["OBE"]

from boundid.estimators.kalman import KalmanEstimator  # noqa: E402
from boundid.estimators.least_squares import RankDeficientError, ols, wls  # noqa: E402
from boundid.estimators.rls import RLS  # noqa: E402

__all__ += ["KalmanEstimator", "RLS", "RankDeficientError", "ols", "wls"]

from boundid.estimators.certify import Certificate, validate  # noqa: E402

__all__ += ["Certificate", "validate"]

from boundid.estimators.box_recursion import BoxRecursion  # noqa: E402
from boundid.estimators.obe_variants import BoxedOBE, WindowedOBE  # noqa: E402
from boundid.estimators.parallelotope_recursion import ParallelotopeRecursion  # noqa: E402
from boundid.estimators.polytope_recursion import LimitedPolytopeRecursion, PolytopeRecursion  # noqa: E402
from boundid.estimators.zonotope_recursion import ZonotopeRecursion  # noqa: E402

__all__ += ["BoxRecursion", "BoxedOBE", "LimitedPolytopeRecursion", "ParallelotopeRecursion", "PolytopeRecursion",
            "WindowedOBE", "ZonotopeRecursion"]
