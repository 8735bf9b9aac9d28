"""The method registry (:mod:`boundid.estimators.registry`): every registered method runs from a
Problem with its default options and agrees with its estimator class called directly; the study
schema is derived from the options dataclasses (no second list)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from boundid.errors import StudyError
from boundid.estimators import (
    OBE,
    RLS,
    BoxedOBE,
    BoxRecursion,
    KalmanEstimator,
    LimitedPolytopeRecursion,
    ParallelotopeRecursion,
    PolytopeRecursion,
    WindowedOBE,
    ZonotopeRecursion,
    ols,
    wls,
)
from boundid.estimators.method import Problem
from boundid.estimators.registry import METHODS
from boundid.sets import Box
from boundid.studies.config import load_study

P, N, E_MAX = 3, 120, 0.05
TRUTH = np.array([0.4, -0.3, 0.2])


def _problem() -> Problem:
    rng = np.random.default_rng(7)
    W = rng.normal(size=(N, P))
    y = W @ TRUTH + rng.uniform(-E_MAX, E_MAX, N)
    return Problem(W=W, y=y, groups=np.arange(N) % 2, names=("a", "b", "c"), unit="N m",
                   prior=Box.from_center(np.zeros(P), np.full(P, 2.0)), e_max=E_MAX, record_every=5)


def _direct(name: str, pb: Problem):
    """The estimator class or function of each method called directly with its own defaults."""
    kw = {"record_every": pb.record_every, "names": pb.names}
    sets = {"obe": OBE, "box": BoxRecursion, "parallelotope": ParallelotopeRecursion, "zonotope": ZonotopeRecursion,
            "polytope_limited": LimitedPolytopeRecursion, "polytope_exact": PolytopeRecursion,
            "obe_boxed": BoxedOBE, "obe_windowed": WindowedOBE}
    if name in sets:
        return sets[name](pb.p, prior=pb.prior, **kw).fit(pb.W, pb.y, pb.e_max)
    if name == "rls":
        return RLS(pb.p, **kw).fit(pb.W, pb.y)
    if name == "kalman":
        return KalmanEstimator(pb.p, **kw).fit(pb.W, pb.y)
    return ols(pb.W, pb.y, names=pb.names) if name == "ols" else wls(pb.W, pb.y, pb.groups, names=pb.names)


@pytest.mark.parametrize("name", list(METHODS))
def test_registered_method_equals_its_estimator_called_directly(name):
    """Reference: the estimator class called directly with its own defaults (a second path): the
    registry's default options are the class's defaults, and a guaranteed set holds the truth
    (uniform errors within e_max, truth in the prior box)."""
    m = METHODS[name]
    pb = _problem()
    est, ref = m.run(pb), _direct(name, pb)
    np.testing.assert_array_equal(est.center, ref.center)
    np.testing.assert_array_equal(est.intervals[0], ref.intervals[0])
    np.testing.assert_array_equal(est.intervals[1], ref.intervals[1])
    assert est.kind == ref.kind and est.names == pb.names
    if m.kind == "guaranteed":
        assert est.kind in ("guaranteed", "unverified") and est.contains(TRUTH)
    else:
        assert est.kind == "statistical"


def test_registry_entries_are_consistent():
    """Reference: the Method fields' documented vocabulary: options are frozen dataclasses whose
    fields all have defaults; every method that needs a bound is guaranteed."""
    for name, m in METHODS.items():
        assert m.name == name and m.summary
        assert dataclasses.is_dataclass(m.options) and m.options.__dataclass_params__.frozen
        m.options()  # every field has a default
        assert m.needs_bound == (m.kind == "guaranteed")


def _study(tmp_path, table: str):
    text = ('regressions = ["inverse_dynamic"]\n[study]\nname = "s"\ntitle = "t"\n[robot]\nmodel = "linear_toy"\n'
            '[experiment]\nsource = "simulate"\n[[estimators]]\n' + table)
    path = tmp_path / "s.toml"
    path.write_text(text)
    return load_study(path)


def test_study_tables_are_read_from_the_options_dataclass(tmp_path):
    """Reference: the options dataclasses: types (Literal choices, optional integers), ranges and
    defaults come from them; unknown keys are refused listing the known ones."""
    cfg = _study(tmp_path, 'method = "obe"\nregressions = ["inverse_dynamic"]\ne_max = 1.0\nform = "standard"\n')
    (ec,) = cfg.estimators
    assert ec.options == METHODS["obe"].options(form="standard") and ec.e_max == 1.0
    cfg = _study(tmp_path, 'method = "polytope_limited"\nregressions = ["inverse_dynamic"]\ne_max = 1.0\nblock = 50\n')
    assert cfg.estimators[0].options.block == 50 and cfg.estimators[0].options.max_strips is None
    for table, match in [
        ('method = "obe"\nregressions = ["inverse_dynamic"]\ne_max = 1.0\nform = "qr"\n',
         r"form: must be one of 'standard', 'factorized'"),
        ('method = "zonotope"\nregressions = ["inverse_dynamic"]\ne_max = 1.0\norder = 1\n', r"order: must be >= 2"),
        ('method = "zonotope"\nregressions = ["inverse_dynamic"]\ne_max = 1.0\norder = 2.5\n',
         r"order: must be an integer"),
        ('method = "obe_boxed"\nregressions = ["inverse_dynamic"]\ne_max = 1.0\nwindow = 3\n',
         r"window: unknown key; the obe_boxed estimator takes .*box_every \(integer >= 1, optional\)"),
        ('method = "ols"\nregressions = ["inverse_dynamic"]\ne_max = 1.0\n', r"e_max: unknown key"),
        ('method = "kalman"\nregressions = ["inverse_dynamic"]\nP0 = 2.0\n', r"P0: was renamed 'shape0'"),
        ('method = "lasso"\nregressions = ["inverse_dynamic"]\n', r"method: must be one of 'obe', 'rls'"),
    ]:
        with pytest.raises(StudyError, match=match):
            _study(tmp_path, table)
