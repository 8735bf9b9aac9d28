"""The closing verdict of a study run: one line that says whether its guarantees stand.

Three questions, answered from the run's own result objects (:class:`~boundid.studies.runner.StudyResult`
and its :class:`~boundid.studies.runner.ExactResult`), nothing recomputed:

1. Does the error bound hold at the truth? (simulated data: max_k |y_k - w_k^T theta_true| / e_max <= 1,
   ``ExactResult.truth_error_ratio``; measured data, whose truth is unknown: are the data consistent
   with the bound, gamma* <= 1.) Only when it holds must a guaranteed set contain the truth.
2. Are the guarantees verified? Every guaranteed set on the exact regression contains the exact
   feasible polytope (``ExactResult.certificates[label].contains_polytope``).
3. Were there failures? (``StudyResult.failures``: estimators, exact optima, validation.)

and, named in the line only when it fails: does the truth lie in every guaranteed set and every
physically consistent interval (simulated data; the truth checks of ``verdict.json``,
:mod:`boundid.report.verdict_file`, which holds every check with its value and limit).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class Verdict:
    """The answers for one run; ``ok`` when the bound holds (or cannot be judged), every
    checked guaranteed set contains the polytope, no set or physically consistent interval misses the
    truth and nothing failed. ``line`` is the sentence."""

    bound_holds: bool | None  # None: not judged (no exact regression, or the consistency LP failed)
    guarantees_verified: bool | None  # None: no guaranteed set was certified
    n_failures: int
    line: str
    truth_inside: bool | None = None  # None: not judged (measured data, no exact regression, no set)

    @property
    def ok(self) -> bool:
        return (self.bound_holds is not False and self.guarantees_verified is not False
                and self.truth_inside is not False and self.n_failures == 0)


def _bound(r) -> tuple[bool | None, str]:
    ex = r.exact
    if ex is None:
        return None, "bound not checked (the study has no [exact] regression)"
    if r.config.experiment.source == "simulate" and np.isfinite(ex.truth_error_ratio):
        if ex.truth_error_ratio <= 1.0:
            return True, f"the bound holds at the truth (max |error| = {ex.truth_error_ratio:.3g} x e_max)"
        n_rows = r.regressions[ex.regression].n_rows
        return False, (f"the bound does NOT hold at the truth ({ex.truth_violations} of {n_rows} rows over e_max, "
                       f"max {ex.truth_error_ratio:.3g} x e_max): no set is guaranteed to contain the truth")
    if not np.isfinite(ex.gamma_star):
        return None, "bound not checked (the consistency LP failed)"
    if ex.consistent:
        gs = "" if ex.evidence is None else f" (gamma* = {ex.evidence.one:.3g} {ex.evidence.unit})"
        margin = "" if ex.rule is not None else f", {1.0 / ex.gamma_star:.3g} x the smallest the data allow{gs}"
        return True, (f"truth unknown (measured data): e_max = {ex.bound_text()}{margin}; what follows holds only if "
                      "every row's error is within it")
    tail = ""
    if ex.outliers is not None:
        o = ex.outliers
        tail = f"; at least {o.lower_bound} row{'s' * (o.lower_bound != 1)} must go{' (proven)' if o.proven else ''}"
    return False, (f"the data contradict the bound (the bounds must grow {ex.gamma_star:.3g}x): no guaranteed set "
                   "exists" + tail)


def _guarantees(r) -> tuple[bool | None, str]:
    ex = r.exact
    guaranteed = [lab for (lab, reg), e in r.estimates.items() if e.guaranteed
                  and ex is not None and reg == ex.regression]
    unverified = sorted({lab for (lab, _), e in r.estimates.items() if e.kind == "unverified"})
    tail = f"; {len(unverified)} set(s) unverified by their estimator ({', '.join(unverified)})" if unverified else ""
    if not guaranteed:
        return None, "no guaranteed set to verify" + tail
    if not ex.consistent:
        return None, "no exact polytope to verify the guaranteed sets against (it is empty)" + tail
    certified = {lab: ex.certificates[lab] for lab in guaranteed if lab in ex.certificates}
    missing = [lab for lab in guaranteed if lab not in certified]
    outside = [lab for lab, c in certified.items() if not c.contains_polytope]
    lp_only = any(c.vertex_kind != "all" for c in certified.values())
    how = " (checked at the 2p LP-bound vertices, a necessary condition)" if lp_only else ""
    if outside:
        return False, (f"guarantees NOT verified: {', '.join(outside)} miss(es) part of the exact polytope"
                       + (f"; {', '.join(missing)} not certified" if missing else "") + tail)
    if missing:
        return None, (f"{len(certified)} of {len(guaranteed)} guaranteed sets contain the exact polytope{how}; "
                      f"{', '.join(missing)} not certified" + tail)
    return True, f"guarantees verified: all {len(certified)} guaranteed sets contain the exact polytope{how}" + tail


def _failures(r) -> str:
    if not r.failures:
        return "no failures"
    what = "; ".join(f"{f.stage} {f.subject}" for f in r.failures[:3]) + ("; ..." if len(r.failures) > 3 else "")
    return f"{len(r.failures)} failure{'s' * (len(r.failures) > 1)} ({what}; see the page's last section)"


def _truth_outside(r, bound: bool | None) -> tuple[bool | None, str]:
    """(truth inside, words): the truth checks of verdict.json (and, for simulated data whose bound
    holds at the truth, its gamma* check: the data contradict the bound only when the truth lies
    outside the prior box); words only when one fails."""
    from boundid.report import verdict_file as vf

    found = [vf.truth_in_guaranteed_sets(r), vf.physical_bounds_contain_truth(r)]
    if bound is True and r.config.experiment.source == "simulate":
        found.append(vf.gamma_star(r))
    failed = [c.summary for c in found if c.status == "fail"]
    if failed:
        return False, "; ".join(failed)
    return (True if any(c.status == "pass" for c in found[:2]) else None), ""


def run_verdict(r) -> Verdict:
    """The verdict of the study result ``r`` (a :class:`~boundid.studies.runner.StudyResult`)."""
    bound, bound_text = _bound(r)
    verified, verified_text = _guarantees(r)
    inside, outside_text = _truth_outside(r, bound)
    v = Verdict(bound, verified, len(r.failures), "", inside)
    line = (f"{r.config.name}: {'OK' if v.ok else 'ATTENTION'}: {bound_text}; {verified_text}; "
            + (f"{outside_text}; " if outside_text else "") + f"{_failures(r)}.")
    return replace(v, line=line)
