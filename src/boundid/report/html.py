"""Self-contained HTML report pages (stdlib ``string.Template`` + ``html.escape``, no Jinja).

A :class:`Page` collects sections of text, tables and matplotlib figures and writes::

    <dir>/index.html      one page, figures embedded as base64 PNG, inline CSS, no script and a
                          Content-Security-Policy that forbids every network load
    <dir>/figures/*.png, *.svg
    <dir>/tables/*.csv    numeric tables (intervals as lo/hi columns)
    <dir>/tables/*.tex    booktabs LaTeX
    <dir>/summary.md      the whole page as Markdown (tables via tabulate, figures linked)

Every page opens with a header (:func:`site_header`): the way back to the site index
(``reports/index.html``) and the files of the page (its data files, the CSV and LaTeX of every
table, the PNG and SVG of every figure, listed in full in its last section, "Files").

:func:`write_site_index` writes ``reports/index.html``: what boundid is and what the studies found
(:mod:`boundid.report.front_page`: a figure across studies, their verdicts, the papers), then every
study, campaign, lesson and the benchmark page found under ``reports/``, each with its full
description (the page's ``<meta name="description">``). :func:`write_index` writes the index of one group of pages
(the teaching kit).

The site index also links two pages it writes beside itself (:func:`write_site_pages`):
``reports/glossary.html`` (:data:`boundid.report.glossary.GLOSSARY`) and ``reports/references.html``
(``docs/references.md`` rendered). A page made with ``Page(..., glossary=True)`` (the study pages)
links the first occurrence of each glossary term in its prose to its entry and every citation
``[Key]`` to the references page (the rules: :mod:`boundid.report.glossary`); ``cites`` names
the paper a page reproduces in full under its headline.
"""

from __future__ import annotations

import base64
import html
import io
import posixpath
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from html.parser import HTMLParser
from pathlib import Path
from string import Template

import pandas as pd
from matplotlib import rc_context
from matplotlib.figure import Figure

from boundid import __version__
from boundid.errors import InputError
from boundid.report.figures import DPI
from boundid.report.glossary import (
    GLOSSARY_PAGE,
    REFERENCES_PAGE,
    Linker,
    glossary_body,
    references_body,
    references_file,
    slug,
)
from boundid.report.output import write_file_atomically
from boundid.report.tables import FloatFormat, format_frame, latex_table, markdown_table, shows_index

MAX_PAGE_BYTES = 3_000_000  # a study page stays under 3 MB

_CSS = """
:root { --fg: #1f2328; --muted: #59636e; --line: #d1d9e0; --bg-alt: #f6f8fa; --accent: #0072B2; }
* { box-sizing: border-box; }
body { margin: 0; font: 15px/1.55 system-ui, -apple-system, "Segoe UI", Roboto, Helvetica, Arial, sans-serif;
       color: var(--fg); background: #fff; }
main { max-width: 1040px; margin: 0 auto; padding: 1.5rem 1.25rem 3rem; }
h1 { font-size: 1.7rem; margin: 0 0 .4rem; }
h2 { font-size: 1.25rem; margin: 2.2rem 0 .6rem; padding-bottom: .25rem; border-bottom: 1px solid var(--line); }
p { margin: .5rem 0; max-width: 75ch; }
a { color: var(--accent); }
nav { font-size: .9rem; margin: .8rem 0 1.2rem; color: var(--muted); display: flex; flex-wrap: wrap; row-gap: .3rem; }
nav a { margin-right: .9rem; white-space: nowrap; }
dl.setup { display: grid; grid-template-columns: max-content auto; gap: .15rem 1.2rem; margin: 1rem 0;
           padding: .7rem 1rem; background: var(--bg-alt); border-radius: 6px; font-size: .92rem; }
dl.setup dt { font-weight: 600; } dl.setup dd { margin: 0; }
figure { margin: 1.2rem 0; }
figure.fig img { max-width: 100%; height: auto; display: block; border: 1px solid var(--line); border-radius: 4px; }
figcaption { font-size: .9rem; color: var(--muted); margin: .35rem 0; }
figcaption b { color: var(--fg); }
.files { font-size: .8rem; margin-left: .5rem; }
/* a table wider than its box scrolls sideways; shadows at the edges that have more columns behind
   them say so (the "local" white covers hide each shadow once that edge is reached) */
.scroll { overflow-x: auto; background:
  linear-gradient(to right, #fff 30%, rgba(255, 255, 255, 0)) left / 2.5rem 100% no-repeat local,
  linear-gradient(to left, #fff 30%, rgba(255, 255, 255, 0)) right / 2.5rem 100% no-repeat local,
  radial-gradient(farthest-side at 0 50%, rgba(0, 0, 0, .28), transparent) left / .9rem 100% no-repeat scroll,
  radial-gradient(farthest-side at 100% 50%, rgba(0, 0, 0, .28), transparent) right / .9rem 100% no-repeat scroll; }
table.data { border-collapse: collapse; font-size: .88rem; font-variant-numeric: tabular-nums; }
table.data th, table.data td { padding: .28rem .65rem; border-bottom: 1px solid var(--line); text-align: right;
                               white-space: nowrap; }
table.data thead th { background: var(--bg-alt); border-bottom: 2px solid var(--line); }
table.data.keyed td:first-child, table.data.keyed th:first-child { text-align: left; }
table.data.keyed td:first-child { font-weight: 600; }
table.data td.prose, table.data th.prose { text-align: left; white-space: normal; min-width: 16rem; }
table.data td.words, table.data th.words { text-align: left; }
table.data tbody tr:hover { background: #fafbfc; }
footer { margin-top: 3rem; font-size: .8rem; color: var(--muted); }
ul.studies li { margin: .45rem 0; }
header.site { background: var(--bg-alt); border-bottom: 1px solid var(--line); font-size: .86rem; }
header.site > div { max-width: 1040px; margin: 0 auto; padding: .45rem 1.25rem; display: flex; flex-wrap: wrap;
                    justify-content: space-between; gap: .2rem 1.5rem; }
header.site .crumbs a { font-weight: 600; } header.site .sep { color: var(--muted); margin: 0 .35rem; }
header.site .here { color: var(--muted); }
header.site .pagefiles { min-width: 0; }
header.site .pagefiles a { margin-left: .7rem; white-space: nowrap; }
ul.filelist li { margin: .15rem 0; }
div.entry { margin: .9rem 0 1.3rem; padding-left: .9rem; border-left: 3px solid var(--line); }
div.entry h3 { font-size: 1.05rem; margin: 0 0 .2rem; }
div.entry .links { font-size: .88rem; } div.entry .links a { margin-right: .9rem; }
div.entry code { font-size: .8rem; color: var(--muted); margin-left: .4rem; }
p.absent { color: var(--muted); font-style: italic; }
details.fold > summary { cursor: pointer; color: var(--accent); font-weight: 600; margin: .4rem 0; }
.findings { border-left: 4px solid var(--accent); background: #eef6fb; padding: .5rem 1rem; margin: 1rem 0;
            border-radius: 0 6px 6px 0; }
.findings.attention { border-left-color: #b33c00; background: #fdf1ea; }
a.term { color: inherit; text-decoration: underline dotted var(--accent); text-underline-offset: .18em; }
a.term:hover { color: var(--accent); }
p.cites { font-size: .92rem; color: var(--muted); }
dl.glossary dt { font-weight: 600; margin-top: .9rem; } dl.glossary dd { margin: .15rem 0 0 1.2rem; max-width: 75ch; }
dl.glossary .forms { display: block; font-size: .85rem; color: var(--muted); }
ul.refs li { margin: .4rem 0; max-width: 80ch; } pre { overflow-x: auto; font-size: .85rem; background: var(--bg-alt);
                                                       padding: .4rem .6rem; }
"""

