"""Published values against the data (boundid.studies.published).

Independent references: scipy.optimize.linprog (HiGHS through scipy, not boundid's working-set LP)
for the exact interval of c^T theta and for the smallest bound factor, alone and for a whole table;
the definition of that factor (the polytope with the values fixed is non-empty just above it, empty
just below); a regrouping matrix written by hand for the base-parameter combinations.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import linprog

from boundid.errors import InputError, StudyError
from boundid.sets import Polytope
from boundid.studies.published import PublishedTable, compare_published, functional, parse_linear, smallest_factor
from tiny_study import run_study_text, tiny_study


def test_parse_linear_reads_published_definitions():
    assert parse_linear("Izz1 + 1.0*Ia1 + 0.05185*m3 - 1.0*Iyy2") == {"Izz1": 1.0, "Ia1": 1.0, "m3": 0.05185,
                                                                     "Iyy2": -1.0}
    assert parse_linear("Ixx2 - 0.05062 m3 + 1e-05*m4") == {"Ixx2": 1.0, "m3": -0.05062, "m4": 1e-05}
    assert parse_linear("-fv5 + fvm6 + fv5") == {"fv5": 0.0, "fvm6": 1.0}
    for bad in ("", "fv5 +", "fv5 fv6", "2*", "fv5 * 2", "fv5 + (fvm6)"):
        with pytest.raises(InputError):
            parse_linear(bad)


# standard parameters a, b, c, d regrouped into base parameters aR = a + 0.5 c, b, dR = d - c
TOY = SimpleNamespace(name="toy", param_names=("aR", "b", "dR"),
                      robot=SimpleNamespace(param_names=("a", "b", "c", "d")),
                      base=SimpleNamespace(K=np.array([[1.0, 0, 0.5, 0], [0, 1, 0, 0], [0, 0, -1, 1]])))


def test_functional_is_the_base_combination_or_none():
    np.testing.assert_allclose(functional("a + 0.5*c", TOY), [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(functional("b + d - c", TOY), [0, 1, 1], atol=1e-12)
    np.testing.assert_allclose(functional("aR + 2 b", TOY), [1, 2, 0], atol=1e-12)  # base symbols too
    np.testing.assert_allclose(functional("a + 0.50001*c", TOY), [1, 0, 0], atol=1e-4)  # published rounding
    assert functional("a", TOY) is None  # a alone is not identifiable
    assert functional("c", TOY) is None
    with pytest.raises(InputError, match="'e' in 'a \\+ e' is not a parameter of the toy model; its parameters: "
                                         "aR, b, dR, a, c, d."):
        functional("a + e", TOY)
    with pytest.raises(InputError, match="^'b_' is not a parameter of the toy model \\(did you mean 'b'\\?\\)"):
        functional("b_", TOY)


def _problem(seed=0, rows=40, p=3):
    rng = np.random.default_rng(seed)
    W = rng.normal(size=(rows, p))
    theta = np.array([1.0, -2.0, 0.5])
    y = W @ theta + rng.uniform(-0.3, 0.3, rows)
    box = (np.full(p, -10.0), np.full(p, 10.0))
    return Polytope.from_strips(W, y, 0.3, box=box), theta


def _linprog_factor(P, C, v) -> float:
    """min t s.t. |y - W beta| <= t e, C beta = v, beta in the box (scipy's HiGHS)."""
    N, p = P.W.shape
    e = P.e_max
    A = np.block([[-P.W, -e[:, None]], [P.W, -e[:, None]]])
    res = linprog(np.r_[np.zeros(p), 1.0], A_ub=A, b_ub=np.r_[-P.y, P.y],
                  A_eq=np.c_[np.atleast_2d(C), np.zeros((np.atleast_2d(C).shape[0], 1))], b_eq=np.atleast_1d(v),
                  bounds=[*zip(P.box[0], P.box[1], strict=True), (0, None)], method="highs")
    return float(res.fun)


def _linprog_interval(P, c) -> tuple[float, float]:
    A, b = np.vstack([P.W, -P.W]), np.r_[P.y + P.e_max, -(P.y - P.e_max)]
    bounds = list(zip(P.box[0], P.box[1], strict=True))
    lo = linprog(c, A_ub=A, b_ub=b, bounds=bounds, method="highs").fun
    hi = -linprog(-c, A_ub=A, b_ub=b, bounds=bounds, method="highs").fun
    return lo, hi


def test_compare_published_against_linprog():
    """Values inside and outside their exact intervals, a combination named by the source; the table as
    a whole; values that contradict one another are never allowed together."""
    P, theta = _problem()
    model = SimpleNamespace(name="toy", param_names=("p1", "p2", "p3"))
    lo, hi = _linprog_interval(P, np.array([1.0, 1.0, 0.0]))
    s_value = theta[0] + hi + 0.2  # 2 p1 + p2 at p1 = theta[0], p1 + p2 = hi + 0.2
    table = PublishedTable("paper", "a paper", (("p1", theta[0]), ("p1 + p2", hi + 0.2), ("s", s_value)),
                           {"s": "p2 + 2 p1"})
    out = compare_published((table,), model, P, None, {"centre": theta})
    v = out.values.set_index("name")
    assert v.loc["p1 + p2", "exact lo"] == pytest.approx(lo, abs=1e-8)
    assert v.loc["p1 + p2", "exact hi"] == pytest.approx(hi, abs=1e-8)
    assert v.loc["p1", "inside exact"] == "yes" and v.loc["p1 + p2", "inside exact"] == "no"
    assert v.loc["s", "quantity"] == "2 p1 + p2"
    for name, c, value in (("p1", [1, 0, 0], theta[0]), ("p1 + p2", [1, 1, 0], hi + 0.2), ("s", [2, 1, 0], s_value)):
        ref = _linprog_factor(P, np.array(c, float), value)
        assert v.loc[name, "from bound"] == pytest.approx(ref, rel=1e-7), name
        assert (v.loc[name, "from bound"] <= 1.0) == (v.loc[name, "inside exact"] == "yes")
    assert v.loc["p1", "centre - value [%]"] == pytest.approx(0.0, abs=1e-12)
    C = np.array([[1.0, 0, 0], [1, 1, 0], [2, 1, 0]])
    values = np.array([theta[0], hi + 0.2, s_value])
    together = out.tables.loc[0, "together from"]
    assert together == pytest.approx(_linprog_factor(P, C, values), rel=1e-7)
    assert together >= v["from bound"].max() - 1e-9  # fixing more values can only need a larger bound
    values[2] += 1.0  # now p1 and p2 are fixed two ways
    assert smallest_factor(P, C, values) == np.inf


@pytest.mark.parametrize("seed", range(3))
def test_smallest_factor_is_the_definition(seed):
    """Just above the factor the polytope with the value fixed is non-empty; just below, empty."""
    P, theta = _problem(seed)
    c, value = np.array([0.3, -1.0, 2.0]), float(np.array([0.3, -1.0, 2.0]) @ theta) + 0.4
    s = smallest_factor(P, c, value)
    halfspaces = (np.vstack([c, -c]), np.array([value, -value]))
    assert not Polytope.from_strips(P.W, P.y, s * (1 + 1e-6) * P.e_max, box=P.box,
                                    halfspaces=halfspaces).consistency().empty
    assert Polytope.from_strips(P.W, P.y, s * (1 - 1e-3) * P.e_max, box=P.box,
                                halfspaces=halfspaces).consistency().empty


PUBLISHED = """
[[estimators]]
method = "wls"
label = "WLS"
regressions = ["filtered_dynamic"]

[exact]
regression = "filtered_dynamic"
e_max = 6.0

[[published]]
label = "truth"
source = "the simulator"
values = {{ th1 = {th1!r}, b1 = {b1!r}, fc = {fc!r} }}
names = {{ fc = "fc1" }}

[[published]]
label = "file"
file = "pub.csv"
header = true
value_column = 2
"""


def test_a_study_file_compares_its_published_tables(tmp_path):
    """The simulated direct-drive study's own truth as a published table lies inside every exact interval
    and is allowed as a whole from the bound's truth ratio at most; a CSV table is read by its columns."""
    (tmp_path / "pub.csv").write_text("name,comment,value\nth2,a,0.08\nfc2,b,1.7\n")
    from boundid.studies.registry import make_robot

    t = make_robot("direct_drive", {}).theta_true
    text = tiny_study("pub", 1) + PUBLISHED.format(th1=float(t[0]), b1=float(t[5]), fc=float(t[7]))
    _, r = run_study_text(tmp_path, "pub", text)
    v = r.published.values.set_index("name")
    assert list(v.index) == ["th1", "b1", "fc", "th2", "fc2"]
    assert v.loc["fc", "quantity"] == "fc1" and v.loc["fc2", "value"] == 1.7
    truth = r.published.tables.set_index("published").loc["truth"]
    assert truth["inside exact"] == 3 and truth["together from"] <= r.exact.truth_error_ratio + 1e-9


@pytest.mark.parametrize("table, match", [
    ('label = "x"\nvalues = { th1 = 1.0 }\nfile = "pub.csv"', "give exactly one"),
    ('label = "x"', "give exactly one"),
    ('label = "x"\nvalues = { zz = 1.0 }', "entry 'zz'.*not a parameter of the direct_drive model.*names = "),
    ('label = "x"\nvalues = { th1 = "one" }', "must be a table \\{name = number\\}"),
    ('label = "x"\nvalues = { th1 = nan }', "'th1' is not finite"),
    ('label = "x"\nvalues = { th1 = 1.0 }\nnames = { th1 = 3 }', "names: must be a table"),
    ('label = "x"\nfile = "missing.csv"', "missing.csv not found"),
    ('label = "x"\nfile = "pub.csv"', "line 1 of pub.csv: 'value' is not a number \\(a header line\\? set header"),
    ('label = "x"\nfile = "pub.csv"\nheader = true\nvalue_column = 5', "line 2 of pub.csv has 2 columns"),
    ('label = "x"\nvalues = { th1 = 1.0 }\ncolour = "red"', "colour"),
])
def test_bad_published_tables_are_refused_naming_the_fix(tmp_path, table, match):
    (tmp_path / "pub.csv").write_text("name,value\nth1,2.0\n")
    path = tmp_path / "bad.toml"
    wls = '[[estimators]]\nmethod = "wls"\nlabel = "WLS"\nregressions = ["filtered_dynamic"]\n'
    path.write_text(tiny_study("bad", 0) + f"\n{wls}\n[[published]]\n{table}\n")
    from boundid.studies.config import load_study

    with pytest.raises(StudyError, match=match):
        load_study(path)
