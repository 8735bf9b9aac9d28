"""The site index's front matter: what boundid is, what the studies found, the papers.

Reference: the figure's numbers recomputed here from each study's results.csv with plain pandas
(mean over the parameters of (hi - lo) / exact LP width, guaranteed sets on the exact regression),
the papers' full references from docs/references.md, and the verdict files as written.
"""

from __future__ import annotations

import json
import shutil
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from boundid.report.figure_check import PAGE_WIDTH_PX, assert_nothing_clipped
from boundid.report.front_page import (
    FIGURE_NAME,
    set_family,
    study_width_ratios,
    width_ratio_figure,
    width_ratios_across_studies,
)
from boundid.report.glossary import full_reference
from boundid.report.html import Page, write_site_index
from boundid.report.verdict import run_verdict
from boundid.report.verdict_file import write_verdict_file
from tiny_study import run_study_text, tiny_study

SETS = """
[[estimators]]
method = "wls"
regressions = ["filtered_dynamic"]

[[estimators]]
method = "obe"
label = "OBE-factorized"
regressions = ["filtered_dynamic"]

[[estimators]]
method = "box"
label = "Box"
regressions = ["filtered_dynamic"]
{more}
[exact]
regression = "filtered_dynamic"
e_max = 6.0
"""
ZONOTOPE = """
[[estimators]]
method = "zonotope"
label = "Zonotope"
regressions = ["filtered_dynamic"]
"""
NO_EXACT = """
[[estimators]]
method = "wls"
regressions = ["filtered_dynamic"]
"""


class _Text(HTMLParser):
    """The text of a page (whitespace folded), its hrefs and its <img> sources."""

    def __init__(self):
        super().__init__()
        self.parts, self.hrefs, self.images = [], [], []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "a" and a.get("href"):
            self.hrefs.append(a["href"])
        if tag == "img":
            self.images.append(a.get("src", ""))

    def handle_data(self, data):
        self.parts.append(data)

    @property
    def text(self) -> str:
        return " ".join(" ".join(self.parts).split())


def _read(page: Path) -> _Text:
    p = _Text()
    p.feed(page.read_text(encoding="utf-8"))
    return p


def _write_study(root: Path, folder: Path, name: str, text: str) -> None:
    """Run a study and write what the index reads: results.csv, verdict.json and a page."""
    cfg, r = run_study_text(folder, name, text)
    out = root / name
    out.mkdir(parents=True)
    r.table.to_csv(out / "results.csv", index=False)
    write_verdict_file(r, out, run_verdict(r).line)
    Page(cfg.title, f"The tiny study {name}.").section("Results", "words").write(out / "index.html")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """Three tiny direct-drive studies: two with exact bounds and guaranteed sets (OBE and box; the
    second a zonotope too, another seed), one with WLS alone (no [exact]); then the site index."""
    root, folder = tmp_path_factory.mktemp("reports"), tmp_path_factory.mktemp("studies")
    _write_study(root, folder, "fp_a", tiny_study("fp_a", 3) + SETS.format(more=""))
    _write_study(root, folder, "fp_b", tiny_study("fp_b", 4) + SETS.format(more=ZONOTOPE))
    _write_study(root, folder, "fp_wls", tiny_study("fp_wls", 5) + NO_EXACT)
    return root, write_site_index(root)


def _recomputed(results_csv: Path) -> dict[str, float]:
    """{estimator: mean over parameters of its width over the exact LP width}, by hand."""
    df = pd.read_csv(results_csv)
    exact = df[df["kind"] == "exact"].set_index("parameter")
    reg = exact["regression"].iloc[0]
    lp = exact["hi"] - exact["lo"]
    out = {}
    for est, d in df[(df["kind"] == "guaranteed") & (df["regression"] == reg)].groupby("estimator"):
        d = d.set_index("parameter").loc[lp.index]
        out[est] = float(np.mean((d["hi"] - d["lo"]) / lp))
    return out


def test_figure_numbers_are_those_of_the_results_files(site):
    root, index = site
    shown = pd.read_csv(root / f"{FIGURE_NAME}.csv")
    assert sorted(shown["study"].unique()) == ["fp_a", "fp_b"]
    for study in ("fp_a", "fp_b"):
        expected = _recomputed(root / study / "results.csv")
        got = shown[shown["study"] == study].set_index("estimator")["mean_width_over_exact"].to_dict()
        assert got.keys() == expected.keys() and len(got) >= 2
        for est, value in expected.items():
            assert got[est] == pytest.approx(value, rel=1e-12), (study, est)
            assert value >= 1.0 - 1e-9  # a guaranteed set holds the polytope: never narrower than its LP hull
    assert set(shown[shown["study"] == "fp_b"]["family"]) == {"OBE-factorized", "Box", "Zonotope"}
    page = _read(index)
    assert any(src.startswith("data:image/png;base64,") for src in page.images)
    for ext in ("png", "svg", "csv"):
        assert (root / f"{FIGURE_NAME}.{ext}").is_file() and f"{FIGURE_NAME}.{ext}" in page.hrefs


