"""The front matter of the site index (``reports/index.html``): what boundid is, what the studies found,
the papers it reproduces. :func:`boundid.report.html.write_site_index` puts it above the list of pages.

Everything it says about the studies is read from their files, by the run that writes the index:

- :func:`study_width_ratios` reads a study's ``results.csv``: for each guaranteed set on the exact
  regression, the mean over the parameters of its interval width ``hi - lo`` (the raw set, as the
  file holds it) over the exact LP width of that parameter: the "mean width / exact" of the
  certificate table of the study's page. :func:`width_ratios_across_studies` does it for every
  study and says why a study is left out (no results.csv, no exact LP bounds, no guaranteed set).
- :func:`width_ratio_figure` draws these numbers, one group per study, one marker per set family
  (:func:`set_family`) in the report's palette (:func:`boundid.report.figures.series_styles`), on
  a log axis; the index embeds it as PNG and writes :data:`FIGURE_NAME` ``.png``, ``.svg`` and
  ``.csv`` beside itself (removed again when no study has both).
- :func:`read_findings` reads each study's ``verdict.json`` (docs/verdict-file.md): its data, its
  verdict line, its paper claims and the gate checks that failed.
- :func:`front_matter` is the HTML: the paragraph on the suite, the findings in a few computed
  sentences, the figure, the findings table and the papers cited in full
  (:func:`boundid.report.glossary.full_reference`).
"""

from __future__ import annotations

import base64
import html
import io
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib import rc_context
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

from boundid.errors import InputError
from boundid.report.figures import DPI, MAX_WIDTH_IN, REFERENCE_STYLES, _figure, _figure_legend, series_styles
from boundid.report.glossary import (
    GLOSSARY_PAGE,
    REFERENCES_PAGE,
    Linker,
    full_reference,
    reference_anchor,
)
from boundid.report.output import write_file_atomically
from boundid.report.verdict_file import FILE_NAME as VERDICT_FILE
from boundid.report.verdict_file import read_verdict_file

#: the figure's files beside the site index: <name>.png, <name>.svg and <name>.csv (its numbers)
FIGURE_NAME = "set-width-ratios"
RESULTS_FILE = "results.csv"

#: the papers boundid reproduces, each with the robot of the study that does
PAPERS = (("H4Paper", "H4 parallel robot"), ("DirectDrivePaper", "two-link direct-drive arm"))

SUITE = ("boundid is a reference and comparison suite for robot dynamic identification. Given a robot's "
         "measured motion and torques, it computes which dynamic parameters (inertias, masses, friction) are "
         "consistent with the data under a bound on the torque error. It puts the recursive estimators people "
         "use, the bounded-error sets (OBE in standard and square-root form, box, parallelotope, zonotope, "
         "limited polytope) and RLS, WLS and Kalman, beside the exact optima they approximate: the LP bounds of "
         "the feasible polytope, SDP ellipsoids and physically consistent bounds. It reproduces two papers on "
         "simulated data (cited below), runs on any arm given as a URDF, and on measured recordings such as "
         "the Staubli TX40's.")

#: the set families in the order the figure places them in every group (others follow, as found)
FAMILY_ORDER = ("OBE-standard", "OBE-factorized", "OBE ∩ prior box", "Box", "Parallelotope", "Zonotope",
                "Limited polytope")

_NEEDED = ("estimator", "method", "regression", "parameter", "lo", "hi", "kind")


def set_family(method: str) -> str:
    """The family of a set estimator from its ``method`` in results.csv, its settings left out:
    "OBE-factorized (volume)" -> "OBE-factorized", "Limited polytope (K = 56 strips, ...)" ->
    "Limited polytope", "Box recursion" -> "Box"."""
    name = re.sub(r"\s*\(.*\)\s*$", "", str(method)).strip()
    return re.sub(r"\s+recursion$", "", name) or str(method)


