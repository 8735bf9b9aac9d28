"""Layer 2, estimators: recursive set-membership (OBE), RLS, batch LS, Kalman.

Input: a regression (W, y) with error bounds or noise levels. Output: an :class:`Estimate`.
"""

from boundid.estimators.estimate import Estimate, History

__all__ = ["Estimate", "History"]

from boundid.estimators.obe import OBE  # noqa: E402

__all__ += ["OBE"]
