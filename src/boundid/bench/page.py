"""The benchmark page ``<out>/index.html``: every goal met or missed, from the CSVs alone.

:func:`write_page` reads ``<topic>.csv`` (the rows a benchmark module wrote) and ``<topic>.json``
(the machine it ran on, see :func:`boundid.bench.goals.machine`) for every topic it finds in the
folder, judges the module's ``GOAL_CHECKS`` on them and writes one self-contained page: a summary
of the verdicts, one table of every goal (measured value, target, the case's size, the load when it
ran, the verdict), and per topic its description (Markdown, :func:`markdown_html`), machine and
full table (folded); then every other Markdown report in the folder (``mutation.md``,
``platforms.md``), rendered. No link names a folder (:func:`local_href`). Nothing is measured
here: ``python -m boundid.bench --page-only`` rebuilds the page from the files.
"""

from __future__ import annotations

import functools
import html
import importlib
import json
import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import pandas as pd
from markdown_it import MarkdownIt

from boundid.bench.goals import Goal, Verdict, judge
from boundid.report.html import Page, render_page, site_header
from boundid.report.output import write_file_atomically

NOT_MEASURED = "not measured"
_STATUS_CLASS = {"met": "met", "met on CPU time only": "cpu", "missed": "missed", NOT_MEASURED: "none"}

_CSS = """
.keypoints { border-left: 4px solid var(--accent); background: #eef6fb; padding: .6rem 1rem; margin: 1rem 0;
             border-radius: 0 6px 6px 0; }
td.met { color: #006d4e; font-weight: 600; } td.missed { color: #b33c00; font-weight: 700; }
td.cpu { color: #8a5a00; font-weight: 600; } td.none { color: var(--muted); font-style: italic; }
table.data td.met, table.data td.missed, table.data td.cpu { text-align: left; }
table.data td.text { text-align: left; white-space: normal; min-width: 9rem; }
table.data td:first-child.text { min-width: 15rem; }
table.data thead th { text-align: left; }
.cpu-time { font-size: .8rem; color: var(--muted); }
details.raw > summary { cursor: pointer; color: var(--muted); font-weight: 600; margin: .6rem 0; }
p.machine { font-size: .9rem; color: var(--muted); }
div.goals { font-size: .92rem; background: var(--bg-alt); padding: .3rem .9rem; border-radius: 6px; }
div.goals li { margin: .2rem 0; max-width: 80ch; }
"""

def topic_module(topic: str):
    """The benchmark module ``boundid.bench.bench_<topic>``, or None if there is none."""
    try:
        return importlib.import_module(f"boundid.bench.bench_{topic}")
    except ModuleNotFoundError:
        return None


def _fmt(v) -> str:
    """A table cell: 4 significant digits, "not measured" for an empty number, text as is."""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return f"{v:,}"
    if isinstance(v, float):
        if not math.isfinite(v):
            return NOT_MEASURED
        return f"{v:,.0f}" if v.is_integer() and abs(v) < 1e15 else f"{v:.4g}"
    return "" if v is None else str(v)


def _value(v: float | None, unit: str) -> str:
    """A measured value or target with its unit: "0.913x", "1.5 s", "3.83 M samples/s"."""
    if v is None:
        return ""
    return f"{v:.3g}x" if unit == "x" else f"{v:.3g} {unit}".rstrip()


def _table(header: Sequence[str], rows: Sequence[Sequence[tuple[str, str]]]) -> str:
    """HTML table in the report style; cells are (text, css class) pairs, text already escaped."""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f'<td class="{c}">{t}</td>' if c else f"<td>{t}</td>" for t, c in row)
                   + "</tr>" for row in rows)
    return (f'<div class="scroll"><table class="data"><thead><tr>{head}</tr></thead>'
            f"<tbody>{body}</tbody></table></div>")


def _machine_text(meta: Mapping | None, topic: str) -> str:
    if not meta:
        return (f"Machine not recorded: {topic}.csv was written before the benchmark runner stored it "
                f"(run <code>make bench</code>, or <code>python -m boundid.bench --only {html.escape(topic)}</code>).")
    v = meta.get("versions", {})
    libs = ", ".join(f"{k} {v[k]}" for k in ("numpy", "numba", "highspy", "clarabel") if k in v)
    load = meta.get("load_avg") or [math.nan]
    when = f"run {meta['started']}" + (f" in {meta['elapsed_s']:.0f} s" if "elapsed_s" in meta else "") \
        if "started" in meta else "run"
    quick = " with --quick (smaller sizes)" if meta.get("quick") else ""
    return html.escape(f"{when}{quick} on {meta.get('cpu', '?')}, {meta.get('cores', '?')} cores, load average "
                       f"{load[0]:.2f} (1 min) at the start; {meta.get('system', '')}, Python "
                       f"{v.get('python', '?')}, {libs}.")


_ROLE = re.compile(r":(?:py:)?(?:func|meth|class|mod|attr|data|obj|exc|const|ref|doc):`~?([^`]+)`")
_EXTERNAL = re.compile(r"^([a-z][a-z0-9+.-]*:|//|#)", re.I)  # a scheme (https:, mailto:), //host or #anchor