def study_width_ratios(results_csv: str | Path) -> pd.DataFrame | str:
    """Each guaranteed set's mean interval width over the exact LP width, from one study's results.csv.

    Returns a DataFrame, one row per guaranteed set on the exact regression: ``family``
    (:func:`set_family`; "family (estimator)" when a study has two sets of one family),
    ``estimator``, ``method``, ``regression``, ``n_parameters`` (those with a finite set width and a
    positive exact width) and ``mean_width_over_exact`` = mean over them of (hi - lo) / (LP hi - LP lo).
    Or, when the study has no such number, the reason in words.
    """
    path = Path(results_csv)
    if not path.is_file():
        return f"no {RESULTS_FILE}"
    try:
        df = pd.read_csv(path)
    except (OSError, ValueError) as exc:  # pandas' parser errors are ValueErrors
        return f"its {RESULTS_FILE} cannot be read ({type(exc).__name__})"
    missing = [c for c in _NEEDED if c not in df.columns]
    if missing:
        return f"its {RESULTS_FILE} has no {', '.join(missing)} column{'s' if len(missing) > 1 else ''}"
    df = df.assign(lo=pd.to_numeric(df["lo"], errors="coerce"), hi=pd.to_numeric(df["hi"], errors="coerce"))
    exact = df[df["kind"] == "exact"]
    if (exact["estimator"] == "LP exact").any():
        exact = exact[exact["estimator"] == "LP exact"]
    if exact.empty:
        return "no exact LP bounds (no [exact] table in its study file, or the exact stage failed)"
    regression = exact["regression"].iloc[0]
    exact = exact[exact["regression"] == regression].drop_duplicates("parameter").set_index("parameter")
    lp_width = exact["hi"] - exact["lo"]
    sets = df[(df["kind"] == "guaranteed") & (df["regression"] == regression)]
    if sets.empty:
        return f"no guaranteed set on the exact regression ({regression})"
    rows = []
    for estimator, d in sets.groupby("estimator", sort=False):
        d = d.drop_duplicates("parameter").set_index("parameter")
        common = [p for p in lp_width.index if p in d.index]
        width = (d["hi"] - d["lo"]).reindex(common).to_numpy(dtype=float)
        ref = lp_width.reindex(common).to_numpy(dtype=float)
        ok = np.isfinite(width) & np.isfinite(ref) & (ref > 0)
        if not ok.any():
            continue
        rows.append({"family": set_family(d["method"].iloc[0]), "estimator": estimator, "method": d["method"].iloc[0],
                     "regression": regression, "n_parameters": int(ok.sum()),
                     "mean_width_over_exact": float(np.mean(width[ok] / ref[ok]))})
    if not rows:
        return "no parameter with a positive exact LP width and a finite set width"
    out = pd.DataFrame(rows)
    twice = out["family"].duplicated(keep=False)
    out.loc[twice, "family"] = out.loc[twice, "family"] + " (" + out.loc[twice, "estimator"].astype(str) + ")"
    return out


@dataclass
class WidthRatios:
    """The figure's numbers: ``table`` (one row per study and guaranteed set: ``study``, ``data``
    and the columns of :func:`study_width_ratios`) and ``left_out`` ({study: why})."""

    table: pd.DataFrame
    left_out: dict[str, str] = field(default_factory=dict)


def width_ratios_across_studies(root: str | Path, studies: Sequence[str],
                                data: dict[str, str] | None = None) -> WidthRatios:
    """:func:`study_width_ratios` of every study folder ``root/<study>`` in ``studies`` (in that
    order); ``data``: {study: "simulated" or "measured"} (from its verdict.json)."""
    root, data = Path(root), data or {}
    frames, left_out = [], {}
    for study in studies:
        got = study_width_ratios(root / study / RESULTS_FILE)
        if isinstance(got, str):
            left_out[study] = got
        else:
            frames.append(got.assign(study=study, data=data.get(study, "")))
    columns = ["study", "data", "family", "estimator", "method", "regression", "n_parameters",
               "mean_width_over_exact"]
    table = pd.concat(frames, ignore_index=True)[columns] if frames else pd.DataFrame(columns=columns)
    return WidthRatios(table, left_out)


