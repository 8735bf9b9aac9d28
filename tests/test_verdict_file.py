"""verdict.json beside results.csv, and the exit codes of `boundid run` and `boundid report`.

Independent references: the equation error at the truth recomputed with numpy from the regression
rows (max |y - W theta_true| / e_max); the truth's membership in the OBE ellipsoid recomputed from
its centre and shape matrix, (x - c)^T S^-1 (x - c) <= 1 with numpy.linalg.solve; gamma* of a
measured recording under the rule e_max = 2 gamma* (the bounds can shrink by half: 0.5, and the
margin is the rule's factor, 2) and under a number 0.8 gamma* (1.25 and 0.8); the paper verdict
counts counted from the Claim list with collections.Counter. Every file and document produced here
is validated with the jsonschema package (installed with the dev extra, through jupytext's
nbformat) against SCHEMA, itself checked as a draft 2020-12 schema, and each check's status
against its value, limit and comparison.
"""

from __future__ import annotations

import copy
import json
import re
from collections import Counter
from dataclasses import replace
from pathlib import Path

import jsonschema
import numpy as np
import pytest

from boundid.cli import build_parser, main
from boundid.report import verdict_file as vf
from boundid.report.verdict import run_verdict
from boundid.sets import Ellipsoid
from boundid.studies import runner
from boundid.studies.config import load_study
from boundid.studies.reproduction import VERDICTS, claims
from boundid.studies.runner import run_study
from test_verdict import ESTIMATORS
from tiny_study import measured_twin, run_study_text, tiny_study

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "verdict-file.md").read_text(encoding="utf-8")
VALIDATOR = jsonschema.Draft202012Validator(vf.SCHEMA)
GATES = [c for c, s in vf.CHECKS.items() if s.gate]

def _study(folder: Path, name: str, e_max: float) -> Path:
    """The tiny direct-drive study (seed 7) with WLS, an OBE and the exact polytope at ``e_max``:
    6 N m holds at the truth (max 0.79 e_max); 3 N m is broken on 119 of 1600 rows, the data
    contradict it (gamma* 1.5 e_max) and the OBE, skipping 90 rows, misses the truth."""
    path = folder / f"{name}.toml"
    path.write_text(tiny_study(name, 7) + ESTIMATORS.replace("E_MAX", repr(e_max)))
    return path


@pytest.fixture(autouse=True)
def short_outlier_milp(monkeypatch):
    """The minimum-outlier MILP of a bound the data contradict, 0.5 s instead of 10 (its answer is
    not what these tests check)."""
    monkeypatch.setattr(runner, "OUTLIER_TIME_LIMIT_S", 0.5)


def _valid(doc: dict) -> dict:
    """``doc`` validated against SCHEMA, and its statuses, gates and exit code against its numbers."""
    VALIDATOR.validate(doc)
    for c in doc["checks"]:
        if c["status"] == "not_evaluated":
            assert c["value"] is None and c["reason"], c
            continue
        ok = c["value"] <= c["limit"] if c["comparison"] == "<=" else c["value"] >= c["limit"]
        assert c["status"] == ("pass" if ok else "fail"), c
    failed = [c["id"] for c in doc["checks"] if c["gate"] and c["status"] == "fail"]
    assert doc["failed_gates"] == failed and doc["exit_code"] == (3 if failed else 0)
    return doc


def _file(folder: Path) -> dict:
    """The study folder's verdict.json, read as strict JSON and validated."""
    path = folder / "verdict.json"
    assert (folder / "results.csv").is_file() and path.is_file()

    def bad(name):
        raise ValueError(f"not strict JSON: {name}")
    return _valid(json.loads(path.read_text(encoding="utf-8"), parse_constant=bad))


def _check(doc: dict, cid: str) -> dict:
    return next(c for c in doc["checks"] if c["id"] == cid)


def _in_ellipsoid(est, x) -> bool:
    d = np.asarray(x, float) - est.set.center
    return float(d @ np.linalg.solve(est.set.shape, d)) <= 1.0