# No script, no network: everything the page shows is inline (CSS) or a data: URI (images).
_CSP = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"

_PAGE = Template("""<!DOCTYPE html>
<html lang="en">
<head>
<meta http-equiv="Content-Security-Policy" content="$csp">
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="description" content="$meta_description">
<meta name="generator" content="boundid $version">
<title>$title</title>
<style>$css</style>
</head>
<body>
$header
<main>
<h1>$title</h1>
$body
<footer>Generated by boundid $version$note.</footer>
</main>
</body>
</html>
""")


def _paragraphs(text: str, linker: Linker | None = None) -> str:
    """Plain text -> escaped <p> blocks (blank lines separate paragraphs); with ``linker``, its
    glossary terms and citations linked (:class:`boundid.report.glossary.Linker`)."""
    esc = html.escape if linker is None else linker.text
    return "\n".join(f"<p>{esc(' '.join(p.split()))}</p>" for p in re.split(r"\n\s*\n", text) if p.strip())


def _prose(text: str, linker: Linker | None) -> str:
    """One line of plain text (a caption, a list item) escaped, with ``linker``'s links."""
    return html.escape(text) if linker is None else linker.text(text)


def _site_href(home: str | None, name: str) -> str:
    """``name`` (a page beside the site index) relative to a page whose site index is ``home``."""
    return posixpath.join(posixpath.dirname(home), name) if home else name


def _meta_text(text: str) -> str:
    """``text`` for the page's meta description: whole, each paragraph on one line, paragraphs
    separated by a blank line (the site index shows it in full, paragraph by paragraph)."""
    return "\n\n".join(" ".join(p.split()) for p in re.split(r"\n\s*\n", text) if p.strip())


def site_header(title: str, home: str | None, trail: Sequence[tuple[str, str]] = (),
                files: Sequence[tuple[str, str]] = ()) -> str:
    """The header bar of a page: "boundid reports › <trail> › <title>" on the left (``home``: the
    site index relative to the page, None for the index itself; ``trail``: (label, href) of the
    levels between), the page's files as (label, href) links on the right. Escaped HTML."""
    crumbs = ([f'<a href="{html.escape(home)}">&larr; boundid reports</a>'] if home else [])
    crumbs += [f'<a href="{html.escape(href)}">{html.escape(label)}</a>' for label, href in trail]
    crumbs.append(f'<span class="here">{html.escape(title)}</span>')
    sep = '<span class="sep">›</span>'
    links = " ".join(f'<a href="{html.escape(href)}">{html.escape(label)}</a>' for label, href in files)  # may wrap
    right = f'<span class="pagefiles">Files:{links}</span>' if links else ""
    return f'<header class="site"><div><span class="crumbs">{sep.join(crumbs)}</span>{right}</div></header>'