def width_ratio_figure(table: pd.DataFrame) -> Figure:
    """The mean width over the exact LP width of every guaranteed set of ``table`` (the ``table`` of
    :class:`WidthRatios`): one group per study along x, one marker per family at the same place in
    every group (colour and marker from :func:`series_styles`, unique per family), a stem from the
    line at 1 (the exact LP width), log y axis."""
    if table.empty:
        raise InputError("width_ratio_figure needs at least one study with a guaranteed set and exact bounds.")
    studies = list(dict.fromkeys(table["study"]))
    families = _families(table)
    styles = series_styles(families)
    n = len(families)
    step = min(0.8 / n, 0.16)
    offset = {f: (k - (n - 1) / 2) * step for k, f in enumerate(families)}
    width = min(MAX_WIDTH_IN - 0.5, max(5.0, 1.3 + len(studies) * max(1.5, 0.24 * n)))
    fig = _figure(width, 3.1)
    ax = fig.subplots()
    x_of = {s: i for i, s in enumerate(studies)}
    for fam in families:
        rows = table[table["family"] == fam]
        x = np.array([x_of[s] + offset[fam] for s in rows["study"]])
        y = rows["mean_width_over_exact"].to_numpy(dtype=float)
        st = styles[fam]
        ax.vlines(x, 1.0, y, colors=st.color, lw=1.4, alpha=0.55, label="_stem")
        ax.plot(x, y, ls="none", marker=st.marker, ms=7, color=st.color, mec="white", mew=0.6, label=fam)
    ref = REFERENCE_STYLES["LP exact"]
    ax.axhline(1.0, color=ref.color, ls=ref.linestyle, lw=1.0, label="exact LP width (= 1)")
    for i in range(1, len(studies)):
        ax.axvline(i - 0.5, color="#d1d9e0", lw=0.8, label="_separator")
    values = table["mean_width_over_exact"].to_numpy(dtype=float)
    values = values[np.isfinite(values) & (values > 0)]
    lo, hi = (min(0.8, values.min() / 1.3), max(1.25, values.max() * 1.6)) if values.size else (0.5, 2.0)
    ax.set_yscale("log")
    ax.set_ylim(lo, hi)
    ax.yaxis.set_major_locator(LogLocator(10.0, subs=(1.0, 2.0, 5.0) if np.log10(hi / lo) <= 2.5 else (1.0,)))
    ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_xlim(-0.5, len(studies) - 0.5)
    data = table.drop_duplicates("study").set_index("study")["data"]
    labels = [s + ("\n(measured)" if data.get(s) == "measured" else "") for s in studies]
    rotate = len(studies) * 1.5 > width
    ax.set_xticks(range(len(studies)), labels, rotation=90 if rotate else 0)  # upright: no name overlaps the next
    ax.tick_params(axis="x", length=0, labelsize=9)
    ax.tick_params(axis="y", labelsize=9)
    ax.set_ylabel("mean width / exact LP width", fontsize=9.5)
    ax.grid(axis="y", which="major", alpha=0.3)
    handles = [Line2D([], [], ls="none", marker=styles[f].marker, ms=7, color=styles[f].color, mec="white",
                      mew=0.6) for f in families]
    handles.append(Line2D([], [], color=ref.color, ls=ref.linestyle, lw=1.0))
    _figure_legend(fig, handles, [*families, "exact LP width (= 1)"])
    return fig


def _families(table: pd.DataFrame) -> list[str]:
    """The families of ``table`` in :data:`FAMILY_ORDER`, the others after them as found."""
    found = list(dict.fromkeys(table["family"]))
    rank = {f: k for k, f in enumerate(FAMILY_ORDER)}
    return sorted(found, key=lambda f: (rank.get(f, len(rank)), found.index(f)))


def render_figure(fig: Figure) -> tuple[bytes, bytes]:
    """(PNG, SVG) of ``fig`` as :meth:`boundid.report.html.Page.figure` saves a study page's figures:
    the PNG at the report's DPI, the SVG with the PNG's layout and fixed element ids."""
    png, svg = io.BytesIO(), io.BytesIO()
    fig.savefig(png, format="png", dpi=DPI, metadata={"Software": None})
    engine = fig.get_layout_engine()
    fig.set_layout_engine("none")
    try:
        with rc_context({"svg.hashsalt": "boundid"}):
            fig.savefig(svg, format="svg", metadata={"Date": None, "Creator": None})
    finally:
        fig.set_layout_engine(engine)
    return png.getvalue(), svg.getvalue()


