"""verdict.json: the checks of one study run as strict JSON, with a schema, and the exit code they give.

``boundid run`` and ``boundid report`` write ``verdict.json`` beside ``results.csv`` in every study
folder (:func:`write_verdict_file`, called by
:func:`boundid.report.study_page.write_study_report`) and exit with :func:`exit_code` of the files
they wrote. Every check is answered from the run's own result objects
(:class:`~boundid.studies.runner.StudyResult`), nothing recomputed but containment tests:

=================================  =====  ==========================================================
id                                 gate   value (pass when value <= limit, or >= for bound_margin)
=================================  =====  ==========================================================
bound_at_truth                     yes    max |y - W theta_true| / e_max on the exact rows (<= 1)
truth_in_guaranteed_sets           yes    guaranteed sets on the exact rows that miss the truth (0)
guaranteed_sets_contain_polytope   yes    certified guaranteed sets that miss the polytope (0)
physical_bounds_contain_truth      yes    parameters whose physical interval misses the truth (0)
gamma_star                         yes    gamma* in multiples of e_max, the consistency LP (<= 1)
bound_margin                       yes    e_max / gamma*; a rule's factor (>= 1)
paper_claims                       no     claims whose verdict is "not reproduced" (0)
estimator_failures                 no     failures the run recorded (0)
=================================  =====  ==========================================================

A check is "pass" or "fail" only when it was evaluated; otherwise "not_evaluated" with the reason
(measured data: "measured data: no truth"; no [exact] regression; a stage that failed ...) and a
null value: a check never passes unjudged. A gate check that fails makes the commands exit 3
(:data:`EXIT_GUARANTEE`, as ``boundid certify`` does when the ellipsoid misses the polytope); the
other two are reported only (a paper claim not reproduced is a finding, and an estimator that
breaks down, such as the standard-form OBE of the direct-drive study, is shown, not gated).
The format is :data:`SCHEMA` (JSON Schema, draft 2020-12), described in docs/verdict-file.md.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from boundid import __version__
from boundid.errors import RUN_FAILURES, InputError
from boundid.studies.reproduction import VERDICTS as CLAIM_VERDICTS
from boundid.studies.reproduction import claims
from boundid.studies.reproduction import counts as claim_counts
from boundid.studies.reproduction import summary as claims_summary

FILE_NAME = "verdict.json"
SCHEMA_NAME = "boundid-verdict"
SCHEMA_VERSION = 2
#: the reason of every truth check on measured data
NO_TRUTH = "measured data: no truth"
#: exit codes: every evaluated gate check passes (or --allow-failures); a gate check fails
EXIT_OK, EXIT_GUARANTEE = 0, 3
STATUSES = ("pass", "fail", "not_evaluated")


class Spec(NamedTuple):
    """What a check's value is: ``gate`` (a fail makes the commands exit 3), pass when
    ``value <comparison> limit``, the value's unit and its meaning (one sentence, written into the file)."""

    gate: bool
    comparison: str
    limit: float | int
    unit: str
    meaning: str


CHECKS: dict[str, Spec] = {
    "bound_at_truth": Spec(
        True, "<=", 1.0, "x e_max",
        "max_k |y_k - w_k^T theta_true| / e_max_k over the exact regression's rows: <= 1 when the error bound "
        "holds at the simulator's truth, the condition under which every guaranteed set must contain it"),
    "truth_in_guaranteed_sets": Spec(
        True, "<=", 0, "count",
        "guaranteed sets on the exact regression that do not contain the simulator's truth"),
    "guaranteed_sets_contain_polytope": Spec(
        True, "<=", 0, "count",
        "certified guaranteed sets on the exact regression that miss part of the exact feasible polytope "
        "(every vertex checked for p <= 6; else the 2p vertices where the exact LP bounds are reached, a "
        "necessary condition)"),
    "physical_bounds_contain_truth": Spec(
        True, "<=", 0, "count",
        "parameters whose physically consistent exact interval does not contain the simulator's value"),
    "gamma_star": Spec(
        True, "<=", 1.0, "x e_max",
        "gamma* in multiples of the study's bound: the smallest factor of e_max (row by row, in its proportions) "
        "that some parameter vector of the prior box satisfies on every row (the consistency LP); <= 1: the data "
        "respect the bound, > 1: they contradict it and no guaranteed set exists"),
    "bound_margin": Spec(
        True, ">=", 1.0, "x gamma*",
        "e_max / gamma*: how many times the smallest bound the data allow (in e_max's row proportions) the "
        "study's bound is; for an [exact] e_max_rule its factor (e_max = factor x gamma* by construction), "
        "otherwise 1 / the gamma_star check's value"),
    "paper_claims": Spec(
        False, "<=", 0, "count",
        "paper claims (boundid.studies.reproduction.claims) whose verdict is 'not reproduced'; details.counts "
        "gives the number of each verdict (a claim that holds by construction is not counted as reproduced)"),
    "estimator_failures": Spec(
        False, "<=", 0, "count",
        "failures the run recorded (estimators, exact optima, physical consistency, validation, re-simulation), "
        "listed in details; a failure of the page itself (a figure) is not counted"),
}
CHECK_IDS = tuple(CHECKS)


