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
    IDENTIFIED,
    NARROWED,
    CriteriaComparison,
    ExcitationDesign,
)

#: the picks' colours (Okabe-Ito, as the report's series): first draw, guaranteed, cond, logdet
_COLORS = {"first draw": "#999999", "guaranteed": "#0072B2", "cond": "#D55E00", "logdet": "#009E73"}
_MARKERS = {"first draw": "o", "guaranteed": "s", "cond": "^", "logdet": "v"}

CRITERIA_TEXT = ("The guaranteed criterion scores a trajectory by its design set D = {d : |W d| <= e_max, |d_j| <= "
                 "r_j} (r the prior half-widths): the exact set when the errors are zero and the truth is at the "
                 "prior's centre; for any errors within the bound the exact set lies within the truth + 2 D, so twice "
                 "the design width bounds every exact interval the trajectory can leave. Score: the mean over "
                 "parameters of the design width over the prior width, by exact LP bounds (lower is better). The "
                 "classical criteria: cond(W) with unit-norm columns (lower is better) and ln det of (W R)^T (W R), "
                 "R = diag(r) (D-optimality, higher is better).")


def _pct(x: float) -> str:
    return f"{100 * x:.3g} %"


def design_section(page: Page, design: ExcitationDesign) -> None:
    """The search that chose a study's excitation: its criterion, budget, family and every
    candidate's scores, the chosen one marked."""
    s, st = design.search, design.settings
    k = design.chosen
    sc = s.scores.copy()
    sc.insert(0, "chosen", ["yes" if i == k else "" for i in sc.index])
    sc = sc.rename(columns={"guaranteed": "mean design width / prior", "cond": "cond(W)", "logdet": "ln det"})
    failed = (f" {len(s.failed)} draws were refused and replaced (first: {s.failed[0][1]})." if s.failed else "")
    page.section("Excitation designed before the experiment",
                 f"The identification run's excitation is candidate {k} of {len(s.candidates)}, the best by the "
                 f"{design.criterion} criterion ({CRITERIA[design.criterion][0]}). Candidates: {design.family}; each "
                 f"scored on its design regression (the inverse-dynamic rows of its noise-free motion at "
                 f"{st.rate_hz:g} Hz, the [exact] bound, the prior box), drawn from the study's seed on a stream of "
                 f"their own, so the same file gives the same choice. Search budget: {st.candidates} candidates, "
                 f"{design.time_s:.1f} s.{failed} {CRITERIA_TEXT}")
    page.table(sc, "Every candidate of the search: the three criteria, its rows and the time to draw and score it [s].",
               name="excitation_search")