@dataclass
class Finding:
    """What one study's verdict.json says: its data, verdict line, paper claims and failed gates."""

    study: str
    data: str
    verdict: str
    paper_claims: str
    failed_gates: list[str]
    not_reproduced: int | None = None
    counts: dict[str, int] = field(default_factory=dict)


def read_findings(root: str | Path, studies: Sequence[str]) -> tuple[list[Finding], dict[str, str]]:
    """(the :class:`Finding` of each study with a readable verdict.json, {study: why not} of the others)."""
    root = Path(root)
    found, missing = [], {}
    for study in studies:
        path = root / study / VERDICT_FILE
        if not path.is_file():
            missing[study] = f"no {VERDICT_FILE}"
            continue
        try:
            doc = read_verdict_file(path)
            checks = {c["id"]: c for c in doc["checks"]}
            claims = checks.get("paper_claims", {})
            line = str(doc["verdict_line"])
            prefix = f"{doc.get('study', study)}: "
            verdict = line[len(prefix):] if line.startswith(prefix) else line
            if claims.get("status") == "not_evaluated":
                text = "not evaluated: " + str(claims.get("reason") or "").split(" (")[0]
                not_reproduced, counts = None, {}
            elif claims:
                text = str(claims.get("summary") or "")
                not_reproduced = int(claims["value"]) if claims.get("value") is not None else None
                counts = {str(k): int(v) for k, v in ((claims.get("details") or {}).get("counts") or {}).items()}
            else:
                text, not_reproduced, counts = "–", None, {}
            found.append(Finding(study, str(doc.get("data", "")), verdict, text, [str(g) for g in doc["failed_gates"]],
                                 not_reproduced, counts))
        except (InputError, ValueError, KeyError, TypeError, AttributeError) as exc:
            missing[study] = f"its {VERDICT_FILE} cannot be read ({type(exc).__name__})"
    return found, missing


# ------------------------------------------------------------------------------------ the HTML
def _p(text: str, cls: str = "") -> str:
    return f'<p{f" class={chr(34)}{cls}{chr(34)}" if cls else ""}>{html.escape(" ".join(text.split()))}</p>'


def _range(lo: float, hi: float) -> str:
    return f"{lo:.3g} x" if f"{lo:.3g}" == f"{hi:.3g}" else f"{lo:.3g}–{hi:.3g} x"


def width_sentence(table: pd.DataFrame) -> str:
    """The figure in one sentence: the tightest family (smallest worst case over the studies) and the
    loosest (largest), with their range over the studies."""
    if table.empty:
        return ""
    g = table.groupby("family", sort=False)["mean_width_over_exact"]
    lo, hi = g.min(), g.max()
    n = table["study"].nunique()
    where = f"over the {n} studies with exact bounds" if n > 1 else f"in {table['study'].iloc[0]}"
    if len(hi) == 1:
        fam = hi.index[0]
        return (f"Guaranteed sets {where}: {fam} is {_range(lo[fam], hi[fam])} the exact LP width "
                "(mean over parameters).")
    tight, loose = hi.idxmin(), hi.idxmax()
    at = table.loc[table[table["family"] == loose]["mean_width_over_exact"].idxmax(), "study"]
    obe = "OBE-factorized"  # the suite's own recursive estimator, said when neither end of the range
    own = f"; {obe} {_range(lo[obe], hi[obe])}" if obe in hi.index and obe not in (tight, loose) else ""
    return (f"Guaranteed sets against the exact LP bounds, {where} (mean width / exact width): the tightest is "
            f"{tight}, {_range(lo[tight], hi[tight])}{own}; the loosest {loose}, up to {hi[loose]:.3g} x ({at}).")