def render_page(title: str, body: str, *, description: str = "", header: str = "", css: str = _CSS,
                csp: str = _CSP, note: str = "") -> str:
    """A complete page in the report style: ``body`` and ``header`` are HTML (escaped by the
    caller), ``description`` plain text for the meta description (shown by the site index),
    ``note`` plain text ending the footer's "Generated by boundid <version>"."""
    return _PAGE.substitute(csp=csp, meta_description=html.escape(_meta_text(description)), version=__version__,
                            title=html.escape(title), css=css, header=header,
                            body=body, note=html.escape(note))


@dataclass
class _Table:
    df: pd.DataFrame
    caption: str
    name: str
    float_format: FloatFormat
    number: int


@dataclass
class _Figure:
    png: bytes
    svg: bytes
    caption: str
    name: str
    number: int


@dataclass
class _Findings:
    items: list[str]
    attention: bool


@dataclass
class _Section:
    title: str | None
    anchor: str
    blocks: list = field(default_factory=list)  # str (text) | _Table | _Figure
    folded: str | None = None  # the line shown while the section's content is folded away


#: a table column holding a cell longer than this is prose: left-aligned and wrapped (a sentence in a
#: right-aligned, unwrapped column would push the short values of the others out of the reader's view)
PROSE_CHARS = 60


def _link_cells(body: str, linker: Linker, keyed: bool) -> str:
    """``body`` (a pandas to_html table) with the header cells, and the first (label) column of a
    keyed table, linked where the whole cell is a glossary term (first occurrence only)."""
    head, sep, rest = body.partition("<tbody>")
    cell = re.compile(r"(<th(?: [^>]*)?>)(.*?)(</th>)", re.S)
    head = cell.sub(lambda m: m.group(1) + linker.cell(m.group(2)) + m.group(3), head)
    if keyed:
        first = re.compile(r"(<tr>\s*<t[dh](?: [^>]*)?>)(.*?)(</t[dh]>)", re.S)
        rest = first.sub(lambda m: m.group(1) + linker.cell(m.group(2)) + m.group(3), rest)
    return head + sep + rest


def _prose_cells(body: str, classes: dict[int, str]) -> str:
    """``body`` (a pandas to_html table) with the header and body cells of the columns in ``classes``
    (0-based column -> class, "prose" or "words") marked with their class."""
    if not classes:
        return body

    def tag(cell: str, k: int) -> str:
        return f'<{cell} class="{classes[k]}">' if k in classes else f"<{cell}>"

    head, sep, rest = body.partition("<tbody>")
    ths = head.split("<th>")
    head = ths[0] + "".join(tag("th", k) + c for k, c in enumerate(ths[1:]))
    rows = rest.split("<tr>")
    for i in range(1, len(rows)):
        cells = rows[i].split("<td>")
        rows[i] = cells[0] + "".join(tag("td", k) + c for k, c in enumerate(cells[1:]))
    return head + sep + "<tr>".join(rows)


def _is_words(values) -> bool:
    """Whether a column of cells (as shown) holds words rather than numbers: some cell is neither a
    number nor a dash (left-aligned, as text reads; numbers stay right-aligned to line up digits)."""
    for v in values:
        text = str(v).strip()
        if text in ("", "–", "-", "nan"):
            continue
        try:
            float(text.replace(",", "").rstrip("%x ").replace("−", "-"))
        except ValueError:
            return True
    return False


