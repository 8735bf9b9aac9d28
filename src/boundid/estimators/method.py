"""What a registered method is: :class:`Method` (name, options, build, set family, style), the
:class:`Problem` it is built on, and the :class:`Style` the report draws it with.

Each estimator module ends with its ``METHOD = Method(...)``; :mod:`boundid.estimators.registry`
lists them. A method's options are a frozen dataclass whose fields are the keyword options a
study file may set in its ``[[estimators]]`` table: the field's type gives the value's type
(``typing.Literal[...]`` the allowed strings, ``int | None`` an optional integer), its default
the default, and :func:`option` adds the range, a help line and former names.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from boundid.estimators.estimate import Estimate
from boundid.sets.box import Box

#: the families a method's set may belong to ("none": a point estimate)
SetFamily = Literal["ellipsoid", "box", "parallelotope", "zonotope", "polytope", "none"]


def option(default: Any, help: str, *, lo: float | None = None, hi: float | None = None, strict_lo: bool = False,
           strict_hi: bool = False, renamed_from: tuple[str, ...] = ()):
    """A field of an options dataclass: its default, a help line (units included), the range of a
    number (``lo``/``hi``, exclusive when ``strict_lo``/``strict_hi``; an integer's bounds are
    inclusive), and the names it had before (a study file using one gets an error naming the new
    key). A study file's value is checked against the range when it is read, and a number must also
    be finite (:func:`boundid.studies.config.read_options`)."""
    return field(default=default, metadata={"help": help, "lo": lo, "hi": hi, "strict_lo": strict_lo,
                                            "strict_hi": strict_hi, "renamed_from": tuple(renamed_from)})


@dataclass(frozen=True)
class NoOptions:
    """A method without options."""


@dataclass(frozen=True)
class Style:
    """How the report draws a method: a colour (colour-blind-safe palettes: Okabe-Ito, Paul Tol),
    a matplotlib marker and a line style. Every method and variant has its own."""

    color: str
    marker: str
    linestyle: str = "-"


@dataclass(frozen=True)
class Problem:
    """One regression, as a method sees it.

    W : (N, p)                observation matrix; y : (N,) measured side, in ``unit``
    groups : (N,) int         group of each row (the joint; -1 for scalar energy or power rows)
    names : tuple[str]        the p parameter names
    unit : str                unit of y ("N m", "J", "W")
    prior : Box               the prior box: a-priori values +- ranges (parameter units); every
                              guaranteed method starts from it
    e_max : float | None      the bound |y - w^T theta| <= e_max (in ``unit``) of the methods that
                              need one (``Method.needs_bound``)
    record_every : int        history sampling of the recursive methods (every that many rows)
    """

    W: np.ndarray
    y: np.ndarray
    groups: np.ndarray
    names: tuple[str, ...]
    unit: str
    prior: Box
    e_max: float | None = None
    record_every: int = 1

    @property
    def p(self) -> int:
        return int(self.W.shape[1])


@dataclass(frozen=True)
class Method:
    """One entry of the method registry.

    name : str                 what a study file writes (``method = "obe"``)
    summary : str              one line for ``boundid list`` and the pages
    options : type             the frozen options dataclass (see the module docstring)
    build : (Problem, options) -> Estimate
    set_family : SetFamily     the family of the returned set
    kind : "guaranteed" | "statistical"
    needs_bound : bool         the method needs Problem.e_max (a study gives ``e_max``; equal to
                               [exact].e_max when both bound the same rows)
    style : Style, or a function of the options giving one (variants drawn apart)
    """

    name: str
    summary: str
    options: type
    build: Callable[[Problem, Any], Estimate]
    set_family: SetFamily
    kind: Literal["guaranteed", "statistical"]
    needs_bound: bool
    style: Style | Callable[[Any], Style]

    def style_for(self, options=None) -> Style:
        """The style of this method with ``options`` (default options when None)."""
        if isinstance(self.style, Style):
            return self.style
        return self.style(self.options() if options is None else options)

    def run(self, problem: Problem, options=None) -> Estimate:
        """``build(problem, options)`` with default options when None."""
        return self.build(problem, self.options() if options is None else options)