@functools.cache
def _markdown() -> MarkdownIt:
    """CommonMark with tables; raw HTML in the text is shown as text, never passed through."""
    return MarkdownIt("commonmark", {"html": False}).enable(["table", "strikethrough"])


def local_href(href: str, folder: Path | None) -> str | None:
    """The link ``href`` of a page in ``folder`` as it should be written, or None when it must not be
    a link: a folder (an href ending in "/", or naming a folder beside the page) opens as a page only
    through its index.html, so it becomes ``<folder>/index.html`` when there is one and None when
    there is not (a static site shows a folder link as nothing useful). Other hrefs are kept."""
    if not href or _EXTERNAL.match(href):
        return href
    path = re.split(r"[?#]", href, maxsplit=1)[0]
    is_dir = path.endswith("/") or (folder is not None and path not in ("", ".") and (folder / path).is_dir())
    if path in ("", "."):
        return href
    if not is_dir:
        return href
    index = path.rstrip("/") + "/index.html"
    return index if folder is not None and (folder / index).is_file() else None


def markdown_html(text: str, folder: Path | None = None, *, shift: int = 0) -> str:
    """Markdown text (a benchmark's GOALS, a report's .md) as HTML in the page's style.

    CommonMark with tables (markdown-it-py): inline code, bold, italics, links, lists, headings,
    tables. A reST role (``:func:`name```, ``:class:``, ...) is shown as the code ``name``; headings
    go ``shift`` levels down (h1 -> h(1 + shift), at most h6); tables get the report's style; a link
    to a folder is rewritten by :func:`local_href` (its index.html, or plain text when it has none).
    """
    md = _markdown()
    tokens = md.parse(_ROLE.sub(lambda m: f"`{m.group(1)}`", text))
    for tok in tokens:
        if tok.type in ("heading_open", "heading_close"):
            tok.tag = f"h{min(6, int(tok.tag[1:]) + shift)}"
        elif tok.type == "table_open":
            tok.attrSet("class", "data")
        if tok.children:
            kept, dropping = [], False
            for child in tok.children:
                if child.type == "link_open":
                    href = local_href(str(child.attrGet("href") or ""), folder)
                    dropping = href is None
                    if dropping:
                        continue
                    child.attrSet("href", href)
                elif child.type == "link_close" and dropping:
                    dropping = False
                    continue
                kept.append(child)
            tok.children = kept
    out = md.renderer.render(tokens, md.options, {})
    return out.replace('<table class="data">', '<div class="scroll"><table class="data">').replace(
        "</table>", "</table></div>")


def _title_and_body(text: str) -> tuple[str, str]:
    """A Markdown report's first-level heading (its title) and the text after it."""
    m = re.match(r"\s*#\s+(.+?)\s*#*\s*\n", text + "\n")
    return (m.group(1), text[m.end():]) if m else ("", text)


def verdict_row(topic: str, v: Verdict) -> list[tuple[str, str]]:
    """goal, verdict, measured, target, case, load: the cells of one goal (escaped HTML)."""
    g = v.goal
    measured = html.escape(_value(v.value, g.unit)) or "–"
    if v.cpu_value is not None:
        measured += f'<br><span class="cpu-time">CPU time: {html.escape(_value(v.cpu_value, g.unit))}</span>'
    status = v.status if v.status != NOT_MEASURED else f"{NOT_MEASURED}: {v.reason}"
    return [(f"<b>{html.escape(topic)}</b>: {html.escape(g.name)}", "text"),
            (html.escape(status), _STATUS_CLASS[v.status] + (" text" if v.status == NOT_MEASURED else "")),
            (measured, ""), (html.escape(f"{g.op} {_value(g.target, g.unit)}"), ""), (html.escape(v.size), "text"),
            (f"{v.load:.2f}" if v.load is not None else "–", "")]


def verdicts_markdown(verdicts: Sequence[Verdict]) -> str:
    """The verdicts of one topic as a Markdown table (for ``<topic>.md``)."""
    lines = ["| goal | case | measured | target | verdict |", "|:--|:--|--:|--:|:--|"]
    for v in verdicts:
        g = v.goal
        status = v.status if v.status != NOT_MEASURED else f"{NOT_MEASURED}: {v.reason}"
        lines.append(f"| {g.name} | {v.size} | {_value(v.value, g.unit) or '–'} | {g.op} {_value(g.target, g.unit)} | "
                     f"{status} |")
    return "\n".join(lines)


def read_topic(out: Path, topic: str) -> tuple[pd.DataFrame, dict | None]:
    """The CSV of a topic and its machine record (None when the runner did not store one)."""
    df = pd.read_csv(out / f"{topic}.csv", keep_default_na=True)
    meta_file = out / f"{topic}.json"
    return df, json.loads(meta_file.read_text(encoding="utf-8")) if meta_file.is_file() else None


