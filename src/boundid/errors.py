"""The few exception types boundid raises.

Every message says what was wrong and what to do about it.
"""

import numpy as np


class BoundidError(Exception):
    """Base class of every boundid error."""


class InputError(BoundidError, ValueError):
    """Bad input: wrong shape, NaN or infinite values, non-positive bounds, unknown option."""


class InfeasibleDataError(BoundidError):
    """The data contradict the error bounds: the feasible parameter set is empty."""


class SolverError(BoundidError, RuntimeError):
    """An LP or SDP solver failed or returned an inaccurate answer."""


class UnreachablePoseError(BoundidError, ValueError):
    """A robot pose outside the workspace or too close to a singularity."""


class StudyError(BoundidError, ValueError):
    """A study file that cannot be run: missing key, wrong type, unknown value."""


class ResourceError(StudyError):
    """A study whose experiment would exceed the resource budget (samples x joints, memory)."""


class OutputError(BoundidError):
    """A report folder that cannot be written: ``--out`` is a file, not writable, or a name escapes it."""


class NumericalError(BoundidError, ArithmeticError):
    """A recursion's state stopped being a finite, positive definite one (data scaled too far for
    floating point); the message names the row and the fix, and the estimator is left unchanged."""


# What one stage of a run (an estimator, a re-simulation, an exact optimum, a figure) may raise on
# input that is valid but numerically hard: boundid's own errors, and numpy/scipy/math failures
# (LinAlgError, FloatingPointError, ZeroDivisionError, OverflowError, ValueError such as
# "math domain error"). A study run records these as failures of that stage and goes on.
RUN_FAILURES = (BoundidError, np.linalg.LinAlgError, ArithmeticError, ValueError)

