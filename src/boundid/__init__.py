"""boundid: robot dynamic identification, recursive estimators against exact optima."""

from boundid.errors import (
    BoundidError,
    InfeasibleDataError,
    InputError,
    SolverError,
    StudyError,
    UnreachablePoseError,
)

__version__ = "0.1.0"

__all__ = [
    "BoundidError",
    "InfeasibleDataError",
    "InputError",
    "SolverError",
    "StudyError",
    "UnreachablePoseError",
    "__version__",
]
