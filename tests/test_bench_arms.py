"""The full-arms benchmark (boundid.bench.bench_arms): a tiny case measures every part, the
exponent fit recovers known power laws, and every goal judges exactly one row of a table shaped
like run()'s.

Reference: synthetic times t = c p^a N^b, whose exponents are known by construction; a fake
table with run()'s columns and the headline cases' rows, whose verdicts follow from its values.
"""

import math

import numpy as np
import pandas as pd
import pytest

from boundid.bench import bench_arms as B
from boundid.bench.goals import judge, select


def test_a_tiny_case_in_a_fresh_process_times_every_part():
    """The 2-link arm (p = 10), 500 rows, in a spawned process: every part has a positive wall time,
    the exact stage covers the LP bounds and the ellipsoids (outer and inner overlap in two threads:
    at least the LP bounds plus the longer of the two), the peak memory is recorded."""
    rows = pd.DataFrame(B.in_fresh_process("arm2", 500, "tiny"))
    assert sorted(rows.part) == sorted([*B.PARTS, "exact stage"]), rows.detail.tolist()
    assert (rows.p == 10).all() and (rows.N == 500).all()
    assert (rows.time_s > 0).all(), rows[["part", "time_s", "detail"]]
    parts = rows.set_index("part")
    assert parts.cpu_s[["LP bounds", "exact stage", "physical bounds"]].gt(0).all()
    t = parts.time_s
    assert t["exact stage"] >= t["LP bounds"] + max(t["outer ellipsoid"], t["inner ellipsoid"]) - 1e-9
    assert t["exact stage"] <= t[list(B.EXACT_PARTS)].sum() + 0.5
    assert 0.05 < rows.peak_rss_gb.iloc[0] < 2.0 and rows.peak_rss_gb.nunique() == 1


def test_the_regression_has_the_requested_rows_and_the_truth_in_its_strips(tmp_path):
    """N rows (not N states) of p columns; the truth's residuals are within the noise, below e_max."""
    model = B.arm("ur5-2", tmp_path)
    W, y = B.regression(model, 501, seed=0)
    assert W.shape == (501, model.p) == (501, 12) and y.shape == (501,)
    assert np.max(np.abs(y - W @ model.theta_true)) <= B.NOISE < B.E_MAX


@pytest.mark.parametrize(("a", "b"), [(2.0, 0.0), (1.3, 0.7), (-0.5, 1.0)])
def test_the_exponent_fit_recovers_a_known_power_law(a, b):
    p, N = (v.ravel() for v in np.meshgrid([9, 14, 22, 52, 62], [2e3, 1e4, 5e4]))
    e_p, e_n = B.exponents(p, N, 3.0 * p ** a * N ** b)
    assert e_p == pytest.approx(a, abs=1e-9) and e_n == pytest.approx(b, abs=1e-9)


def test_the_exponent_fit_skips_missing_times_and_a_fixed_variable():
    p = np.array([10, 12, 22, 52])
    t = np.array([1.0, 1.2 ** 2, np.nan, 5.2 ** 2])   # t = (p / 10)^2, one case failed
    e_p, e_n = B.exponents(p, np.full(4, 2_000), t)
    assert e_p == pytest.approx(2.0, abs=1e-9) and math.isnan(e_n)
    assert all(math.isnan(e) for e in B.exponents([10, 12], [2e3, 2e3], [np.nan, -1.0]))


def test_growth_rows_fit_each_part_and_name_the_dominant_one():
    grid = []
    for key, p in (("arm2", 10), ("ur5-3", 22)):
        for N in (2_000, 10_000):
            for part in (*B.PARTS, "exact stage"):
                t = 10.0 if part == "outer ellipsoid" and p == 22 else 1e-6 * p ** 2 * N
                grid.append(B._row("part", B.grid_case(key, N), B.ROBOTS[key][0], p, N, part, time_s=t))
    rows = pd.DataFrame(B.growth_rows(pd.DataFrame(grid)))
    exp = rows[rows.what == "exponent"].set_index("part")
    assert list(exp.index) == [*B.PARTS, "exact stage"]
    assert exp.exp_p["LP bounds"] == pytest.approx(2.0) and exp.exp_N["LP bounds"] == pytest.approx(1.0)
    (dom,) = rows[rows.what == "dominant"].itertuples()
    assert dom.part == "outer ellipsoid" and dom.case == B.grid_case("ur5-3", 10_000) and dom.time_s == 10.0


def _headline_table(time_s: float) -> pd.DataFrame:
    """A table with run()'s columns: the headline cases' rows (every time ``time_s``, peak 1 GB),
    plus a grid case and an exponent row that no goal may select."""
    rows = []
    for key in B.HEADLINE:
        for part in (*B.PARTS, "exact stage"):
            rows.append(B._row("part", B.headline_case(key), B.ROBOTS[key][0], 52, B.HEADLINE[key], part,
                               time_s=time_s, cpu_s=time_s, peak_rss_gb=1.0))
    rows.append(B._row("part", B.grid_case("ur5", 10_000), "UR5, 6 joints", 52, 10_000, "exact stage", time_s=1.0))
    rows.append(B._row("exponent", "growth grid", "", "", "", "exact stage", exp_p=2.0, exp_N=1.0))
    return pd.DataFrame(rows)


@pytest.mark.parametrize(("time_s", "status"), [(1.0, "met"), (1e3, "missed")])
def test_every_goal_selects_one_headline_row_and_is_judged(time_s, status):
    df = _headline_table(time_s)
    assert list(df.columns) == list(B._row("part", "", "", 0, 0, "").keys())
    for goal in B.GOAL_CHECKS:
        assert len(select(df, goal.where)) == 1, goal.name
        verdict = judge(goal, df, "arms", 0.5)
        expected = "met" if goal.column == "peak_rss_gb" else status
        assert verdict.status == expected, (goal.name, verdict.reason)
        assert verdict.size.startswith(("UR5, 6 joints, p = 52, N = 8,600", "Panda, 7 joints, p = 52, N = 10,033"))


def test_the_baseline_ratio_is_on_the_two_headline_ur5_rows_only():
    ratios = {(r["case"], r["part"]): B.baseline_ratio(r) for r in _headline_table(46.0).to_dict("records")}
    finite = {k: v for k, v in ratios.items() if np.isfinite(v)}
    ur5 = B.headline_case("ur5")
    assert finite == {(ur5, "exact stage"): pytest.approx(46.0 / 92.0),
                      (ur5, "physical bounds"): pytest.approx(46.0 / 47.0)}