def _truth_ratio(r) -> tuple[float, int]:
    reg = r.regressions["filtered_dynamic"]
    ratio = np.abs(reg.y - reg.W @ r.model.theta_true) / r.exact.e_max
    return float(ratio.max()), int(np.sum(ratio > 1.0))


# ------------------------------------------------------------------------------ the schema


@pytest.fixture(scope="module")
def ok_run(tmp_path_factory):
    """(study file, result) of the study at e_max = 6 N m, run without writing a page."""
    path = _study(tmp_path_factory.mktemp("ok"), "vf_ok", 6.0)
    return path, run_study(load_study(path))


def test_the_schema_is_a_2020_12_schema_and_refuses_what_it_must(ok_run):
    """A pass without a value, a not-evaluated check without a reason or with a value, a count that
    is not an integer, a gate flipped, a check missing, out of order or unknown, an unknown
    status or field: each refused."""
    jsonschema.Draft202012Validator.check_schema(vf.SCHEMA)
    doc = _valid(json.loads(json.dumps(vf.verdict_document(ok_run[1], run_verdict(ok_run[1]).line))))

    def edited(fn):
        d = copy.deepcopy(doc)
        fn(d)
        return d

    def at(cid, **fields):
        return lambda d: _check(d, cid).update(fields)

    bad = {
        "pass with no value": at("bound_at_truth", value=None),
        "not evaluated, no reason": at("paper_claims", reason=None),
        "not evaluated, a value": at("paper_claims", value=0),
        "pass with a reason": at("bound_at_truth", reason="because"),
        "a count of 0.5": at("estimator_failures", value=0.5),
        "a gate flipped": at("estimator_failures", gate=True),
        "another limit": at("bound_at_truth", limit=2.0),
        "an unknown status": at("bound_at_truth", status="skipped"),
        "an unknown field": at("bound_at_truth", note="x"),
        "an unknown detail": lambda d: _check(d, "bound_at_truth")["details"].update(extra=1),
        "a check missing": lambda d: d["checks"].pop(3),
        "checks out of order": lambda d: d["checks"].reverse(),
        "a second copy of a check": lambda d: d["checks"].append(d["checks"][0]),
        "another schema version": lambda d: d.update(schema_version=vf.SCHEMA_VERSION - 1),
        "exit code 1": lambda d: d.update(exit_code=1),
        "a non-gate among the failed gates": lambda d: d["failed_gates"].append("paper_claims"),
        "no study name": lambda d: d.pop("study"),
    }
    for what, fn in bad.items():
        assert not VALIDATOR.is_valid(edited(fn)), what
    assert [c["id"] for c in doc["checks"]] == list(vf.CHECK_IDS)


def test_the_doc_lists_every_check_with_its_gate_limit_and_unit():
    """docs/verdict-file.md's table of checks, parsed: the same ids in the same order, gates,
    comparisons, limits and units as CHECKS; the schema's version and every top-level field named."""
    rows = re.findall(r"^\| `(\w+)` \| (yes|no) \| (<=|>=) \| ([\d.]+) \| ([^|]+) \|", DOC, re.M)
    assert [r[0] for r in rows] == list(vf.CHECK_IDS)
    for cid, gate, comparison, limit, unit in rows:
        s = vf.CHECKS[cid]
        assert (gate == "yes", comparison, float(limit), unit.strip()) == (s.gate, s.comparison, s.limit, s.unit)
    for field in vf.SCHEMA["properties"]:
        assert f"| `{field}` |" in DOC, field
    for field in vf.SCHEMA["$defs"]["check"]["properties"]:
        assert f"| `{field}` |" in DOC, field
    assert vf.NO_TRUTH in DOC and f"`{vf.SCHEMA_VERSION}`" in DOC
    assert set(VERDICTS) == set(vf.CLAIM_VERDICTS)


