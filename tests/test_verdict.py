"""The closing verdict of `boundid run`: one line per study, from the run's own result objects.

Independent references: the equation error at the truth recomputed here with numpy from the
regression rows (max |y - W theta_true| / e_max and the count of rows over the bound), the
certificate's containment re-checked by testing the 2p vertices of the exact polytope where its LP
bounds are reached against the OBE ellipsoid, and the failures the run recorded.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from boundid.cli import main
from boundid.report.verdict import run_verdict
from boundid.studies.config import load_study
from boundid.studies.runner import Failure, run_study
from tiny_study import tiny_study

#: WLS, a factorized OBE and the exact polytope on the tiny study's rows, at the bound E_MAX
ESTIMATORS = """
[[estimators]]
method = "wls"
regressions = ["filtered_dynamic"]

[[estimators]]
method = "obe"
label = "OBE-factorized"
regressions = ["filtered_dynamic"]
e_max = E_MAX

[exact]
regression = "filtered_dynamic"
e_max = E_MAX
"""
TINY = tiny_study("dd_verdict", 7) + ESTIMATORS


def _study(tmp_path, e_max: float):
    path = tmp_path / f"dd_{e_max:g}.toml".replace(".", "_", 1)
    path.write_text(TINY.replace("E_MAX", repr(e_max)))
    return path


@pytest.fixture(scope="module")
def ok_run(tmp_path_factory):
    """(study file, result) of the study with e_max = 6 N m."""
    path = _study(tmp_path_factory.mktemp("study"), 6.0)
    return path, run_study(load_study(path))


def _truth_errors(r):
    reg = r.regressions["filtered_dynamic"]
    ratio = np.abs(reg.y - reg.W @ r.model.theta_true) / r.exact.e_max
    return ratio.max(), int(np.sum(ratio > 1.0)), reg.n_rows


def test_run_ends_with_the_verdict_line(ok_run, tmp_path, capsys):
    """Uniform torque noise of 0.5 N m keeps the equation errors under e_max = 6 N m (checked
    here with numpy), so the verdict says the bound holds; the OBE set must contain the polytope
    (every vertex checked here), and nothing failed. The line is the last one printed."""
    path, r = ok_run  # same seed: the same numbers as the run below
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    worst, over, _ = _truth_errors(r)
    assert worst <= 1.0 and over == 0
    obe = r.estimates[("OBE-factorized", "filtered_dynamic")]
    b = r.exact.bounds  # p = 9: the 2p vertices where the exact LP bounds are reached
    assert all(obe.set.contains(v) for v in np.vstack([b.argmin, b.argmax]))
    assert last == run_verdict(r).line
    assert last.startswith("dd_verdict: OK: the bound holds at the truth")
    assert f"{worst:.3g} x e_max" in last
    assert "guarantees verified: all 1 guaranteed sets contain the exact polytope" in last
    assert last.endswith("no failures.")
    assert (tmp_path / "out" / "index.html").is_file()  # the run refreshed the site index


def test_verdict_names_a_broken_bound_and_failures(tmp_path):
    """With e_max = 0.2 N m the data break the bound: the number of rows over it equals a numpy
    count; the data contradict the bound, so the exact LP bounds are not computed and that is
    recorded as a failure, which the verdict counts."""
    r = run_study(load_study(_study(tmp_path, 0.2)))
    worst, over, n = _truth_errors(r)
    assert worst > 1.0 and over > 0
    v = run_verdict(r)
    assert v.bound_holds is False and not v.ok and v.n_failures == len(r.failures) > 0
    assert v.line.startswith("dd_verdict: ATTENTION: the bound does NOT hold at the truth")
    assert f"({over} of {n} rows over e_max, max {worst:.3g} x e_max)" in v.line
    assert f"{len(r.failures)} failure" in v.line and r.failures[0].subject in v.line


def test_verdict_flags_a_guaranteed_set_that_misses_the_polytope(ok_run):
    """A certificate that reports vertices outside (as the certifier would for a set too small)
    turns the verdict to "NOT verified"; a measured-data run reports the truth as unknown."""
    _, r = ok_run
    cert = r.exact.certificates["OBE-factorized"]
    broken = replace(r, exact=replace(r.exact, certificates={"OBE-factorized": replace(
        cert, contains_polytope=False, n_outside=1)}))
    v = run_verdict(broken)
    assert v.guarantees_verified is False and not v.ok
    assert "guarantees NOT verified: OBE-factorized" in v.line
    measured = replace(r, config=replace(r.config, experiment=replace(r.config.experiment, source="measured")))
    assert "truth unknown (measured data): e_max = " in run_verdict(measured).line
    assert "what follows holds only if every row's error is within it" in run_verdict(measured).line
    failed = run_verdict(replace(r, failures=[Failure("estimator", f"X{k}", "boom") for k in range(4)])).line
    assert "4 failures (estimator X0; estimator X1; estimator X2; ...;" in failed