@dataclass(frozen=True)
class Check:
    """One check: ``status`` one of :data:`STATUSES`; ``value`` None when not evaluated, then
    ``reason`` says why; ``summary``: the result in words; ``details``: the numbers behind it."""

    id: str
    status: str
    value: float | int | None
    summary: str
    reason: str | None = None
    details: dict = field(default_factory=dict)

    @property
    def spec(self) -> Spec:
        return CHECKS[self.id]

    @property
    def failed_gate(self) -> bool:
        return self.spec.gate and self.status == "fail"

    def to_json(self) -> dict:
        s = self.spec
        return {"id": self.id, "status": self.status, "gate": s.gate, "value": self.value, "limit": s.limit,
                "comparison": s.comparison, "unit": s.unit, "meaning": s.meaning, "summary": self.summary,
                "reason": self.reason, "details": self.details}


def _number(x) -> float | None:
    """A float for strict JSON: None (null) for NaN or an infinity."""
    x = float(x)
    return x if math.isfinite(x) else None


def _judged(cid: str, value: float | int, summary: str, details: dict | None = None) -> Check:
    """An evaluated check; its status follows from value, limit and comparison (and nothing else).
    A count stays an integer."""
    s = CHECKS[cid]
    ok = value <= s.limit if s.comparison == "<=" else value >= s.limit
    value = int(value) if isinstance(value, int | np.integer) else float(value)
    return Check(cid, "pass" if ok else "fail", value, summary, None, details or {})


def _unjudged(cid: str, reason: str, details: dict | None = None) -> Check:
    return Check(cid, "not_evaluated", None, f"not evaluated: {reason}", reason, details or {})


def _simulated(r) -> bool:
    return r.config.experiment.source == "simulate"


def _no_exact(r) -> str | None:
    """Why the checks on the exact polytope cannot be judged, or None when they can."""
    if r.config.exact.regression is None:
        return "the study has no [exact] regression"
    if r.exact is None:
        return "the exact stage failed (see estimator_failures)"
    return None


def _sets_on_exact(r, kind: str) -> dict:
    return {lab: e for (lab, rn), e in r.estimates.items() if rn == r.exact.regression and e.kind == kind}


# ------------------------------------------------------------------------------ the checks


def bound_at_truth(r) -> Check:
    cid = "bound_at_truth"
    if not _simulated(r):
        return _unjudged(cid, NO_TRUTH)
    if (why := _no_exact(r)) is not None:
        return _unjudged(cid, why)
    ex = r.exact
    if not math.isfinite(ex.truth_error_ratio):
        return _unjudged(cid, "the equation error at the truth was not computed")
    n_rows = r.regressions[ex.regression].n_rows
    details = {"rows_over": int(ex.truth_violations), "n_rows": int(n_rows), "e_max": ex.bound_text()}
    word = "holds" if ex.truth_error_ratio <= 1.0 else "is BROKEN"
    return _judged(cid, ex.truth_error_ratio,
                   f"the bound {word} at the truth: max |error| = {ex.truth_error_ratio:.3g} x e_max, "
                   f"{ex.truth_violations} of {n_rows} rows over e_max = {ex.bound_text()}", details)