def test_help_gives_the_exit_codes_and_allow_failures():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for name in ("run", "report"):
        text = " ".join(sub.choices[name].format_help().split())
        assert "--allow-failures" in text and "exit 0 even when a guarantee check fails" in text
        assert "0 when every evaluated guarantee check of every study passes" in text
        assert "3 when a guarantee check fails" in text and "2 on bad input" in text
        assert "verdict.json" in text and "docs/verdict-file.md" in text


# ------------------------------------------------------------------------------ runs


def test_run_writes_a_passing_verdict_file(ok_run, tmp_path, capsys):
    """e_max = 6 N m holds at the truth (numpy), the OBE contains the truth (numpy): every
    guarantee check passes, the paper claims are not evaluated (no RLS, no paper claim applies),
    exit 0; the file's verdict line is the one printed."""
    path, r = ok_run  # the same seed: the same numbers as the run below
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--quiet", "--jobs", "1"]) == 0
    printed = capsys.readouterr()
    doc = _file(out / "vf_ok")
    assert printed.out.splitlines() == [doc["verdict_line"]] and printed.err == ""
    assert doc["study"] == "vf_ok" and doc["data"] == "simulated" and doc["exit_code"] == 0
    worst, over = _truth_ratio(r)
    c = _check(doc, "bound_at_truth")
    assert c["status"] == "pass" and c["value"] == pytest.approx(worst, rel=1e-12) and worst <= 1.0
    assert c["details"]["rows_over"] == over == 0 and c["details"]["n_rows"] == 1600
    obe = r.estimates[("OBE-factorized", "filtered_dynamic")]
    assert _in_ellipsoid(obe, r.model.theta_true)
    c = _check(doc, "truth_in_guaranteed_sets")
    assert c["status"] == "pass" and c["value"] == 0
    assert c["details"]["sets"] == [{"label": "OBE-factorized", "contains_truth": True}]
    for cid in GATES:
        assert _check(doc, cid)["status"] == "pass", cid
    assert _check(doc, "gamma_star")["value"] == pytest.approx(r.exact.gamma_star)
    assert _check(doc, "bound_margin")["value"] == pytest.approx(1.0 / r.exact.gamma_star)
    assert _check(doc, "physical_bounds_contain_truth")["details"]["n_parameters"] == 9
    claims_check = _check(doc, "paper_claims")
    assert claims_check["status"] == "not_evaluated" and "no paper claim applies" in claims_check["reason"]
    assert _check(doc, "estimator_failures")["status"] == "pass"


