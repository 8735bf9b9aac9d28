"""The glossary and references pages of the site, and the links from the study pages' prose to them.

Reference: docs/references.md read directly (its keys by the pattern ``**[Key]**``), the pages
written here parsed back with html.parser, and every relative link resolved on the file system.
"""

from __future__ import annotations

import re
from html.parser import HTMLParser
from pathlib import Path

import pandas as pd
import pytest

from boundid.errors import InputError
from boundid.report.glossary import (
    GLOSSARY,
    Linker,
    full_reference,
    references,
    study_citations,
)
from boundid.report.html import Page, write_site_index
from boundid.report.study_page import study_page
from tiny_study import run_study_text, tiny_study

ROOT = Path(__file__).resolve().parent.parent
REFS = (ROOT / "docs" / "references.md").read_text(encoding="utf-8")
KEYS = re.findall(r"\*\*\[(\w+)\]\*\*", REFS)


class _Parsed(HTMLParser):
    """Every id, every <a> (href, class, text) and the text of the page in order."""

    def __init__(self):
        super().__init__()
        self.ids, self.links, self.text, self._a = set(), [], [], None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "a":
            self._a = [a.get("href"), a.get("class"), ""]
            self.links.append(self._a)

    def handle_endtag(self, tag):
        if tag == "a":
            self._a = None

    def handle_data(self, data):
        self.text.append(data)
        if self._a is not None:
            self._a[2] += data


def _parse(path: Path) -> _Parsed:
    p = _Parsed()
    p.feed(path.read_text(encoding="utf-8"))
    return p


def _resolves(page: Path, href: str) -> bool:
    """A relative link names an existing file, and its #anchor an id in that file."""
    target, _, anchor = href.partition("#")
    path = (page.parent / target) if target else page
    return path.is_file() and (not anchor or anchor in _parse(path).ids)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """A site with one study-like page (glossary links on, citing the H4 paper) and its index."""
    root = tmp_path_factory.mktemp("reports")
    page = Page("Toy", "The error bound holds at the truth; gamma* = 0.3 x e_max.", glossary=True,
                cites=[("Reproduces", "H4Paper")], setup={"exact polytope": "Polytope (limited) 1 x (raw set 1 x)"})
    page.section("Sets", "The exact polytope, then gamma* again, then the exact polytope once more; see [H4Paper] "
                 "eq. 37 and [refs §LP]. A gamma*_j and an e_max_rule are other things.")
    page.table(pd.DataFrame({"width": [1.0, 2.0]}, index=pd.Index(["Polytope (limited)", "OBE ∩ prior box"],
                                                                 name="estimator")), "Widths ∩ prior box")
    path = page.write(root / "toy" / "index.html")
    return root, path, write_site_index(root)


def test_every_glossary_term_has_its_anchor_on_the_glossary_page(site):
    root, _, _ = site
    parsed = _parse(root / "glossary.html")
    anchors = [t.anchor for t in GLOSSARY]
    assert len(set(anchors)) == len(anchors)
    assert set(anchors) <= parsed.ids
    text = " ".join(" ".join(parsed.text).split())
    for t in GLOSSARY:
        assert t.name in text and " ".join(t.definition.split())[:40] in text
        if t.ref is not None:
            assert t.ref.removeprefix("refs §") in (KEYS + ["OBE", "LP", "PHYS", "SDP", "QR"]), t.ref
    for name in ("gamma*", "e_max (error bound)", "raw set", "∩ prior box", "Polytope (limited)", "OBE ∩ prior box",
                 "guaranteed", "statistical", "unverified", "outlier", "q-relaxed set", "base parameters",
                 "confidence band", "prediction band", "holds by construction", "LP bounds (exact interval hull)"):
        assert name in {t.name for t in GLOSSARY}, name
    broken = [h for h, _, _ in parsed.links if not _resolves(root / "glossary.html", h)]
    assert not broken, broken


def test_first_occurrence_links_and_later_ones_do_not(site):
    _, path, _ = site
    parsed = _parse(path)
    terms = [(h.split("#")[1], text) for h, cls, text in parsed.links if cls == "term"]
    anchors = [a for a, _ in terms]
    assert len(anchors) == len(set(anchors)), "a term links more than once"
    assert terms[:2] == [("e-max", "error bound"), ("gamma-star", "gamma*")]  # the headline comes first
    assert ("exact-polytope", "exact polytope") in terms and ("raw-set", "raw set") in terms
    html = path.read_text()
    assert html.count(">exact polytope</a>") == 1 and "the exact polytope once more" in html
    assert "gamma*_j" in html and "e_max_rule" in html  # not words of the glossary
    assert ">Polytope (limited)</a>" in html  # in the set-up box, before the table
    assert '<td class="words">Polytope (limited)</td>' in html  # the table's label cell: already linked above
    assert '>OBE ∩ prior box</a></td>' in html  # first met in the table's label column
    assert "<h2>Sets</h2>" in html and "<dt>exact polytope</dt>" in html  # headings and labels never link
    cites = [h for h, cls, _ in parsed.links if cls == "cite"]
    assert "../references.html#H4Paper" in cites and "../references.html#refs-LP" in cites
    assert all(_resolves(path, h) for h, _, _ in parsed.links), [h for h, _, _ in parsed.links
                                                                 if not _resolves(path, h)]