def verdict_sentence(findings: Sequence[Finding]) -> str:
    """The verdict files in one or two sentences: gate checks passed or failed, paper claims."""
    if not findings:
        return ""
    n = len(findings)
    kinds = {k: sum(f.data == k for f in findings) for k in ("simulated", "measured")}
    mix = ", ".join(f"{v} {k}" for k, v in kinds.items() if v)
    failed = [f for f in findings if f.failed_gates]
    if not failed:
        gates = f"{'All ' + str(n) + ' studies pass' if n > 1 else 'The study passes'} every gate check ({mix})."
    else:
        gates = (f"{len(failed)} of {n} stud{'ies' if n > 1 else 'y'} ({mix}) fail{'s' if len(failed) == 1 else ''} "
                 "a gate check: " + "; ".join(f"{f.study} ({', '.join(f.failed_gates)})" for f in failed) + ".")
    tested = [f for f in findings if f.counts]
    if not tested:
        return gates
    total = {k: sum(f.counts.get(k, 0) for f in tested) for k in ("reproduced", "partly", "not reproduced")}
    nots = [f"{f.study} {f.counts.get('not reproduced', 0)}" for f in tested if f.counts.get("not reproduced")]
    claims = (f"Paper claims tested: {total['reproduced']} reproduced, {total['partly']} partly, "
              f"{total['not reproduced']} not reproduced" + (f" ({', '.join(nots)})" if nots else "")
              + "; a claim not reproduced is a finding, not a failed gate.")
    return gates + " " + claims


def _findings_table(findings: Sequence[Finding]) -> str:
    head = ("<thead><tr><th class=\"words\">study</th><th class=\"words\">data</th><th class=\"prose\">verdict</th>"
            "<th class=\"prose\">paper claims</th><th class=\"words\">failed gates</th></tr></thead>")
    rows = []
    for f in findings:
        gates = ", ".join(f.failed_gates) if f.failed_gates else "none"
        rows.append(f'<tr><td class="words"><a href="{html.escape(f.study)}/index.html">{html.escape(f.study)}</a></td>'
                    f'<td class="words">{html.escape(f.data)}</td><td class="prose">{html.escape(f.verdict)}</td>'
                    f'<td class="prose">{html.escape(f.paper_claims)}</td>'
                    f'<td class="words{" fail" if f.failed_gates else ""}">{html.escape(gates)}</td></tr>')
    return (f'<div class="scroll"><table class="data keyed findings-table">{head}<tbody>{"".join(rows)}</tbody>'
            "</table></div>")


def _numbers_table(table: pd.DataFrame) -> str:
    wide = table.pivot_table(index="family", columns="study", values="mean_width_over_exact", sort=False)
    wide = wide.reindex(index=_families(table), columns=list(dict.fromkeys(table["study"])))
    head = "<thead><tr><th>family</th>" + "".join(f"<th>{html.escape(s)}</th>" for s in wide.columns) + "</tr></thead>"
    body = "".join("<tr><td>" + html.escape(str(fam)) + "</td>"
                   + "".join(f"<td>{v:.4g}</td>" if np.isfinite(v) else "<td>–</td>" for v in row) + "</tr>"
                   for fam, row in zip(wide.index, wide.to_numpy(dtype=float), strict=True))
    return f'<div class="scroll"><table class="data keyed">{head}<tbody>{body}</tbody></table></div>'


def _papers_html(root: Path, studies: Sequence[str], refs_linked: bool) -> str:
    """The papers cited in full, each with the study pages that cite it; links to the references
    page (and its anchor) and the glossary when they are written."""
    linker = Linker(None, REFERENCES_PAGE) if refs_linked else None
    items = []
    for key, robot in PAPERS:
        try:
            text = (linker.reference_html(key) if linker is not None
                    else html.escape(full_reference(key)) + html.escape(f" [{key}]"))
        except InputError:  # no docs/references.md (boundid without its checkout)
            text = html.escape(f"[{key}]")
        citing = [s for s in studies if _cites(root / s / "index.html", key)]
        by = (" Reproduced by " + ", ".join(f'<a href="{html.escape(s)}/index.html">{html.escape(s)}</a>'
                                             for s in citing) + ".") if citing else ""
        items.append(f"<li>{html.escape(robot[0].upper() + robot[1:])}: {text}{by}</li>")
    more = ""
    if refs_linked:
        more = (f'<p>Every other work the pages cite is on the <a href="{REFERENCES_PAGE}">references page</a>; '
                f'what the pages\' words mean (gamma*, e_max, the exact polytope, the set families) is in the '
                f'<a href="{GLOSSARY_PAGE}">glossary</a>.</p>')
    return f'<ul class="refs">{"".join(items)}</ul>{more}'