class Page:
    """A report page under construction; every method but :meth:`write` returns the page (chainable).

    title : page title;  description : a short plain-text description of the set-up (paragraphs
    separated by blank lines; the site index shows it in full);  setup : {key: value} shown as a
    definition list under it (robot, samples, noise level, ...);  dpi : PNG resolution of figures.
    home : the site index relative to the page (default ``../index.html``: a page at
    ``reports/<name>/index.html``);  trail : (label, href) of the levels between the index and
    the page (e.g. the teaching kit), for the header.
    glossary : link the first occurrence of each glossary term in the page's prose (paragraphs,
    captions, the values of the set-up box, the findings; table header cells and the label column
    when the whole cell is a term; never headings or the set-up box's labels) to ``glossary.html``
    beside the site index, and every citation
    ``[Key]`` to ``references.html``; :meth:`write` writes those pages there if they are missing.
    cites : (label, reference key) of docs/references.md, e.g. ``[("Reproduces", "H4Paper")]``:
    each shown under the description as "<label>: <the full reference>" (authors, title, venue,
    year), and added to the meta description; InputError for a key the file does not have.
    """

    css = _CSS  # subclasses may add rules (the teaching handouts' stepper) or
    csp = _CSP  # allow one script by its hash

    def __init__(self, title: str, description: str = "", *, setup: Mapping[str, object] | None = None,
                 dpi: int = DPI, max_bytes: int = MAX_PAGE_BYTES, home: str | None = "../index.html",
                 trail: Sequence[tuple[str, str]] = (), glossary: bool = False,
                 cites: Sequence[tuple[str, str]] = ()):
        self.title = title
        self.glossary = glossary
        self.cites = [(str(label), str(key).strip("[]")) for label, key in cites]
        self._full_refs = {}
        if self.cites:
            from boundid.report.glossary import full_reference
            self._full_refs = {key: full_reference(key) for _, key in self.cites}  # InputError: unknown key
        self._site_links: set[str] = set()  # the site pages the last rendering linked to
        self.home = home
        self.trail = list(trail)
        self._attached: list[tuple[str, str, str]] = []  # (label, href, what it holds)
        self._findings: _Findings | None = None
        self.description = description
        self.setup = dict(setup or {})
        self.dpi = dpi
        self.max_bytes = max_bytes
        self._sections = [_Section(None, "top")]
        self._names: set[str] = set()
        self._anchors: set[str] = {"top", "files", "files-tables", "files-figures"}
        self._n_tables = 0
        self._n_figures = 0

    def section(self, title: str, text: str | None = None, *, folded: str | None = None) -> Page:
        """Start a new section (an <h2> in the page, listed in the navigation bar). ``folded``: the
        section's content is folded (<details>) under its heading behind this one-line summary."""
        self._sections.append(_Section(title, slug(title, self._anchors), folded=folded))
        if text:
            self.text(text)
        return self

    def text(self, text: str) -> Page:
        """A paragraph (or several, separated by blank lines) in the current section."""
        self._sections[-1].blocks.append(text)
        return self

    def findings(self, items: Sequence[str], *, attention: bool = False) -> Page:
        """What the page found, a few sentences computed from the run, in a box at the top of the
        page (before the set-up); ``attention`` marks it as reporting a problem (a broken bound, a
        guarantee not verified, failures)."""
        if isinstance(items, str) or not items or not all(isinstance(t, str) and t.strip() for t in items):
            raise InputError("Page.findings takes a non-empty list of sentences.")
        self._findings = _Findings(list(items), attention)
        return self

    def table(self, df: pd.DataFrame, caption: str, float_format: FloatFormat = "{:.4g}", *,
              name: str | None = None) -> Page:
        """A table: shown in the page, written as ``tables/<name>.csv`` (numeric) and ``.tex``.

        df : numeric DataFrame, e.g. from :func:`boundid.report.tables.parameter_table`
        float_format : ``"{:.4g}"``, ``".3f"`` or a callable float -> str (display only; CSV keeps
            full precision).  name : file stem (default: from the caption).
        """
        if not isinstance(df, pd.DataFrame):
            raise InputError(f"Page.table needs a pandas DataFrame, got {type(df).__name__}.")
        self._n_tables += 1
        item = _Table(df, caption, slug(name or caption, self._names), float_format, self._n_tables)
        self._sections[-1].blocks.append(item)
        return self

    def figure(self, fig: Figure, caption: str, *, name: str | None = None) -> Page:
        """A matplotlib figure: embedded as PNG, written as ``figures/<name>.png`` and ``.svg``.

        The figure is rendered now, so the caller may close or reuse it afterwards. Its layout
        (e.g. constrained) is computed once, for the PNG; the SVG reuses it.
        """
        if not isinstance(fig, Figure):
            raise InputError(f"Page.figure needs a matplotlib Figure, got {type(fig).__name__}.")
        png, svg = io.BytesIO(), io.BytesIO()
        fig.savefig(png, format="png", dpi=self.dpi, metadata={"Software": None})
        engine = fig.get_layout_engine()
        fig.set_layout_engine("none")  # the axes stay where the PNG's layout put them
        try:
            # a fixed salt for the SVG's element ids (random by default): the same figure, the same file
            with rc_context({"svg.hashsalt": "boundid"}):
                fig.savefig(svg, format="svg", metadata={"Date": None, "Creator": None})
        finally:
            fig.set_layout_engine(engine)
        self._n_figures += 1
        self._sections[-1].blocks.append(
            _Figure(png.getvalue(), svg.getvalue(), caption, slug(name or caption, self._names), self._n_figures)
        )
        return self

    def attach(self, label: str, href: str, about: str = "") -> Page:
        """A file or folder beside the page that the page does not write itself (e.g. a campaign's
        ``data/``), linked from the header and listed under "Files". Files found beside the page
        when it is written (e.g. a study's ``results.csv``) are linked without being attached."""
        self._attached.append((label, href, about))
        return self

    # ----------------------------------------------------------------------------------- output
    def _table_html(self, t: _Table) -> str:
        text = format_frame(t.df, t.float_format)
        if shows_index(t.df):  # the index as a first, left-aligned column with its name in the header row
            text = text.reset_index()
        classes = {}
        for k, c in enumerate(text.columns):
            cells = text[c].astype(str)
            if cells.str.len().max() > PROSE_CHARS:
                classes[k] = "prose"
            elif _is_words(cells):
                classes[k] = "words"
        body = _prose_cells(text.to_html(index=False, border=0, escape=True,
                                         classes="data" + (" keyed" if shows_index(t.df) else "")), classes)
        linker = self._linker
        caption = _prose(t.caption, linker)  # the caption comes before the cells in the page
        if linker is not None:
            body = _link_cells(body, linker, shows_index(t.df))
        return (f'<figure class="tab" id="tab-{t.name}"><figcaption><b>Table {t.number}.</b> '
                f'{caption}<span class="files"><a href="tables/{t.name}.csv">CSV</a> · '
                f'<a href="tables/{t.name}.tex">LaTeX</a></span></figcaption>'
                f'<div class="scroll">{body}</div></figure>')

    def _figure_html(self, f: _Figure) -> str:
        data = base64.b64encode(f.png).decode("ascii")
        return (f'<figure class="fig" id="fig-{f.name}"><img src="data:image/png;base64,{data}" '
                f'alt="{html.escape(f.caption)}"><figcaption><b>Figure {f.number}.</b> '
                f'{_prose(f.caption, self._linker)}'
                f'<span class="files"><a href="figures/{f.name}.png">PNG</a> · '
                f'<a href="figures/{f.name}.svg">SVG</a></span></figcaption></figure>')

    def _block_html(self, block) -> str:
        if isinstance(block, _Table):
            return self._table_html(block)
        if isinstance(block, _Figure):
            return self._figure_html(block)
        return _paragraphs(block, self._linker)

    def _files(self, data_files: Sequence[str]) -> tuple[str, str]:
        """The header bar and the "Files" section: data files, every table (CSV, LaTeX), every
        figure (PNG, SVG) and summary.md, as links relative to the page."""
        blocks = [b for s in self._sections for b in s.blocks]
        tables = [b for b in blocks if isinstance(b, _Table)]
        figures = [b for b in blocks if isinstance(b, _Figure)]
        extra = [(f, f, "") for f in data_files] + self._attached
        links = [(label, href) for label, href, _ in extra]
        if tables:
            links.append((f"{len(tables)} table{'s' * (len(tables) > 1)} (CSV, LaTeX)", "#files-tables"))
        if figures:
            links.append((f"{len(figures)} figure{'s' * (len(figures) > 1)} (PNG, SVG)", "#files-figures"))
        links.append(("summary.md", "summary.md"))
        header = site_header(self.title, self.home, self.trail, links)

        def item(label: str, href: str, about: str) -> str:
            return f'<li><a href="{html.escape(href)}">{html.escape(label)}</a>' + (
                f": {html.escape(about)}" if about else "") + "</li>"

        parts = [item(label, href, about or "data of the run") for label, href, about in extra]
        parts.append(item("summary.md", "summary.md", "the whole page as Markdown"))
        ul = '<ul class="filelist">'
        out = f"<p>Everything on this page is also a file beside it:</p>{ul}" + "".join(parts) + "</ul>"
        if tables:
            out += f'<p id="files-tables"><b>Tables</b> (CSV at full precision, booktabs LaTeX):</p>{ul}'
            out += "".join(f"<li>Table {t.number}. {html.escape(t.caption)} <a href=\"tables/{t.name}.csv\">CSV</a>"
                           f' · <a href="tables/{t.name}.tex">LaTeX</a></li>' for t in tables) + "</ul>"
        if figures:
            out += f'<p id="files-figures"><b>Figures</b>:</p>{ul}'
            out += "".join(f"<li>Figure {f.number}. {html.escape(f.caption)} <a href=\"figures/{f.name}.png\">PNG</a>"
                           f' · <a href="figures/{f.name}.svg">SVG</a></li>' for f in figures) + "</ul>"
        return header, f'<section id="files">\n<h2>Files</h2>\n{out}\n</section>'

    _linker: Linker | None = None  # set while to_html renders the page

    def _cites_html(self, linker: Linker) -> str:
        """ "<label>: <full reference> [Key]" lines (title in italics, the key linked)."""
        return "\n".join(f'<p class="cites">{html.escape(label)}: {linker.reference_html(key)}</p>'
                         for label, key in self.cites)

    def _meta_description(self) -> str:
        cites = "\n\n".join(f"{label}: {self._full_refs[key]}" for label, key in self.cites)
        return "\n\n".join(t for t in (self.description, cites) if t.strip())

    def to_html(self, data_files: Sequence[str] = ()) -> str:
        """The complete page as one string; ``data_files``: files beside the page to link (names)."""
        refs = _site_href(self.home, REFERENCES_PAGE)
        linker = Linker(_site_href(self.home, GLOSSARY_PAGE) if self.glossary else None,
                        refs if (self.glossary or self.cites) else None)
        self._linker = linker if self.glossary else None
        try:
            return self._render(data_files, linker)
        finally:
            self._site_links = set(linker.used)
            self._linker = None

    def _render(self, data_files: Sequence[str], linker: Linker) -> str:
        link = self._linker
        parts = []
        if self._findings is not None:
            f = self._findings
            items = "".join(f"<li>{_prose(' '.join(t.split()), link)}</li>" for t in f.items)
            parts.append(f'<div class="findings{" attention" if f.attention else ""}"><b>Findings</b><ul>{items}'
                         "</ul></div>")
        if self.description:
            parts.append(_paragraphs(self.description, link))
        if self.cites:
            parts.append(self._cites_html(linker))
        if self.setup:
            items = "".join(f"<dt>{html.escape(str(k))}</dt><dd>{_prose(str(v), link)}</dd>"  # dt: a label
                            for k, v in self.setup.items())
            parts.append(f'<dl class="setup">{items}</dl>')
        titled = [s for s in self._sections if s.title is not None]
        links = "".join(f'<a href="#{s.anchor}">{html.escape(s.title)}</a>' for s in titled)
        parts.append(f'<nav>{links}<a href="#files">Files</a></nav>')
        for s in self._sections:
            inner = "\n".join(self._block_html(b) for b in s.blocks)
            if s.folded:
                inner = f'<details class="fold"><summary>{html.escape(s.folded)}</summary>\n{inner}\n</details>'
            if s.title is None:
                parts.append(inner)
            else:
                parts.append(f'<section id="{s.anchor}">\n<h2>{html.escape(s.title)}</h2>\n{inner}\n</section>')
        header, files = self._files(data_files)
        parts.append(files)
        return render_page(self.title, "\n".join(p for p in parts if p), description=self._meta_description(),
                           header=header, css=self.css, csp=self.csp)

    def to_markdown(self) -> str:
        """The page as Markdown (``summary.md``): text, tables via tabulate, figures as links. Every
        text it quotes (title, description, captions, table cells ...) has <, > and & escaped, so a
        Markdown renderer shows it as text, as the HTML page does, and never runs it as HTML."""
        def esc(text) -> str:
            return html.escape(str(text), quote=False)

        out = [f"# {esc(self.title)}", ""]
        if self._findings is not None:
            out += ["**Findings**", ""] + [f"- {esc(' '.join(t.split()))}" for t in self._findings.items] + [""]
        if self.description:
            out += [esc(self.description.strip()), ""]
        out += [f"{esc(label)}: {esc(self._full_refs[key])} [{esc(key)}]" for label, key in self.cites]
        out += [""] if self.cites else []
        out += [f"- **{esc(k)}**: {esc(v)}" for k, v in self.setup.items()] + ([""] if self.setup else [])
        for s in self._sections:
            if s.title is not None:
                out += [f"## {esc(s.title)}", ""]
            for b in s.blocks:
                if isinstance(b, _Table):
                    out += [f"**Table {b.number}.** {esc(b.caption)}", "",
                            esc(markdown_table(b.df, b.float_format)), ""]
                elif isinstance(b, _Figure):
                    out += [f"![Figure {b.number}. {esc(b.caption)}](figures/{b.name}.png)", ""]
                else:
                    out += [esc(b.strip()), ""]
        return "\n".join(out)

    def write(self, path: str | Path) -> Path:
        """Write the page to ``path`` (e.g. ``reports/<study>/index.html``) with ``figures/``,
        ``tables/`` and ``summary.md`` beside it. Returns the page path.

        Raises InputError when the page would exceed ``max_bytes`` (3 MB): lower ``dpi`` or
        draw fewer/smaller figures.
        """
        path = Path(path)
        root = path.parent
        data_files = sorted(f.name for f in root.glob("*") if f.is_file() and not f.name.startswith(".")
                            and f.name not in (path.name, "summary.md")) if root.is_dir() else []
        page = self.to_html(data_files).encode("utf-8")
        if len(page) > self.max_bytes:
            raise InputError(f"report page {path} would be {len(page) / 1e6:.2f} MB, over the "
                             f"{self.max_bytes / 1e6:.2f} MB limit; lower Page(dpi=...) or use fewer/smaller figures.")
        root.mkdir(parents=True, exist_ok=True)
        blocks = [b for s in self._sections for b in s.blocks]
        for sub, kind in (("figures", _Figure), ("tables", _Table)):
            if any(isinstance(b, kind) for b in blocks):
                (root / sub).mkdir(exist_ok=True)
        for b in blocks:
            if isinstance(b, _Figure):
                (root / "figures" / f"{b.name}.png").write_bytes(b.png)
                (root / "figures" / f"{b.name}.svg").write_bytes(b.svg)
            elif isinstance(b, _Table):
                b.df.to_csv(root / "tables" / f"{b.name}.csv", index=shows_index(b.df))
                (root / "tables" / f"{b.name}.tex").write_text(
                    latex_table(b.df, b.caption, f"tab:{b.name}", b.float_format), encoding="utf-8")
        (root / "summary.md").write_text(self.to_markdown(), encoding="utf-8")
        site = root / posixpath.dirname(self.home) if self.home else root
        missing = [name for name in (GLOSSARY_PAGE, REFERENCES_PAGE) if not (site / name).is_file()]
        if self._site_links and missing:  # a page written alone still has its links resolve (the glossary's too)
            write_site_pages(site, missing)
        path.write_bytes(page)
        return path