def _width_figure(cmp: CriteriaComparison) -> Figure:
    """Design widths (guaranteed) and exact widths (the simulated recording) per parameter, one marker per pick."""
    p = len(cmp.names)
    fig = Figure(figsize=(min(13.0, 3.0 + 0.32 * p), 4.4), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    x = np.arange(p)
    for ax, kind, what in ((axes[0], "design", "design width / prior width (guaranteed)"),
                           (axes[1], "exact", "exact width / prior width (one recording)")):
        w = cmp.widths(kind)
        for j, label in enumerate(w.columns):
            ax.plot(x + (j - 1.5) * 0.12, w[label].to_numpy(), _MARKERS.get(label, "o"), color=_COLORS.get(label),
                    ms=5, label=label, alpha=0.9)
        ax.axhline(1.0, color="#444444", lw=0.8, ls=":")
        ax.set_ylabel(what, fontsize=9)
        ax.set_yscale("log")
    axes[1].set_xticks(x, cmp.names, rotation=90 if p > 12 else 0, fontsize=8)
    axes[0].legend(loc="lower right", fontsize=8, ncols=4)
    return fig


def _study_findings(cmp: CriteriaComparison) -> list[str]:
    """What the comparison of one study found, in sentences computed from it."""
    sm = cmp.summary()
    best_exact = sm["exact width"].idxmin()
    widths = ", ".join(f"{label} {_pct(sm.loc[label, 'design width'])}" for label in sm.index)
    same = [c for c in ("cond", "logdet") if sm.loc[c, "candidate"] == sm.loc["guaranteed", "candidate"]]
    agree = (f" ({' and '.join(same)} picked the same trajectory as the guaranteed criterion)" if same else "")
    g = sm.loc["guaranteed"]
    out = [f"{cmp.study}: mean design width of each pick at {cmp.bound}, over the prior width: {widths}{agree}; "
           f"the guaranteed pick identifies {g['identified']} of {len(cmp.names)} parameters; on the recordings the "
           f"smallest mean exact width is {best_exact}'s ({_pct(sm.loc[best_exact, 'exact width'])})."]
    never = cmp.never_narrowed()
    k = len(cmp.design.search.candidates)
    if never:
        out.append(f"{cmp.study}: even the {k} candidates' rows together leave {', '.join(never)} at "
                   f"{_pct(NARROWED)} of the prior width or more at {cmp.bound} (design widths), so no candidate "
                   "tried narrows them: bounding them needs another excitation family, a smaller bound or prior "
                   "knowledge.")
    elif cmp.pooled is not None:
        out.append(f"{cmp.study}: the {k} candidates' rows together narrow every parameter (largest pooled "
                   f"design width {_pct(float(cmp.pooled.max()))} of the prior).")
    return out


def excitation_page(comparisons: list[CriteriaComparison]) -> Page:
    """The criteria side by side, one section per study (nothing written)."""
    findings = [f for c in comparisons for f in _study_findings(c)]
    page = Page("Excitation design: guaranteed against classical criteria",
                "For each study, candidate excitations of its own experiment are scored by three criteria: the "
                "guaranteed one (the exact design set's widths at the study's bound) and the classical cond(W) and "
                "ln det W^T W. Each criterion's best is then recorded at the study's row rate and bounded exactly, "
                "by the study's OBE and by WLS, so the page shows which parameters each criterion's trajectory "
                "identifies at the bound.",
                setup={"studies": ", ".join(c.study for c in comparisons),
                       "recordings": f"errors uniform within {ERROR_FRACTION:g} x the bound, the same draw for every "
                                     "pick (seeded by the study)",
                       "identified": f"twice the design width below {IDENTIFIED:g} x the prior width: narrowed by "
                                     "every recording within the bound",
                       "narrowed": f"exact width below {NARROWED:g} x the prior width on the recording"})
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
                       "(design: guaranteed; exact, OBE, WLS: on the recording), and how many of the "
                       f"{len(cmp.names)} parameters it identifies (twice the design width below the prior width: "
                       "narrowed by any recording within the bound) and narrows on its recording, and those it does "
                       "not identify.",
                   name=f"{cmp.study}_summary")
        page.figure(_width_figure(cmp), "Per parameter, each pick's width over the prior width: the design width "
                                        "(top; twice it bounds every exact interval the trajectory can leave) and the "
                                        "exact width on the recording (bottom); dotted: the prior width.",
                    name=f"{cmp.study}_widths")
        per = pd.concat([cmp.widths(kind).add_prefix(f"{kind} · ") for kind in ("design", "exact", "obe", "wls")],
                        axis=1)
        if cmp.pooled is not None:
            per.insert(0, "design · all candidates' rows", cmp.pooled)
        page.section(f"{cmp.study}: every parameter", folded=f"the {len(cmp.names)} parameters' widths over their "
                                                             "prior widths, for each pick")
        page.table(per, "Widths over the prior widths per parameter: design (guaranteed; first, of all the "
                        "candidates' rows together, at the search's rate), exact (LP bounds of the "
                        "recording), OBE and WLS (95 %), one column per pick.", name=f"{cmp.study}_parameters")
    return page


def write_excitation_page(comparisons: list[CriteriaComparison], out: str | Path) -> Path:
    """Write ``<out>/index.html`` (replaced as a whole) and return it."""
    page = excitation_page(comparisons)
    with replace_folder(Path(out)) as tmp:
        page.write(tmp / "index.html")
    return Path(out) / "index.html"
