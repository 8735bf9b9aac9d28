"""The excitation design on the pages: the three criteria side by side (reports/excitation/) and, on a
study page, the search that chose the study's excitation.

Every number comes from :mod:`boundid.studies.excitation` (the searches and the picks' recordings),
computed by the run that writes the page.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from boundid.experiments.excitation_design import CRITERIA
from boundid.report.html import Page
from boundid.report.output import replace_folder
from boundid.studies.excitation import (
    ERROR_FRACTION,
    NARROWED,
    CriteriaComparison,
    ExcitationDesign,
)

#: the picks' colours (Okabe-Ito, as the report's series): first draw, guaranteed, cond, logdet
_COLORS = {"first draw": "#999999", "guaranteed": "#0072B2", "cond": "#D55E00", "logdet": "#009E73"}
_MARKERS = {"first draw": "o", "guaranteed": "s", "cond": "^", "logdet": "v"}

CRITERIA_TEXT = ("The guaranteed criterion scores a trajectory by its design set D = {d : |W d| <= e_max, |d_j| <= "
                 "r_j}, W the design regression (the inverse-dynamic rows of the trajectory's noise-free motion), r "
                 "the prior half-widths: D is the exact set, about the truth, when the errors are zero and the truth "
                 "is at the prior's centre; for any errors within the bound and any truth in the prior box the exact "
                 "set of those rows lies within the truth + 2 D, so twice the design width bounds every exact "
                 "interval they can leave. (A study's own exact set is built from other rows, measured and "
                 "filtered, and its own regression model: the design is a guide to it, not a bound on it.) Score: "
                 "the mean over parameters of the design width over the prior width, by exact LP bounds (lower is "
                 "better). The classical criteria: cond(W) with unit-norm columns (lower is better) and ln det of "
                 "(W R)^T (W R), R = diag(r) (D-optimality, higher is better).")


def _pct(x: float) -> str:
    return f"{100 * x:.3g} %"


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def design_section(page: Page, design: ExcitationDesign) -> None:
    """The search that chose a study's excitation: its criterion, budget, family, which candidate
    each criterion prefers and every candidate's scores, the chosen one marked."""
    s, st = design.search, design.settings
    k = design.chosen
    sc = s.scores.copy()
    sc.insert(0, "chosen", ["yes" if i == k else "" for i in sc.index])
    sc = sc.rename(columns={"guaranteed": "mean design width / prior", "cond": "cond(W)", "logdet": "ln det"})
    failed = (f" {len(s.failed)} draws were refused and replaced (first: {s.failed[0][1]})." if s.failed else "")
    others = "; ".join(f"{c} would pick candidate {s.best(c)}" for c in CRITERIA if c != design.criterion)
    page.section("Excitation designed before the experiment",
                 f"The identification run's excitation is candidate {k} of {len(s.candidates)}, the best by the "
                 f"{design.criterion} criterion ({CRITERIA[design.criterion][0]}); {others}. Candidates: "
                 f"{design.family}; each scored on its design regression (the inverse-dynamic rows of its noise-free "
                 f"motion at {st.rate_hz:g} Hz, the [exact] bound, the prior box; not this study's exact regression, "
                 f"which is built from the recording), drawn from the study's seed on a stream of their own, so the "
                 f"same file gives the same choice. Search budget: {_plural(st.candidates, 'candidate')}, "
                 f"{design.time_s:.1f} s.{failed} {CRITERIA_TEXT}")
    page.table(sc, "Every candidate of the search: the three criteria, its rows and the time to draw and score it [s].",
               name="excitation_search")