class _HeadReader(HTMLParser):
    """Reads <title> and <meta name="description"> of a page."""

    def __init__(self):
        super().__init__()
        self.title, self.description, self._in_title = "", "", False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "title":
            self._in_title = True
        elif tag == "meta" and a.get("name") == "description":
            self.description = a.get("content") or ""

    def handle_endtag(self, tag):
        if tag == "title":
            self._in_title = False

    def handle_data(self, data):
        if self._in_title:
            self.title += data


def _index_entries(root: Path, studies) -> list[tuple[str, str | None, Path]]:
    """Normalise ``studies`` to (name, title or None, page path relative to root)."""
    if studies is None:
        return [(p.parent.name, None, p.relative_to(root)) for p in sorted(root.glob("*/index.html"))]
    if isinstance(studies, Mapping):
        return [(name, title, Path(name) / "index.html") for name, title in studies.items()]
    out = []
    for entry in studies:
        if isinstance(entry, str):
            out.append((entry, None, Path(entry) / "index.html"))
        elif isinstance(entry, tuple) and len(entry) in (2, 3):
            name, title = entry[0], entry[1]
            out.append((name, title, Path(entry[2]) if len(entry) == 3 else Path(name) / "index.html"))
        else:
            raise InputError(f"write_index: a study entry must be a name, (name, title) or (name, title, page); "
                             f"got {entry!r}.")
    return out