def truth_in_guaranteed_sets(r) -> Check:
    cid = "truth_in_guaranteed_sets"
    if not _simulated(r):
        return _unjudged(cid, NO_TRUTH)
    if (why := _no_exact(r)) is not None:
        return _unjudged(cid, why)
    truth = r.model.theta_true
    unverified = sorted(_sets_on_exact(r, "unverified"))
    sets = _sets_on_exact(r, "guaranteed")
    if not sets:
        return _unjudged(cid, "no guaranteed set on the exact regression", {"unverified_sets": unverified})
    inside = {lab: bool(e.contains(truth)) for lab, e in sets.items()}
    missed = [lab for lab, ok in inside.items() if not ok]
    details = {"sets": [{"label": lab, "contains_truth": ok} for lab, ok in inside.items()],
               "exact_polytope_contains_truth": bool(r.exact.polytope.contains(truth)),
               "unverified_sets": unverified}
    if not missed:
        summary = f"every guaranteed set ({len(sets)}) contains the truth"
    else:
        summary = f"the truth lies OUTSIDE {', '.join(missed)} (of {len(sets)} guaranteed sets)"
        if r.exact.truth_violations:
            summary += "; the bound is broken at the truth, so no guarantee applies"
    return _judged(cid, len(missed), summary, details)


def guaranteed_sets_contain_polytope(r) -> Check:
    cid = "guaranteed_sets_contain_polytope"
    if (why := _no_exact(r)) is not None:
        return _unjudged(cid, why)
    ex = r.exact
    sets = _sets_on_exact(r, "guaranteed")
    unverified = sorted(_sets_on_exact(r, "unverified"))
    rows = []
    for lab in sets:
        c = ex.certificates.get(lab)
        rows.append({"label": lab, "certified": c is not None,
                     "contains_polytope": None if c is None else bool(c.contains_polytope),
                     "vertex_kind": None if c is None else str(c.vertex_kind),
                     "vertices_checked": None if c is None else int(c.n_vertices),
                     "vertices_outside": None if c is None else int(c.n_outside),
                     "max_gauge": None if c is None else _number(c.max_gauge)})
    details = {"sets": rows, "unverified_sets": unverified}
    if not sets:
        return _unjudged(cid, "no guaranteed set on the exact regression", details)
    outside = [row["label"] for row in rows if row["contains_polytope"] is False]
    missing = [row["label"] for row in rows if not row["certified"]]
    if missing and not outside:
        cause = ("the data contradict the bound, so no certificate was computed" if not ex.consistent
                 else "their certificates failed (see estimator_failures)")
        return _unjudged(cid, f"{', '.join(missing)} not certified: {cause}", details)
    lp_only = any(row["vertex_kind"] not in (None, "all") for row in rows)
    how = " (checked at the 2p LP-bound vertices, a necessary condition)" if lp_only else ""
    if outside:
        summary = f"{', '.join(outside)} MISS(ES) part of the exact polytope{how}"
        if missing:
            summary += f"; {', '.join(missing)} not certified"
    else:
        summary = f"all {len(rows)} guaranteed sets contain the exact polytope{how}"
    return _judged(cid, len(outside), summary, details)


def physical_bounds_contain_truth(r) -> Check:
    cid = "physical_bounds_contain_truth"
    if not _simulated(r):
        return _unjudged(cid, NO_TRUTH)
    if (why := _no_exact(r)) is not None:
        return _unjudged(cid, why)
    ex = r.exact
    ph = ex.physical
    if ph is None:
        failed = [f for f in r.failures if f.stage == "physical consistency"]
        if failed:
            return _unjudged(cid, "the physical-consistency stage failed (see estimator_failures)")
        if ex.bounds is None:
            return _unjudged(cid, "the exact LP bounds were not computed"
                             + (" (the data contradict the bound)" if not ex.consistent else ""))
        return _unjudged(cid, "the robot model states no physical constraints")
    if ph.error is not None:
        return _unjudged(cid, "the physically consistent bounds were not computed (see estimator_failures)")
    inside = ph.intervals["truth_inside"]
    outside = [str(name) for name, v in inside.items() if isinstance(v, str) and v == "no"]
    details = {"parameters_outside": outside, "n_parameters": int(len(inside))}
    summary = (f"the physically consistent intervals of all {len(inside)} parameters contain the truth"
               if not outside else
               f"the truth lies OUTSIDE the physically consistent intervals of {len(outside)} of {len(inside)} "
               f"parameters ({', '.join(outside)})" + ("; the bound is broken at the truth, so no guarantee "
                                                       "applies" if ex.truth_violations else ""))
    return _judged(cid, len(outside), summary, details)