def write_page(out: str | Path, goals: Mapping[str, Sequence[Goal]] | None = None,
               descriptions: Mapping[str, str] | None = None) -> Path:
    """Write ``<out>/index.html`` from every ``<out>/<topic>.csv``.

    goals, descriptions : per topic, the goals to judge and the text describing the benchmark;
        default: ``GOAL_CHECKS`` and ``GOALS`` of ``boundid.bench.bench_<topic>`` (a topic without a
        module, or without GOAL_CHECKS, is shown with its table and "no goals stated").
    """
    out = Path(out)
    topics = sorted(p.stem for p in out.glob("*.csv"))
    all_rows, sections, counts = [], [], {s: 0 for s in _STATUS_CLASS}
    missed = []
    for topic in topics:
        df, meta = read_topic(out, topic)
        mod = topic_module(topic)
        checks = goals.get(topic, ()) if goals is not None else getattr(mod, "GOAL_CHECKS", ())
        text = descriptions.get(topic, "") if descriptions is not None else getattr(mod, "GOALS", "")
        start_load = (meta or {}).get("load_avg", [None])[0]
        verdicts = [judge(g, df, topic, start_load) for g in checks]
        for v in verdicts:
            counts[v.status] += 1
            all_rows.append(verdict_row(topic, v))
            if v.status != "met":
                what = (f"{_value(v.value, v.goal.unit)} against {v.goal.op} {_value(v.goal.target, v.goal.unit)}"
                        if v.value is not None else v.reason)
                load = f", load {v.load:.2f}" if v.load is not None else ""
                missed.append(f"{v.status}: {topic}, {v.goal.name}, {v.size} ({what}{load})")
        raw = _table([str(c) for c in df.columns],
                     [[(html.escape(_fmt(x)), "text" if isinstance(x, str) and len(x) > 40 else "") for x in row]
                      for row in df.itertuples(index=False)])
        n_goals = (f"{len(verdicts)} goal{'s' * (len(verdicts) != 1)}: "
                   + ", ".join(f"{sum(v.status == s for v in verdicts)} {s}" for s in _STATUS_CLASS
                               if any(v.status == s for v in verdicts))) if verdicts else "no goals stated"
        sections.append(
            f'<section id="{html.escape(topic)}"><h2>{html.escape(topic)}</h2>'
            f"<p><b>{html.escape(n_goals)}.</b> Files: <a href=\"{html.escape(topic)}.csv\">CSV</a> · "
            f"<a href=\"{html.escape(topic)}.md\">Markdown</a></p>"
            f'<p class="machine">{_machine_text(meta, topic)}</p>'
            + (f'<div class="goals">{markdown_html(text, out, shift=2)}</div>' if text.strip() else "")
            + f'<details class="raw"><summary>All {len(df)} rows of {html.escape(topic)}.csv ("{NOT_MEASURED}": '
              "the case has no such value, e.g. no reference ran for it)</summary>"
              f"{raw}</details></section>")
    reports = []  # the Markdown reports beside the page that no benchmark module writes (e.g. mutation.md)
    for md_file in sorted(out.glob("*.md")):
        if md_file.stem in topics:
            continue
        title, text = _title_and_body(md_file.read_text(encoding="utf-8"))
        reports.append(md_file.stem)
        sections.append(
            f'<section id="{html.escape(md_file.stem)}"><h2>{html.escape(title or md_file.stem)}</h2>'
            f'<p>File: <a href="{html.escape(md_file.name)}">{html.escape(md_file.name)}</a> (Markdown; '
            f"shown here as written).</p>{markdown_html(text, out, shift=1)}</section>")
    total = sum(counts.values())
    summary = ", ".join(f"{n} {s}" for s, n in counts.items() if n)
    lead = (f"<p><b>{total} goals: {html.escape(summary)}.</b></p>" if total else "<p>No goals found.</p>")
    if missed:
        lead += "<ul>" + "".join(f"<li>{html.escape(m)}</li>" for m in missed) + "</ul>"
    lead += ("<p>Timings depend on the machine's load: the last column is the 1-minute load average when the case "
             "ran (or, if the benchmark did not record it, when the benchmark started); the machine's cores are "
             "named under each benchmark.</p>")
    nav = ('<nav><a href="#goals">Goals</a>'
           + "".join(f'<a href="#{html.escape(t)}">{html.escape(t)}</a>' for t in topics + reports) + "</nav>")
    goals_table = _table(["goal", "verdict", "measured", "target", "case", "load"], all_rows)
    body = (nav + f'<div class="keypoints">{lead}</div>'
            + f'<section id="goals"><h2>Goals</h2>{goals_table}</section>' + "".join(sections))
    header = site_header("boundid benchmarks", "../index.html", files=[(f"{t}.csv", f"{t}.csv") for t in topics]
                         + [(f"{r}.md", f"{r}.md") for r in reports])
    page = render_page("boundid benchmarks", body, description=f"boundid benchmarks: {total} goals, {summary}.",
                       header=header, css=Page.css + _CSS, note=" from the CSV files beside this page")
    path = out / "index.html"
    write_file_atomically(path, page)
    return path