def test_a_guaranteed_set_missing_the_truth_exits_3(tmp_path, capsys):
    """e_max = 3 N m: broken at the truth (numpy), and the OBE, skipping the rows that contradict
    it, misses the truth (numpy). `boundid report` over it and the passing study exits 3 and names
    it on stderr, both files written; `boundid run --allow-failures` exits 0 and still says it."""
    studies = tmp_path / "studies"
    studies.mkdir()
    _study(studies, "vf_ok", 6.0)
    bad = _study(studies, "vf_broken", 3.0)
    out = tmp_path / "out"
    assert main(["report", "--studies", str(studies), "--out", str(out), "--quiet", "--jobs", "1"]) == 3
    printed = capsys.readouterr()
    assert [line.split(":")[0] for line in printed.out.splitlines()] == ["vf_broken", "vf_ok"]
    assert printed.err.startswith("boundid: guarantee check failed: vf_broken (bound_at_truth, "
                                  "truth_in_guaranteed_sets") and printed.err.strip().endswith("exit 3")
    assert _file(out / "vf_ok")["exit_code"] == 0
    doc = _file(out / "vf_broken")
    assert doc["exit_code"] == 3 and doc["verdict_line"].startswith("vf_broken: ATTENTION: ")
    assert {"bound_at_truth", "truth_in_guaranteed_sets", "gamma_star"} <= set(doc["failed_gates"])

    r = run_study(load_study(bad))  # the same seed: the numbers of the report's run
    worst, over = _truth_ratio(r)
    c = _check(doc, "bound_at_truth")
    assert c["value"] == pytest.approx(worst, rel=1e-12) and worst > 1.0
    assert c["details"]["rows_over"] == over > 0
    obe = r.estimates[("OBE-factorized", "filtered_dynamic")]
    assert obe.kind == "guaranteed" and obe.n_outliers > 0 and not _in_ellipsoid(obe, r.model.theta_true)
    c = _check(doc, "truth_in_guaranteed_sets")
    assert c["status"] == "fail" and c["value"] == 1
    assert c["details"]["sets"] == [{"label": "OBE-factorized", "contains_truth": False}]
    assert "no guarantee applies" in c["summary"] and "the truth lies OUTSIDE OBE-factorized" in doc["verdict_line"]
    # no certificate and no physical bounds when the data contradict the bound: not evaluated, never pass
    for cid in ("guaranteed_sets_contain_polytope", "physical_bounds_contain_truth"):
        c = _check(doc, cid)
        assert c["status"] == "not_evaluated" and "contradict the bound" in c["reason"], c
    failures = _check(doc, "estimator_failures")
    assert not failures["gate"] and failures["status"] == "fail"
    assert failures["details"]["failures"][0]["stage"] == "exact optima"

    assert main(["run", str(bad), "--out", str(tmp_path / "explore"), "--quiet", "--jobs", "1",
                 "--allow-failures"]) == 0
    printed = capsys.readouterr()
    assert printed.out.startswith("vf_broken: ATTENTION: ") and len(printed.out.splitlines()) == 1
    assert "vf_broken (bound_at_truth" in printed.err and printed.err.strip().endswith("exit 0 (--allow-failures)")
    assert _file(tmp_path / "explore" / "vf_broken")["exit_code"] == 3


def test_a_set_that_misses_the_truth_under_a_bound_that_holds_fails(ok_run, tmp_path):
    """The bound holds at the truth, but the OBE set is moved 3 semi-axes off it (as a faulty
    estimator would leave it): the truth lies outside it (numpy), the truth check fails, the
    verdict says so and the exit code is 3."""
    _, r = ok_run
    key = ("OBE-factorized", "filtered_dynamic")
    obe = r.estimates[key]
    shift = r.model.theta_true + 3.0 * np.linalg.cholesky(obe.set.shape)[:, 0] - obe.set.center
    moved = replace(obe, set=Ellipsoid(obe.set.center + shift, obe.set.shape), center=obe.center + shift,
                    intervals=(obe.intervals[0] + shift, obe.intervals[1] + shift))
    broken = replace(r, estimates={**r.estimates, key: moved})
    assert moved.guaranteed and not _in_ellipsoid(moved, r.model.theta_true)
    doc = _valid(json.loads(json.dumps(vf.verdict_document(broken, run_verdict(broken).line))))
    assert _check(doc, "bound_at_truth")["status"] == "pass"
    assert _check(doc, "truth_in_guaranteed_sets")["status"] == "fail" and doc["exit_code"] == 3
    assert vf.exit_code([doc]) == 3 and vf.exit_code([_valid(vf.verdict_document(r, run_verdict(r).line))]) == 0
    v = run_verdict(broken)
    assert not v.ok and v.truth_inside is False and "the truth lies OUTSIDE OBE-factorized (of 1" in v.line
    path = vf.write_verdict_file(broken, tmp_path, run_verdict(broken).line)
    assert _valid(vf.read_verdict_file(path)) == doc


RULE = """
[[estimators]]
method = "obe"
label = "OBE"
regressions = ["filtered_dynamic"]

[[estimators]]
method = "wls"
regressions = ["filtered_dynamic"]

[exact]
regression = "filtered_dynamic"
{bound}
"""