def _read_head(page: Path) -> tuple[str, str]:
    """(title, meta description) of a written page."""
    head = _HeadReader()
    head.feed(page.read_text(encoding="utf-8"))
    return head.title.strip(), head.description


def _entry(href: str, title: str, description: str, name: str = "",
           links: Sequence[tuple[str, str]] = ()) -> str:
    """One linked page of an index: its title, its name, its full description, further links."""
    more = "".join(f'<a href="{html.escape(h)}">{html.escape(label)}</a>' for label, h in links)
    return (f'<div class="entry"><h3><a href="{html.escape(href)}">{html.escape(title)}</a>'
            + (f"<code>{html.escape(name)}</code>" if name else "") + "</h3>"
            + (_paragraphs(description) if description else "")
            + (f'<p class="links">{more}</p>' if more else "") + "</div>")


def write_index(reports_dir: str | Path, studies=None, title: str = "boundid reports", description: str = "",
                *, home: str | None = "../index.html") -> Path:
    """Write ``<reports_dir>/index.html`` linking a group of pages (e.g. the teaching kit's lessons).

    studies : None (every ``<reports_dir>/*/index.html`` found), ``{name: title}``, or a sequence
        of ``name``, ``(name, title)`` or ``(name, title, page path relative to reports_dir)``;
        the default page is ``<name>/index.html``. A missing title is read from the page's
        <title>; the page's full meta description is shown under it.
    home : the site index relative to this one (its header's link back), None for none.
    """
    root = Path(reports_dir)
    items = []
    for name, given_title, rel in _index_entries(root, studies):
        page = root / rel
        if not page.is_file():
            raise InputError(f"study page {page} does not exist; run study {name!r} first or leave it out.")
        page_title, text = _read_head(page)
        items.append(_entry(rel.as_posix(), given_title or page_title or name, text, name))
    body = (_paragraphs(description) if description else "") + "".join(items)
    out = root / "index.html"
    root.mkdir(parents=True, exist_ok=True)
    write_file_atomically(out, render_page(title, body, description=description,
                                           header=site_header(title, home) if home else ""))
    return out