def _cites(page: Path, key: str) -> bool:
    """Whether a study page names the paper ``key`` in full under its headline (``<p class="cites">``)."""
    if not page.is_file():
        return False
    anchor = f"#{reference_anchor(key)}\""
    return any(anchor in m for m in re.findall(r'<p class="cites">(.*?)</p>', page.read_text(encoding="utf-8")))


@dataclass
class FrontMatter:
    """The HTML of the front matter: ``lead`` (the suite and the findings, above the index's nav),
    ``sections`` {anchor: (heading, HTML)} in order, and ``files`` written beside the index."""

    lead: str
    sections: dict[str, tuple[str, str]]
    files: list[Path]
    ratios: WidthRatios | None = None
    description: str = SUITE  # the index's meta description


def front_matter(root: str | Path, studies: Sequence[str], *, refs_linked: bool) -> FrontMatter:
    """The front matter of the site index of ``root`` with study folders ``studies``; writes (or
    removes) the figure's files ``root/<FIGURE_NAME>.{png,svg,csv}``. ``refs_linked``: the
    references and glossary pages are written beside the index (link them)."""
    root = Path(root)
    findings, no_verdict = read_findings(root, studies)
    data = {f.study: f.data for f in findings}
    ratios = width_ratios_across_studies(root, studies, data) if studies else None
    summary = [s for s in (width_sentence(ratios.table) if ratios is not None else "",
                           verdict_sentence(findings)) if s]
    lead = _p(SUITE) + ("<div class=\"findings\">" + "".join(_p(s) for s in summary) + "</div>" if summary else "")
    sections: dict[str, tuple[str, str]] = {}
    files = [root / f"{FIGURE_NAME}.{ext}" for ext in ("png", "svg", "csv")]
    if ratios is not None and not ratios.table.empty:
        fig = width_ratio_figure(ratios.table)
        png, svg = render_figure(fig)
        write_file_atomically(root / f"{FIGURE_NAME}.png", png)
        write_file_atomically(root / f"{FIGURE_NAME}.svg", svg)
        write_file_atomically(root / f"{FIGURE_NAME}.csv", ratios.table.to_csv(index=False))
        out = [f"{s} ({why})" for s, why in ratios.left_out.items()]
        caption = ("Each guaranteed set's mean interval width over the exact LP width, per study: for every "
                   "parameter, the width hi − lo of the set's interval (the raw set, as results.csv holds it) over "
                   "the width of the exact LP interval on the same regression, averaged over the parameters, the "
                   "\"mean width / exact\" of each study page's certificate table. 1 is as tight as the exact "
                   "bounds; a guaranteed set that contains the feasible polytope (its certificate is on the study "
                   "page) is never below. Log scale; one marker per set family, at the same place in every group.")
        caption += (" Left out: " + "; ".join(out) + ".") if out else " Every study is shown."
        img = base64.b64encode(png).decode("ascii")
        body = (f'<figure class="fig" id="fig-{FIGURE_NAME}"><img src="data:image/png;base64,{img}" '
                f'alt="{html.escape(caption)}"><figcaption><b>Figure.</b> {html.escape(caption)}'
                f'<span class="files"><a href="{FIGURE_NAME}.png">PNG</a> · <a href="{FIGURE_NAME}.svg">SVG</a> · '
                f'<a href="{FIGURE_NAME}.csv">CSV</a></span></figcaption></figure>'
                f'<details class="fold"><summary>The numbers</summary>{_numbers_table(ratios.table)}</details>')
        sections["set-widths"] = ("Guaranteed sets against the exact bounds", body)
    else:
        for f in files:
            f.unlink(missing_ok=True)
        files = []
    if findings:
        note = ("One row per study, from its verdict.json (docs/verdict-file.md): the verdict line boundid run "
                "prints, the paper claims (reported, never gated) and the gate checks that failed, which make "
                "boundid exit 3.")
        if no_verdict:
            note += " Not listed: " + "; ".join(f"{s} ({why})" for s, why in no_verdict.items()) + "."
        sections["findings"] = ("What each study found", _p(note) + _findings_table(findings))
    sections["papers"] = ("Papers reproduced", _papers_html(root, studies, refs_linked))
    return FrontMatter(lead, sections, files, ratios)