def test_measured_data_never_pass_a_truth_check(tmp_path, capsys):
    """The simulated run's recording as measured data, with the rule e_max = 2 gamma*: the truth
    checks are not evaluated ("measured data: no truth", value null), gamma* is 0.5 e_max and the
    margin the rule's factor 2; exit 0. With a number 0.8 gamma*, the data contradict the bound:
    gamma* 1.25 e_max, margin 0.8, both fail and the exit code is 3, the truth checks still not
    evaluated."""
    head = tiny_study("vf_measured", 3)
    _, sim = run_study_text(tmp_path, "sim", head + RULE.format(bound="e_max = 1.0"))
    text = measured_twin(head + RULE.format(bound='e_max_rule = { factor = 2.0, scaling = "one" }'), sim, tmp_path)
    study = tmp_path / "vf_measured.toml"
    study.write_text(text)
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), "--quiet", "--jobs", "1"]) == 0
    assert capsys.readouterr().err == ""
    doc = _file(out / "vf_measured")
    assert doc["data"] == "measured" and doc["exit_code"] == 0
    for cid in ("bound_at_truth", "truth_in_guaranteed_sets", "physical_bounds_contain_truth"):
        c = _check(doc, cid)
        assert (c["status"], c["value"], c["reason"]) == ("not_evaluated", None, vf.NO_TRUTH), c
    assert _check(doc, "paper_claims")["status"] == "not_evaluated"
    g = _check(doc, "gamma_star")
    assert g["status"] == "pass" and g["value"] == pytest.approx(0.5, rel=1e-6)
    m = _check(doc, "bound_margin")
    assert m["status"] == "pass" and m["value"] == 2.0
    assert m["details"]["basis"] == "rule" and m["details"]["rule"] == {"factor": 2.0, "scaling": "one"}
    assert _check(doc, "guaranteed_sets_contain_polytope")["status"] == "pass"

    one = g["details"]["gamma_star_one"]
    _, r = run_study_text(tmp_path, "vf_low", text.replace('e_max_rule = { factor = 2.0, scaling = "one" }',
                                                           f"e_max = {0.8 * one!r}"))
    doc = _valid(json.loads(json.dumps(vf.verdict_document(r, run_verdict(r).line))))
    assert doc["exit_code"] == 3 and doc["failed_gates"] == ["gamma_star", "bound_margin"]
    assert _check(doc, "gamma_star")["value"] == pytest.approx(1.25, rel=1e-6)
    assert _check(doc, "bound_margin")["value"] == pytest.approx(0.8, rel=1e-6)
    assert _check(doc, "bound_margin")["details"]["basis"] == "consistency LP"
    for cid in ("bound_at_truth", "truth_in_guaranteed_sets", "physical_bounds_contain_truth"):
        assert _check(doc, cid)["reason"] == vf.NO_TRUTH


def test_paper_claim_counts_are_the_claims_verdicts(tmp_path):
    """RLS on the direct-drive paper's three regression models, no [exact] table: the claims are
    counted per verdict word (every word present), the value is the number not reproduced, not a
    gate; every check on the exact polytope is not evaluated, and the run exits 0."""
    text = tiny_study("vf_claims", 5, ("filtered_dynamic", "supplied_energy", "filtered_power")) + """
[[estimators]]
method = "rls"
label = "RLS"
regressions = ["filtered_dynamic", "supplied_energy", "filtered_power"]
"""
    _, r = run_study_text(tmp_path, "vf_claims", text)
    found = claims(r)
    assert found
    doc = _valid(json.loads(json.dumps(vf.verdict_document(r, run_verdict(r).line))))
    c = _check(doc, "paper_claims")
    counts = Counter(x.verdict for x in found)
    assert c["details"]["counts"] == {v: counts.get(v, 0) for v in VERDICTS}
    assert c["value"] == counts.get("not reproduced", 0) and not c["gate"]
    assert [x["claim"] for x in c["details"]["claims"]] == [x.claim for x in found]
    for cid in ("bound_at_truth", "truth_in_guaranteed_sets", "guaranteed_sets_contain_polytope",
                "physical_bounds_contain_truth", "gamma_star", "bound_margin"):
        assert _check(doc, cid)["reason"] == "the study has no [exact] regression", cid
    assert doc["exit_code"] == 0