def _gamma_details(ex) -> dict:
    ev = ex.evidence
    return {"e_max": ex.bound_text(), "unit": ex.unit,
            "gamma_star_one": None if ev is None else _number(ev.one),
            "gamma_star_per_joint": None if ev is None else _number(ev.per_joint),
            "gamma_star_scaled": None if ev is None else _number(ev.scaled)}


def gamma_star(r) -> Check:
    cid = "gamma_star"
    if (why := _no_exact(r)) is not None:
        return _unjudged(cid, why)
    ex = r.exact
    if not math.isfinite(ex.gamma_star):
        return _unjudged(cid, "the consistency LP failed (see estimator_failures)", _gamma_details(ex))
    if ex.consistent:
        summary = f"the data respect the bound: gamma* = {ex.gamma_star:.3g} x e_max"
    else:
        summary = (f"the data CONTRADICT the bound: the bounds must grow {ex.gamma_star:.3g}x; no guaranteed set "
                   "exists")
    return _judged(cid, ex.gamma_star, summary, _gamma_details(ex))


def bound_margin(r) -> Check:
    cid = "bound_margin"
    if (why := _no_exact(r)) is not None:
        return _unjudged(cid, why)
    ex = r.exact
    rule = None if ex.rule is None else {"factor": float(ex.rule.factor), "scaling": ex.rule.scaling}
    details = {"basis": "rule" if rule else "consistency LP", "rule": rule, "e_max": ex.bound_text()}
    if rule is not None:
        return _judged(cid, rule["factor"], f"e_max = {ex.rule.describe()}: {rule['factor']:g} x the smallest bound "
                       "the data allow", details)
    if not math.isfinite(ex.gamma_star):
        return _unjudged(cid, "the consistency LP failed (see estimator_failures)", details)
    if ex.gamma_star <= 0:
        return _unjudged(cid, "gamma* is 0 (a parameter vector fits every row exactly): the margin is infinite, "
                         "which JSON cannot hold", details)
    margin = 1.0 / ex.gamma_star
    return _judged(cid, margin, f"e_max = {ex.bound_text()} is {margin:.3g} x the smallest bound the data allow",
                   details)


def paper_claims(r) -> Check:
    cid = "paper_claims"
    if not _simulated(r):
        return _unjudged(cid, "measured data: the papers' claims are about their own experiments")
    try:
        found = claims(r)
    except RUN_FAILURES as exc:
        return _unjudged(cid, f"the paper verdicts failed: {type(exc).__name__}: {exc}")
    if not found:
        return _unjudged(cid, f"no paper claim applies to this study (the {r.config.robot} robot has no paper, or the "
                         "study runs none of the estimators its paper's claims are about)")
    counts = claim_counts(found)
    details = {"counts": counts, "claims": [asdict(c) for c in found]}
    return _judged(cid, counts["not reproduced"], claims_summary(found), details)


def estimator_failures(r) -> Check:
    fails = [{"stage": f.stage, "subject": f.subject, "reason": f.reason} for f in r.failures]
    by_stage: dict[str, int] = {}
    for f in r.failures:
        by_stage[f.stage] = by_stage.get(f.stage, 0) + 1
    summary = "no failures" if not fails else (
        f"{len(fails)} failure{'s' * (len(fails) > 1)}: " + "; ".join(f"{f.stage} {f.subject}" for f in r.failures))
    return _judged("estimator_failures", len(fails), summary, {"failures": fails, "by_stage": by_stage})


