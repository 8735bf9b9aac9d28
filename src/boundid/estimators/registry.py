"""The method registry: every estimator a study file may name, one line each.

``METHODS[name]`` is the :class:`~boundid.estimators.method.Method` of that name: its options
dataclass (what a study's ``[[estimators]]`` table may set), its ``build(problem, options)``,
its set family, kind, whether it needs the bound e_max, and its style in the report. A new
estimator is its own module ending with ``METHOD = Method(...)`` plus one line here.
"""

from __future__ import annotations

from boundid.errors import InputError
from boundid.estimators import (
    box_recursion,
    kalman,
    least_squares,
    obe,
    obe_variants,
    parallelotope_recursion,
    polytope_recursion,
    rls,
    zonotope_recursion,
)
from boundid.estimators.method import Method


def _index(*methods: Method) -> dict[str, Method]:
    out: dict[str, Method] = {}
    for m in methods:
        if m.name in out:
            raise InputError(f"two methods are registered as {m.name!r}.")
        out[m.name] = m
    return out


METHODS: dict[str, Method] = _index(
    obe.METHOD,
    rls.METHOD,
    kalman.METHOD,
    least_squares.OLS_METHOD,
    least_squares.WLS_METHOD,
    box_recursion.METHOD,
    parallelotope_recursion.METHOD,
    zonotope_recursion.METHOD,
    polytope_recursion.LIMITED_METHOD,
    polytope_recursion.EXACT_METHOD,
    obe_variants.BOXED_METHOD,
    obe_variants.WINDOWED_METHOD,
)
