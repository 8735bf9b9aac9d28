"""The site: reports/index.html links every page, each page's header links back and to its files.

Reference: the pages written here read back with Python's html.parser and every relative link
resolved against the file system (a link counts only if the file it names exists).
"""

from __future__ import annotations

from html.parser import HTMLParser
from pathlib import Path

import pandas as pd
import pytest
from matplotlib.figure import Figure

from boundid.bench.page import write_page
from boundid.errors import InputError
from boundid.report.html import Page, write_index, write_site_index

LONG = ("A study whose description runs well past three hundred characters, so that an index which cut it "
        "would lose its end. " * 4 + "The last words of the first paragraph.\n\n"
        "A second paragraph, with its own ending.")


class _Links(HTMLParser):
    """Every href of a page, the hrefs inside its <header>, and its text."""

    def __init__(self):
        super().__init__()
        self.hrefs, self.header, self.text, self._in_header = [], [], [], False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "header":
            self._in_header = True
        if tag == "a" and a.get("href"):
            self.hrefs.append(a["href"])
            if self._in_header:
                self.header.append(a["href"])

    def handle_endtag(self, tag):
        if tag == "header":
            self._in_header = False

    def handle_data(self, data):
        self.text.append(data)


def _links(page: Path) -> _Links:
    parser = _Links()
    parser.feed(page.read_text(encoding="utf-8"))
    return parser


def _resolves(page: Path, href: str) -> bool:
    """Whether a relative link of ``page`` names an existing file (anchors: an id in the page)."""
    if href.startswith("#"):
        return f'id="{href[1:]}"' in page.read_text(encoding="utf-8")
    return (page.parent / href.split("#")[0]).exists()


def _figure() -> Figure:
    fig = Figure(figsize=(3, 2))
    fig.subplots().plot([0, 1], [1, 0])
    return fig


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """A reports folder with a study (and its results.csv), its campaign, the teaching kit with a
    lesson, and the benchmark page; then the site index."""
    root = tmp_path_factory.mktemp("reports")
    study = root / "toy"
    study.mkdir()
    pd.DataFrame({"a": [1.0]}).to_csv(study / "results.csv", index=False)
    table = pd.DataFrame({"x": [1.0, 2.0]}, index=pd.Index(["p", "q"], name="parameter"))
    (Page("Toy study", LONG).section("Results").table(table, "Intervals").figure(_figure(), "A line")
     .write(study / "index.html"))
    camp = Page("Monte Carlo campaign: toy", "noisy: Gaussian noise.", home="../../index.html",
                trail=[("Toy study", "../index.html")])
    camp.attach("data/", "data/", "the replicate files")
    (study / "campaign" / "data").mkdir(parents=True)
    camp.section("Summary").table(table, "Overview").write(study / "campaign" / "index.html")
    Page("Lesson 1: a feasible set", "What a feasible set is.", home="../../index.html",
         trail=[("teaching kit", "../index.html")]).section("Text", "words").write(
        root / "teaching" / "lesson1" / "index.html")
    write_index(root / "teaching", None, title="boundid teaching kit", description="The lessons.")
    bench = root / "benchmarks"
    bench.mkdir()
    pd.DataFrame({"case": ["a"], "time_s": [1.0]}).to_csv(bench / "toy.csv", index=False)
    (bench / "toy.md").write_text("# Benchmark: toy")  # written beside the CSV by the benchmark runner
    write_page(bench, goals={}, descriptions={})
    return root, write_site_index(root)


def test_site_index_links_every_page_with_its_full_description(site):
    root, index = site
    links = _links(index)
    assert {"toy/index.html", "toy/results.csv", "toy/campaign/index.html", "teaching/index.html",
            "teaching/lesson1/index.html", "benchmarks/index.html"} <= set(links.hrefs)
    assert all(_resolves(index, h) for h in links.hrefs), [h for h in links.hrefs if not _resolves(index, h)]
    text = " ".join(" ".join(links.text).split())
    for paragraph in LONG.split("\n\n"):  # the whole description, not its first 300 characters
        assert " ".join(paragraph.split()) in text
    for title in ("Toy study", "Monte Carlo campaign: toy", "Lesson 1: a feasible set", "boundid teaching kit",
                  "boundid benchmarks"):
        assert title in text


@pytest.mark.parametrize("page", ["toy/index.html", "toy/campaign/index.html", "teaching/index.html",
                                  "teaching/lesson1/index.html", "benchmarks/index.html"])
def test_every_page_header_links_back_and_to_its_files(site, page):
    root, index = site
    path = root / page
    links = _links(path)
    assert links.header, f"{page} has no header links"
    back = [h for h in links.header if (path.parent / h).resolve() == index.resolve()]
    assert back, f"{page}: no header link to the site index"
    broken = [h for h in links.hrefs if not _resolves(path, h)]
    assert not broken, f"{page}: links to missing files {broken}"


def test_study_page_header_names_its_data_tables_and_figures(site):
    root, _ = site
    page = root / "toy" / "index.html"
    links = _links(page)
    assert "results.csv" in links.header and "summary.md" in links.header
    assert {"tables/intervals.csv", "tables/intervals.tex", "figures/a-line.png", "figures/a-line.svg"} <= set(
        links.hrefs)
    camp = _links(root / "toy" / "campaign" / "index.html")
    assert "data/" in camp.header and "../index.html" in camp.header  # the study page above it


def test_empty_site_says_which_command_writes_each_part(tmp_path):
    index = write_site_index(tmp_path)
    text = index.read_text()
    for command in ("make report", "make campaign", "make teach", "boundid excitation", "make bench"):
        assert command in text
    assert _links(index).hrefs == ["#papers", "#studies", "#campaigns", "#teaching", "#excitation", "#benchmarks"]


def test_folded_section_and_findings_box(tmp_path):
    page = Page("p", "d").findings(["The bound holds."], attention=True)
    page.section("Details", "hidden text", folded="Show the details")
    html = page.to_html()
    assert '<div class="findings attention"><b>Findings</b><ul><li>The bound holds.</li>' in html
    assert html.index("Findings") < html.index("<p>d</p>")
    assert '<details class="fold"><summary>Show the details</summary>' in html
    with pytest.raises(InputError):
        Page("p").findings([])


def test_bench_command_refreshes_the_site_index(tmp_path):
    """`boundid bench --page-only` rebuilds the benchmark page from its CSVs and rewrites the site
    index, which then links it."""
    from boundid.cli import main

    (tmp_path / "benchmarks").mkdir()
    pd.DataFrame({"case": ["a"], "time_s": [1.0]}).to_csv(tmp_path / "benchmarks" / "toy.csv", index=False)
    assert main(["bench", "--page-only", "--out", str(tmp_path)]) == 0
    assert "benchmarks/index.html" in _links(tmp_path / "index.html").hrefs