CHECK_FUNCTIONS = (bound_at_truth, truth_in_guaranteed_sets, guaranteed_sets_contain_polytope,
                   physical_bounds_contain_truth, gamma_star, bound_margin, paper_claims, estimator_failures)


def checks(r) -> list[Check]:
    """Every check of the study result ``r``, in the order of :data:`CHECK_IDS`."""
    return [fn(r) for fn in CHECK_FUNCTIONS]


# ------------------------------------------------------------------------------ the file


def verdict_document(r, line: str) -> dict:
    """The content of verdict.json for the study result ``r`` and its verdict ``line``
    (:func:`boundid.report.verdict.run_verdict`, which reads these checks) (strict JSON: numbers,
    null, strings)."""
    found = checks(r)
    failed = [c.id for c in found if c.failed_gate]
    return _plain({"schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION, "study": r.config.name,
                   "data": "simulated" if _simulated(r) else "measured", "boundid_version": __version__,
                   "verdict_line": line, "exit_code": EXIT_GUARANTEE if failed else EXIT_OK,
                   "failed_gates": failed, "checks": [c.to_json() for c in found]})


def _plain(x):
    """numpy scalars and arrays as Python numbers and lists (NaN, infinities: null)."""
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, list | tuple | np.ndarray):
        return [_plain(v) for v in x]
    if isinstance(x, bool | np.bool_):
        return bool(x)
    if isinstance(x, int | np.integer):
        return int(x)
    if isinstance(x, float | np.floating):
        return _number(x)
    return x


def write_verdict_file(r, folder: str | Path, line: str) -> Path:
    """Write ``folder/verdict.json`` for the study result ``r`` and its verdict ``line``; its path."""
    path = Path(folder) / FILE_NAME
    text = json.dumps(verdict_document(r, line), indent=2, ensure_ascii=False, allow_nan=False)
    path.write_text(text + "\n", encoding="utf-8")
    return path


def read_verdict_file(path: str | Path) -> dict:
    """A verdict.json as written (strict JSON: NaN or Infinity refused)."""
    def bad(name):
        raise InputError(f"{path}: not strict JSON ({name})")
    return json.loads(Path(path).read_text(encoding="utf-8"), parse_constant=bad)


def exit_code(documents) -> int:
    """The exit code of ``boundid run`` / ``report`` for their studies' verdict documents: 3 when a
    gate check failed in any of them, else 0."""
    return EXIT_GUARANTEE if any(d["failed_gates"] for d in documents) else EXIT_OK


# ------------------------------------------------------------------------------ the schema


def _check_schema(cid: str) -> dict:
    s = CHECKS[cid]
    value = {"type": ["integer", "null"]} if s.unit == "count" else _NUM
    return {"allOf": [{"$ref": "#/$defs/check"},
                      {"properties": {"id": {"const": cid}, "gate": {"const": s.gate}, "value": value,
                                      "limit": {"const": s.limit}, "comparison": {"const": s.comparison},
                                      "unit": {"const": s.unit}, "details": {"$ref": f"#/$defs/details_{cid}"}}}]}


def schema_text() -> str:
    """:data:`SCHEMA` as docs/verdict-file.md shows it (indented JSON)."""
    return json.dumps(SCHEMA, indent=2, ensure_ascii=False)


def _obj(props: dict, required: tuple[str, ...] = ()) -> dict:
    return {"type": "object", "additionalProperties": False, "required": list(required), "properties": props}


_STR = {"type": "string"}
_NUM = {"type": ["number", "null"]}
_COUNT = {"type": "integer", "minimum": 0}
_LABELS = {"type": "array", "items": _STR}

