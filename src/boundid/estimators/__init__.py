"""Layer 2, estimators: recursive set-membership (OBE and the set families), RLS, batch LS, Kalman.

Input: a regression (W, y) with error bounds or noise levels. Output: an :class:`Estimate`.
Every recursive estimator follows one protocol (:mod:`boundid.estimators.protocol`: keyword-only
options, the prior as ``prior=`` or ``center0``/``shape0``, ``fit`` from the prior, ``partial_fit``
and ``update`` continuing); the method registry (:mod:`boundid.estimators.registry`) lists them
for the study files. Nothing here imports cvxpy until an SDP is solved.
"""

from boundid.estimators.box_recursion import BoxRecursion
from boundid.estimators.certify import Certificate, validate
from boundid.estimators.estimate import Estimate, History, Statistics
from boundid.estimators.kalman import KalmanEstimator
from boundid.estimators.least_squares import RankDeficientError, ols, wls
from boundid.estimators.obe import OBE
from boundid.estimators.obe_variants import BoxedOBE, WindowedOBE
from boundid.estimators.parallelotope_recursion import ParallelotopeRecursion
from boundid.estimators.polytope_recursion import LimitedPolytopeRecursion, PolytopeRecursion
from boundid.estimators.rls import RLS
from boundid.estimators.zonotope_recursion import ZonotopeRecursion

__all__ = ["BoxRecursion", "BoxedOBE", "Certificate", "Estimate", "History", "KalmanEstimator",
           "LimitedPolytopeRecursion", "OBE", "ParallelotopeRecursion", "PolytopeRecursion", "RLS",
           "RankDeficientError", "Statistics", "WindowedOBE", "ZonotopeRecursion", "ols", "validate", "wls"]