#: sub-folders of the reports folder that hold no study: the lessons and the benchmarks
TEACHING_DIR, BENCHMARKS_DIR, CAMPAIGN_DIR = "teaching", "benchmarks", "campaign"
#: the excitation criteria side by side (:mod:`boundid.report.excitation_page`)
EXCITATION_DIR = "excitation"

_SITE_INTRO = ("Every page is self-contained (figures embedded, no network), so the folder can be copied or opened "
               "offline; its header links back here and to its files (CSV and LaTeX of every table, PNG and SVG of "
               "every figure). Each boundid command that writes pages (report, run, campaign, teach, bench) "
               "rewrites this index from the pages it finds.")

#: the documentation site, built into the reports folder by its own command, linked when present
DOCS_DIR = "docs"
DOCS_PAGE = f"{DOCS_DIR}/index.html"

# the front matter's findings table: failed gates stand out
_INDEX_CSS = """
table.findings-table td.fail { color: #b33c00; font-weight: 600; }
table.findings-table td.prose { min-width: 12rem; }
"""

_ABSENT = {"studies": "No study page yet: make report (or boundid run <study file>) writes them.",
           "campaigns": "No campaign yet: make campaign (boundid campaign <study file>) runs the Monte Carlo "
                        "replicates of a study's noise scenarios and writes its page.",
           "teaching": "No handout yet: make teach (boundid teach) runs the lessons in studies/teaching.",
           "excitation": "No excitation design page yet: make report writes it for the studies whose "
                         "[experiment.design] sets compare = true (or boundid excitation <study file>).",
           "benchmarks": "No benchmark page yet: make bench (boundid bench) measures and writes it."}


_SITE_PAGES = {
    GLOSSARY_PAGE: ("Glossary", "What the words of the study pages mean: gamma*, e_max, the exact polytope, the "
                    "raw set and \"∩ prior box\", the set families (OBE standard and factorized, box, parallelotope, "
                    "zonotope, limited polytope, OBE ∩ prior box), guaranteed, statistical and unverified sets, "
                    "outliers, base parameters ..., each with its reference where one applies."),
    REFERENCES_PAGE: ("References", "The papers and books boundid reproduces, implements and cites (authors, title, "
                      "venue, year; docs/references.md), one anchor per key, and the formulas the code implements."),
}


def write_site_pages(reports_dir: str | Path, names: Sequence[str] = (GLOSSARY_PAGE, REFERENCES_PAGE)) -> list[Path]:
    """Write the site's glossary (``glossary.html``) and references (``references.html``, from
    docs/references.md; left out when the package runs without its checkout) into ``reports_dir``,
    beside the site index. Returns the pages written."""
    root = Path(reports_dir)
    root.mkdir(parents=True, exist_ok=True)
    has_refs = references_file() is not None
    out = []
    for name in names:
        if name == REFERENCES_PAGE and not has_refs:
            continue
        title, description = _SITE_PAGES[name]
        body = (glossary_body(REFERENCES_PAGE if has_refs else None) if name == GLOSSARY_PAGE
                else _paragraphs("Every citation on the pages and in the code, a key such as [H4Paper] or a section "
                                 "such as [refs §LP], points to an entry of this page (docs/references.md, "
                                 "rendered).") + references_body())
        title = f"boundid: {title.lower()}"
        out.append(write_file_atomically(root / name, render_page(title, body, description=description,
                                                                  header=site_header(title, "index.html"))))
    return out