#: the JSON Schema (draft 2020-12) of verdict.json, schema_version 2; docs/verdict-file.md shows it
SCHEMA: dict = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "boundid verdict.json",
    "description": "The checks of one study run (boundid.report.verdict_file).",
    **_obj({
        "schema": {"const": SCHEMA_NAME},
        "schema_version": {"const": SCHEMA_VERSION},
        "study": {"type": "string", "minLength": 1},
        "data": {"enum": ["simulated", "measured"]},
        "boundid_version": _STR,
        "verdict_line": _STR,
        "exit_code": {"enum": [EXIT_OK, EXIT_GUARANTEE]},
        "failed_gates": {"type": "array", "uniqueItems": True,
                         "items": {"enum": [c for c, s in CHECKS.items() if s.gate]}},
        "checks": {"type": "array", "minItems": len(CHECKS), "maxItems": len(CHECKS),
                   "prefixItems": [_check_schema(c) for c in CHECKS], "items": False},
    }, ("schema", "schema_version", "study", "data", "boundid_version", "verdict_line", "exit_code",
        "failed_gates", "checks")),
    "$defs": {
        "check": {
            **_obj({"id": {"enum": list(CHECKS)}, "status": {"enum": list(STATUSES)}, "gate": {"type": "boolean"},
                    "value": _NUM, "limit": {"type": "number"}, "comparison": {"enum": ["<=", ">="]},
                    "unit": _STR, "meaning": {"type": "string", "minLength": 1},
                    "summary": {"type": "string", "minLength": 1}, "reason": {"type": ["string", "null"]},
                    "details": {"type": "object"}},
                   ("id", "status", "gate", "value", "limit", "comparison", "unit", "meaning", "summary", "reason",
                    "details")),
            "if": {"properties": {"status": {"const": "not_evaluated"}}},
            "then": {"properties": {"value": {"type": "null"}, "reason": {"type": "string", "minLength": 1}}},
            "else": {"properties": {"value": {"type": "number"}, "reason": {"type": "null"}}},
        },
        "details_bound_at_truth": _obj({"rows_over": _COUNT, "n_rows": _COUNT, "e_max": _STR}),
        "details_truth_in_guaranteed_sets": _obj({
            "sets": {"type": "array", "items": _obj({"label": _STR, "contains_truth": {"type": "boolean"}},
                                                    ("label", "contains_truth"))},
            "exact_polytope_contains_truth": {"type": "boolean"}, "unverified_sets": _LABELS}),
        "details_guaranteed_sets_contain_polytope": _obj({
            "sets": {"type": "array", "items": _obj({
                "label": _STR, "certified": {"type": "boolean"}, "contains_polytope": {"type": ["boolean", "null"]},
                "vertex_kind": {"type": ["string", "null"]}, "vertices_checked": {"type": ["integer", "null"]},
                "vertices_outside": {"type": ["integer", "null"]}, "max_gauge": _NUM},
                ("label", "certified", "contains_polytope", "vertex_kind", "vertices_checked", "vertices_outside",
                 "max_gauge"))},
            "unverified_sets": _LABELS}),
        "details_physical_bounds_contain_truth": _obj({"parameters_outside": _LABELS, "n_parameters": _COUNT}),
        "details_gamma_star": _obj({"e_max": _STR, "unit": _STR, "gamma_star_one": _NUM,
                                    "gamma_star_per_joint": _NUM, "gamma_star_scaled": _NUM}),
        "details_bound_margin": _obj({
            "basis": {"enum": ["rule", "consistency LP"]},
            "rule": {"oneOf": [{"type": "null"}, _obj({"factor": {"type": "number", "minimum": 1},
                                                       "scaling": _STR}, ("factor", "scaling"))]},
            "e_max": _STR}),
        "details_paper_claims": _obj({
            "counts": _obj({v: _COUNT for v in CLAIM_VERDICTS}, CLAIM_VERDICTS),
            "claims": {"type": "array", "items": _obj(
                {"id": _STR, "section": _STR, "claim": _STR, "paper": _STR, "method": _STR, "ours": _STR,
                 "verdict": {"enum": list(CLAIM_VERDICTS)}, "reason": _STR, "others": _STR},
                ("id", "section", "claim", "paper", "method", "ours", "verdict", "reason", "others"))}}),
        "details_estimator_failures": _obj({
            "failures": {"type": "array", "items": _obj({"stage": _STR, "subject": _STR, "reason": _STR},
                                                        ("stage", "subject", "reason"))},
            "by_stage": {"type": "object", "additionalProperties": _COUNT}}),
    },
}