def _width_figure(cmp: CriteriaComparison) -> Figure:
    """Design widths (guaranteed) and exact widths (the simulated recording) per parameter, one marker per pick."""
    p = len(cmp.names)
    fig = Figure(figsize=(min(13.0, 4.0 + 0.32 * p), 5.0), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    x = np.arange(p)
    for ax, kind, what in ((axes[0], "design", "design width\n/ prior width"),
                           (axes[1], "exact", "exact width\n/ prior width")):
        w = cmp.widths(kind)
        for j, label in enumerate(w.columns):
            ax.plot(x + (j - 1.5) * 0.12, w[label].to_numpy(), _MARKERS.get(label, "o"), color=_COLORS.get(label),
                    ms=5, label=label, alpha=0.9)
        ax.axhline(1.0, color="#444444", lw=0.8, ls=":")
        ax.set_ylabel(what, fontsize=9)
        ax.set_yscale("log")
    axes[1].set_xticks(x, cmp.names, rotation=90 if p > 12 else 0, fontsize=8)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside upper center", fontsize=9, ncols=4)
    return fig


def _study_findings(cmp: CriteriaComparison) -> list[str]:
    """What the comparison of one study found, in sentences computed from it."""
    sm = cmp.summary()
    k = sm.loc["guaranteed", "candidate"]
    same = [c for c in ("first draw", "cond", "logdet") if sm.loc[c, "candidate"] == k]
    agree = f" ({' and '.join(same)}: the same trajectory as the guaranteed pick)" if same else ""
    search = ", ".join(f"{label} {_pct(sm.loc[label, 'design width (search)'])}" for label in sm.index)
    full = ", ".join(f"{label} {_pct(sm.loc[label, 'design width'])}" for label in sm.index)
    best_exact = sm["exact width"].idxmin()
    g = sm.loc["guaranteed"]
    out = [f"{cmp.study}: mean design width over the prior width at {cmp.bound}, on the search's rows "
           f"({cmp.design.settings.rate_hz:g} Hz, what the picks were chosen by): {search}{agree}; at the study's "
           f"{cmp.rate_hz:g} Hz: {full}. The guaranteed pick narrows {g['narrowed for certain']} of "
           f"{len(cmp.names)} parameters for certain; on the recordings the smallest mean exact width is "
           f"{best_exact}'s ({_pct(sm.loc[best_exact, 'exact width'])})."]
    weak = cmp.not_guaranteed()
    n = len(cmp.design.search.candidates)
    if weak:
        out.append(f"{cmp.study}: no candidate tried guarantees to narrow {', '.join(weak)}: even the "
                   f"{_plural(n, 'candidate')}' rows together leave them at {_pct(NARROWED)} of the prior width or "
                   f"more when the errors are zero (bound {cmp.bound}), so some data within the bound do not narrow "
                   "them; a guarantee for them needs another excitation family, a smaller bound or prior knowledge "
                   "(a recording whose errors are not zero may still narrow them: see its exact widths).")
    elif cmp.pooled is not None:
        out.append(f"{cmp.study}: the {_plural(n, 'candidate')}' rows together narrow every parameter for certain "
                   f"(largest design width {_pct(float(cmp.pooled.max()))} of the prior).")
    return out


def excitation_page(comparisons: list[CriteriaComparison]) -> Page:
    """The criteria side by side, one section per study (nothing written)."""
    findings = [f for c in comparisons for f in _study_findings(c)]
    page = Page("Excitation design: guaranteed against classical criteria",
                "For each study, candidate excitations of its own experiment are scored by three criteria: the "
                "guaranteed one (the exact design set's widths at the study's bound) and the classical cond(W) and "
                "ln det W^T W. Each criterion's best is then recorded at the study's row rate and bounded exactly, "
                "by the study's OBE and by WLS, so the page shows which parameters each criterion's trajectory "
                "narrows for certain at the bound, and which none of the candidates can.",
                setup={"studies": ", ".join(c.study for c in comparisons),
                       "recordings": f"errors uniform within {ERROR_FRACTION:g} x the bound, the same draw for every "
                                     "pick (seeded by the study)",
                       "first draw": "the search's first candidate, a random member of the study's family: "
                                     "not the study's own excitation",
                       "narrowed for certain": f"twice the design width below {NARROWED:g} x the prior width: "
                                               "narrowed by every recording of the design rows within the bound",
                       "narrowed on the recording": f"exact width below {NARROWED:g} x the prior width"},
                glossary=True)
    page.findings(findings)
    page.section("The criteria", CRITERIA_TEXT)
    for cmp in comparisons:
        d = cmp.design
        sm = cmp.summary()
        page.section(f"{cmp.study}: {cmp.title}",
                     f"Candidates: {d.family}. Search: {d.settings.candidates} candidates at "
                     f"{d.settings.rate_hz:g} Hz, "
                     f"{d.time_s:.1f} s; the picks recorded at {cmp.rate_hz:g} Hz ({cmp.picks[0].rows} rows), bound "
                     f"{cmp.bound}; OBE: the study's {cmp.obe_label or 'none'}, WLS: its {cmp.wls_label or 'none'} "
                     f"(95 % intervals). {cmp.time_s:.1f} s for the picks.")
        page.table(sm, "Each pick: the criteria's values on its search rows, the mean widths over the prior widths "
                       "(design: the zero-error exact set of the pick's rows at the study's rate; exact, OBE, WLS: on "
                       "the recording; OBE is an ellipsoid around the prior box, so its intervals can be wider than "
                       "the prior; WLS gives 95 % confidence intervals, not guaranteed ones), how many of the "
                       f"{len(cmp.names)} parameters it narrows for certain and on its recording, and those it does "
                       "not narrow for certain.",
                   name=f"{cmp.study}_summary")
        page.figure(_width_figure(cmp), "Per parameter, each pick's width over the prior width: the design width "
                                        "(top; twice it bounds every exact interval of the pick's design rows "
                                        "within the bound) and the exact width on the recording (bottom); dotted: "
                                        "the prior width.",
                    name=f"{cmp.study}_widths")
        per = pd.concat([cmp.widths(kind).add_prefix(f"{kind} · ") for kind in ("design", "exact", "obe", "wls")],
                        axis=1)
        if cmp.pooled is not None:
            per.insert(0, f"design · all candidates' rows ({cmp.design.settings.rate_hz:g} Hz)", cmp.pooled)
        page.section(f"{cmp.study}: every parameter", folded=f"the {len(cmp.names)} parameters' widths over their "
                                                             "prior widths, for each pick")
        page.table(per, "Widths over the prior widths per parameter: first the design width of all the "
                        "candidates' rows together at the search's rate, then per pick, at the study's rate, the "
                        "design width (zero errors), the exact width (LP bounds of the recording), OBE and WLS (95 "
                        "%).", name=f"{cmp.study}_parameters")
    return page


def write_excitation_page(comparisons: list[CriteriaComparison], out: str | Path) -> Path:
    """Write ``<out>/index.html`` (replaced as a whole) and return it."""
    page = excitation_page(comparisons)
    with replace_folder(Path(out)) as tmp:
        page.write(tmp / "index.html")
    return Path(out) / "index.html"