def write_site_index(reports_dir: str | Path, title: str = "boundid reports") -> Path:
    """Write ``<reports_dir>/index.html``. It opens with the front matter
    (:func:`boundid.report.front_page.front_matter`): what boundid is, what the studies found in a
    few sentences, a figure of every study's guaranteed sets against its exact LP bounds (read from
    each ``results.csv``; its PNG, SVG and CSV written beside the index), a table of each study's
    ``verdict.json`` and the papers reproduced, cited in full. Then every page found under
    ``reports_dir``, each with its full description (its meta description), in five sections:

    - studies: ``<name>/index.html`` (with links to its ``results.csv`` and campaign, if present);
    - campaigns: ``<name>/campaign/index.html``;
    - the teaching kit: ``teaching/index.html`` and each ``teaching/<lesson>/index.html``;
    - the excitation design: ``excitation/index.html``;
    - benchmarks: ``benchmarks/index.html``;

    and, once there is a page, in a last section, the documentation (``docs/index.html``, when it
    exists), the glossary and the references, the last two written beside it by
    :func:`write_site_pages`. A section with no page says which command writes it.
    """
    from boundid.report.front_page import front_matter  # it reads the studies' verdict files

    root = Path(reports_dir)
    root.mkdir(parents=True, exist_ok=True)
    groups: dict[str, list[str]] = {k: [] for k in _ABSENT}
    studies: list[str] = []
    for folder in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")):
        page = folder / "index.html"
        if folder.name in (TEACHING_DIR, BENCHMARKS_DIR, DOCS_DIR, EXCITATION_DIR) or not page.is_file():
            continue
        links = [("results.csv", f"{folder.name}/results.csv")] if (folder / "results.csv").is_file() else []
        campaign = folder / CAMPAIGN_DIR / "index.html"
        if campaign.is_file():
            links.append(("Monte Carlo campaign", campaign.relative_to(root).as_posix()))
            c_title, c_text = _read_head(campaign)
            groups["campaigns"].append(_entry(campaign.relative_to(root).as_posix(), c_title or folder.name,
                                              c_text, folder.name, [("study page", f"{folder.name}/index.html")]))
        s_title, s_text = _read_head(page)
        studies.append(folder.name)
        groups["studies"].append(_entry(f"{folder.name}/index.html", s_title or folder.name, s_text, folder.name,
                                        links))
    kit = root / TEACHING_DIR / "index.html"
    if kit.is_file():
        k_title, k_text = _read_head(kit)
        groups["teaching"].append(_entry(f"{TEACHING_DIR}/index.html", k_title or "teaching kit", k_text))
    for lesson in sorted((root / TEACHING_DIR).glob("*/index.html")):
        l_title, l_text = _read_head(lesson)
        groups["teaching"].append(_entry(lesson.relative_to(root).as_posix(), l_title or lesson.parent.name, l_text,
                                         lesson.parent.name))
    design = root / EXCITATION_DIR / "index.html"
    if design.is_file():
        e_title, e_text = _read_head(design)
        groups["excitation"].append(_entry(f"{EXCITATION_DIR}/index.html", e_title or "excitation design", e_text))
    bench = root / BENCHMARKS_DIR / "index.html"
    if bench.is_file():
        b_title, b_text = _read_head(bench)
        groups["benchmarks"].append(_entry(f"{BENCHMARKS_DIR}/index.html", b_title or "benchmarks", b_text))
    site_pages = [p.name for p in write_site_pages(root)] if any(groups.values()) else []  # once a page needs them
    groups["reference"] = [_entry(name, _SITE_PAGES[name][0], _SITE_PAGES[name][1]) for name in site_pages]
    docs = root / DOCS_PAGE
    if docs.is_file():
        d_title, d_text = _read_head(docs)
        groups["reference"].insert(0, _entry(DOCS_PAGE, d_title or "Documentation", d_text))
    front = front_matter(root, studies, refs_linked=REFERENCES_PAGE in site_pages)
    headings = {"studies": "Studies", "campaigns": "Monte Carlo campaigns", "teaching": "Teaching kit",
                "excitation": "Excitation design", "benchmarks": "Benchmarks",
                "reference": ("Documentation, glossary" if docs.is_file() else "Glossary") + " and references"}
    headings = {k: h for k, h in headings.items() if k in _ABSENT or groups[k]}
    nav = ("<nav>" + "".join(f'<a href="#{k}">{html.escape(h)}</a>'
                             for k, h in [*((k, h) for k, (h, _) in front.sections.items()), *headings.items()])
           + "</nav>")
    sections = [f'<section id="{k}"><h2>{html.escape(h)}</h2>{body}</section>'
                for k, (h, body) in front.sections.items()]
    sections.append(_paragraphs(_SITE_INTRO))
    sections += [f'<section id="{k}"><h2>{h}</h2>'
                 + ("".join(groups[k]) or f'<p class="absent">{html.escape(_ABSENT[k])}</p>') + "</section>"
                 for k, h in headings.items()]
    out = root / "index.html"
    write_file_atomically(out, render_page(title, front.lead + nav + "".join(sections),
                                           description=f"{front.description}\n\n{_SITE_INTRO}",
                                           header=site_header(title, None), css=_CSS + _INDEX_CSS))
    return out


# the names the lesson handouts (boundid.teaching) build their pages with, as the study pages do
Table, paragraphs = _Table, _paragraphs  # and slug, imported above