def test_linker_escapes_and_matches_whole_words_with_its_case_rules():
    linker = Linker("g.html", None)
    out = linker.text("Outliers <b> & outlier; non-outlier; box, Box; Guaranteed sets & statistical")
    assert "&lt;b&gt; &amp;" in out and "<b>" not in out
    assert out.count('href="g.html#outlier"') == 1 and ">Outliers</a>" in out  # capitalised first letter
    assert "non-outlier" in out and ">box<" not in out and ">Box</a>" in out  # Box: as written only
    assert ">Guaranteed</a>" in out
    assert Linker(None, None).text("a <gamma*> & b") == "a &lt;gamma*&gt; &amp; b"


def test_a_reference_key_resolves_to_its_full_reference():
    assert {"H4Paper", "DirectDrivePaper", "FIGAROH"} <= set(KEYS) == set(references())
    h4 = full_reference("H4Paper")
    assert h4.startswith("P. Poignet, N. Ramdani, O. A. Vivas.")
    assert "Ellipsoidal estimation of parallel robot dynamic parameters." in h4 and "2003" in h4
    assert "(IROS)" in h4 and "pp. 3300-3305." in h4 and "The H4 4-dof" not in h4  # the venue, not the notes
    dd = full_reference("[DirectDrivePaper]")
    assert dd.startswith("F. Reyes, R. Kelly.") and "Robotica 15(5), 1997, pp. 563-571." in dd
    for key in KEYS:  # every entry with a title gives it, and its year
        ref = references()[key]
        assert ref.title in ref.plain and (not ref.title or re.search(r"\b(19|20)\d\d\b", ref.plain)), key
    with pytest.raises(InputError, match="not an entry"):
        full_reference("NoSuchPaper2099")


def test_study_citations_follow_the_robot_and_the_published_sources():
    class Cfg:
        def __init__(self, robot, sources=(), source="simulate"):
            self.robot = robot
            self.published = [type("T", (), {"source": s})() for s in sources]
            self.experiment = type("E", (), {"source": source})()

    assert study_citations(Cfg("h4")) == [("Reproduces on simulated data", "H4Paper")]
    assert study_citations(Cfg("direct_drive")) == [("Reproduces on simulated data", "DirectDrivePaper")]
    assert study_citations(Cfg("h4", source="measured")) == [("The paper", "H4Paper")]
    tx40 = Cfg("urdf", ["[FIGAROH] config/T40X_config.yaml", "[FIGAROH] results", "[Leboutet2021] BIRDy"])
    assert study_citations(tx40) == [("Source", "FIGAROH"), ("Source", "Leboutet2021")]
    assert study_citations(Cfg("urdf")) == []


def test_site_writer_writes_and_links_the_glossary_and_references(site):
    root, _, index = site
    assert (root / "glossary.html").is_file() and (root / "references.html").is_file()
    links = [h for h, _, _ in _parse(index).links]
    assert "glossary.html" in links and "references.html" in links
    assert all(_resolves(index, h) for h in links), [h for h in links if not _resolves(index, h)]
    refs = _parse(root / "references.html")
    assert set(KEYS) <= refs.ids and {"refs-OBE", "refs-LP", "refs-SDP"} <= refs.ids
    text = " ".join(" ".join(refs.text).split())
    assert "Ellipsoidal estimation of parallel robot dynamic parameters." in text
    assert all(_resolves(root / "references.html", h) for h, _, _ in refs.links)


def test_a_page_written_alone_writes_the_pages_it_links(tmp_path):
    path = Page("Alone", "The exact polytope.", glossary=True).write(tmp_path / "s" / "index.html")
    assert (tmp_path / "glossary.html").is_file() and (tmp_path / "references.html").is_file()
    links = [h for h, cls, _ in _parse(path).links if cls == "term"]
    assert links == ["../glossary.html#exact-polytope"] and _resolves(path, links[0])
    glossary = tmp_path / "glossary.html"  # no site index yet: every link of the glossary but the way home
    assert all(_resolves(glossary, h) for h, _, _ in _parse(glossary).links if h != "index.html")
    plain = Page("Plain", "The exact polytope.").write(tmp_path / "p" / "index.html")  # links are opt-in
    assert 'class="term"' not in plain.read_text()


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    text = tiny_study("dd_refs", 3) + """
[[estimators]]
method = "obe"
label = "OBE-factorized"
form = "factorized"
regressions = ["filtered_dynamic"]
e_max = 6.0

[exact]
regression = "filtered_dynamic"
e_max = 6.0
"""
    return run_study_text(tmp_path_factory.mktemp("tiny"), "dd_refs", text)


def test_a_study_page_names_its_paper_in_full_under_the_headline(tiny, tmp_path):
    cfg, r = tiny
    html = study_page(r).to_html()
    full = full_reference("DirectDrivePaper")
    title = "Experimental evaluation of identification schemes on a direct drive robot."
    cites = re.search(r'<p class="cites">Reproduces on simulated data: (.*?)</p>', html)
    assert cites, "no 'Reproduces on simulated data:' line"
    assert f"<em>{title}</em>" in cites.group(1) and "F. Reyes, R. Kelly." in cites.group(1)
    assert html.index('<p class="cites">') < html.index('<dl class="setup">') < html.index("<h2>")
    assert html.index("<h1>") < html.index('<p class="cites">')
    description = re.search(r'<meta name="description" content="([^"]*)"', html).group(1)
    assert f"Reproduces on simulated data: {full}" in description
    assert 'class="term"' in html  # the study page links its glossary terms