def test_figure_passes_the_figure_check(site):
    root, _ = site
    ratios = width_ratios_across_studies(root, ["fp_a", "fp_b", "fp_wls"])
    assert_nothing_clipped(width_ratio_figure(ratios.table), "set width ratios", display_width_px=PAGE_WIDTH_PX)
    many = pd.concat([ratios.table.assign(study=ratios.table["study"] + f"_{k}") for k in range(6)])
    assert_nothing_clipped(width_ratio_figure(many), "12 studies", display_width_px=PAGE_WIDTH_PX)


def test_study_without_exact_bounds_is_left_out_and_named(site):
    root, index = site
    assert study_width_ratios(root / "fp_wls" / "results.csv").startswith("no exact LP bounds")
    text = _read(index).text
    caption = text[text.index("Figure."):]
    assert "Left out: fp_wls (no exact LP bounds" in caption
    assert "fp_a" not in caption.split("Left out:")[1].split(".")[0]


def test_papers_are_cited_in_full_with_links(site):
    _, index = site
    page = _read(index)
    for key in ("H4Paper", "DirectDrivePaper"):
        assert full_reference(key) in page.text.replace(f" [{key}]", "")
        assert f"references.html#{key}" in page.hrefs
    assert {"references.html", "glossary.html"} <= set(page.hrefs)
    assert "boundid is a reference and comparison suite for robot dynamic identification" in page.text


def test_findings_table_reads_the_verdict_files_and_a_failed_gate(site, tmp_path):
    root, index = site
    text = _read(index).text
    for study in ("fp_a", "fp_b", "fp_wls"):
        doc = json.loads((root / study / "verdict.json").read_text())
        assert doc["verdict_line"].removeprefix(f"{study}: ") in text
    assert "pass every gate check" in text
    copy = tmp_path / "site"
    shutil.copytree(root, copy)
    path = copy / "fp_b" / "verdict.json"
    doc = json.loads(path.read_text())
    for c in doc["checks"]:
        if c["id"] == "truth_in_guaranteed_sets":
            c["status"], c["value"] = "fail", 1
    doc["failed_gates"], doc["exit_code"] = ["truth_in_guaranteed_sets"], 3
    path.write_text(json.dumps(doc))
    html = write_site_index(copy).read_text(encoding="utf-8")
    row = html[html.index('href="fp_b/index.html">fp_b</a>'):].split("</tr>")[0]
    assert '<td class="words fail">truth_in_guaranteed_sets</td>' in row
    assert "1 of 3 studies (3 simulated) fails a gate check: fp_b (truth_in_guaranteed_sets)" in _read(
        copy / "index.html").text


def test_no_study_no_figure_and_stale_files_go(tmp_path):
    for ext in ("png", "svg", "csv"):
        (tmp_path / f"{FIGURE_NAME}.{ext}").write_text("stale")
    text = _read(write_site_index(tmp_path)).text
    assert not list(tmp_path.glob(f"{FIGURE_NAME}.*"))
    assert "boundid is a reference" in text and full_reference("H4Paper") in text.replace(" [H4Paper]", "")


def test_set_family_drops_the_settings():
    assert set_family("OBE-factorized (volume)") == "OBE-factorized"
    assert set_family("Limited polytope (K = 56 strips, LP every 1400 samples)") == "Limited polytope"
    assert set_family("Zonotope recursion (segments, <= 2p generators)") == "Zonotope"
    assert set_family("OBE ∩ prior box") == "OBE ∩ prior box"


def test_documentation_site_is_linked_when_it_exists(tmp_path):
    Page("Toy", "A study.").section("Results", "words").write(tmp_path / "toy" / "index.html")
    assert "docs/index.html" not in _read(write_site_index(tmp_path)).hrefs
    Page("boundid documentation", "How to use boundid.", home="../index.html").section("Start", "words").write(
        tmp_path / "docs" / "index.html")
    index = write_site_index(tmp_path)
    page = _read(index)
    assert page.hrefs.count("docs/index.html") == 1 and "boundid documentation" in page.text
    html = index.read_text(encoding="utf-8")
    studies = html[html.index('<section id="studies">'):].split("</section>")[0]
    assert "toy/index.html" in studies and "docs/" not in studies  # the documentation is no study
    assert "docs/index.html" in html[html.index('<section id="reference">'):]
