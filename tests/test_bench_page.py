"""The benchmark page: goals judged from the CSV files alone, machine and load shown, no `nan`.

Reference: a synthetic CSV written here whose verdicts are known by construction (a value above,
one below its target, a wall-clock rate that misses its goal while its CPU-time rate meets it, an
empty cell, a missing column, a missing row), read back from the page with Python's html.parser;
and the goal records of the real benchmark modules, each of which must select exactly one row of
the CSV its module wrote (the committed reports/benchmarks/*.csv), so a goal cannot silently
judge nothing.
"""

import json
import math
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from boundid.bench.__main__ import main as bench_main
from boundid.bench.__main__ import topics
from boundid.bench.goals import Goal, judge, machine, select
from boundid.bench.page import topic_module, write_page
from boundid.errors import InputError

ROOT = Path(__file__).resolve().parents[1]


class _Cells(HTMLParser):
    """The rows of the first table (the goals table) as lists of cell texts."""

    def __init__(self):
        super().__init__()
        self.rows, self._row, self._cell, self._tables = [], None, None, 0

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self._tables += 1
        if self._tables == 1 and tag == "tr":
            self._row = []
        if self._tables == 1 and tag == "td":
            self._cell = ""

    def handle_endtag(self, tag):
        if tag == "td" and self._cell is not None:
            self._row.append(" ".join(self._cell.split()))
            self._cell = None
        if tag == "tr" and self._row is not None:
            if self._row:
                self.rows.append(self._row)
            self._row = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data


TOY_GOALS = [
    Goal("fast enough", {"case": "a"}, "time_s", "<=", 1.0, "s", size="N = {N:,}"),
    Goal("too slow", {"case": "b"}, "time_s", "<=", 1.0, "s", size="N = {N:,}"),
    Goal("rate", {"case": "a"}, "rate", ">=", 5.0, "M/s", cpu_column="cpu_rate"),
    Goal("empty cell", {"case": "b"}, "rate", ">=", 5.0, "M/s"),
    Goal("no column", {"case": "a"}, "memory_gb", "<=", 4.0, "GB"),
    Goal("no row", {"case": "c"}, "time_s", "<=", 1.0, "s"),
]


def _toy(folder: Path, with_machine: bool = True) -> None:
    pd.DataFrame({"case": ["a", "b"], "N": [100_000, 2_000], "time_s": [0.5, 1.5], "rate": [4.0, np.nan],
                  "cpu_rate": [6.0, np.nan], "load_avg": [2.5, 0.25], "note": ["x", np.nan]}).to_csv(
        folder / "toy.csv", index=False)
    if with_machine:
        meta = {**machine(), "started": "2024-01-01T00:00:00+00:00", "elapsed_s": 3.0, "quick": False}
        (folder / "toy.json").write_text(json.dumps(meta))


def test_page_marks_each_goal_from_a_synthetic_csv(tmp_path):
    _toy(tmp_path)
    page = write_page(tmp_path, goals={"toy": TOY_GOALS}, descriptions={"toy": "A toy benchmark."})
    text = page.read_text()
    cells = _Cells()
    cells.feed(text)
    verdict = {row[0].split(": ", 1)[1]: row[1] for row in cells.rows}
    assert verdict["fast enough"] == "met" and verdict["too slow"] == "missed"
    assert verdict["rate"] == "met on CPU time only"
    assert verdict["empty cell"].startswith("not measured: the benchmark wrote no value in 'rate'")
    assert verdict["no column"].startswith("not measured: toy.csv has no column 'memory_gb'")
    assert verdict["no row"].startswith("not measured: toy.csv has no row with case = c")
    by_goal = {row[0].split(": ", 1)[1]: row for row in cells.rows}
    assert by_goal["fast enough"][2] == "0.5 s" and by_goal["fast enough"][4] == "N = 100,000"
    assert by_goal["fast enough"][5] == "2.50" and by_goal["too slow"][5] == "0.25"
    assert by_goal["rate"][2] == "4 M/sCPU time: 6 M/s"  # two lines in the cell
    assert "6 goals: 1 met, 1 met on CPU time only, 1 missed, 3 not measured." in text
    assert not re.search(r"\bnan\b", text, re.I), "an empty number must read 'not measured', never nan"
    m = machine()
    for fact in (m["cpu"], f"{m['cores']} cores", f"numpy {m['versions']['numpy']}",
                 f"numba {m['versions']['numba']}", f"highspy {m['versions']['highspy']}",
                 f"clarabel {m['versions']['clarabel']}", "load average"):
        assert fact in text


def test_page_says_when_the_machine_was_not_recorded_and_when_no_goal_is_stated(tmp_path):
    _toy(tmp_path, with_machine=False)
    text = write_page(tmp_path, goals={}, descriptions={}).read_text()
    assert "Machine not recorded" in text and "no goals stated" in text and "No goals found." in text


def test_judge_selects_by_regular_expression_and_rejects_a_bad_operator():
    df = pd.DataFrame({"case": ["bounds p=14 N=1e+06", "bounds p=14 N=1e+07"], "time_s": [0.9, 9.0]})
    assert len(select(df, {"case": r"bounds p=14 N=1e\+0[67]"})) == 2
    v = judge(Goal("t", {"case": r"bounds p=14 N=1e\+07"}, "time_s", "<=", 8.0, "s"), df, "sets")
    assert v.status == "missed" and math.isclose(v.value, 9.0)
    with pytest.raises(InputError):
        Goal("t", {}, "time_s", "<", 1.0)


def test_page_only_rebuilds_the_page_without_measuring(tmp_path):
    """`python -m boundid.bench --page-only` writes index.html from the files and touches no CSV."""
    _toy(tmp_path)
    before = (tmp_path / "toy.csv").read_bytes()
    assert bench_main(["--out", str(tmp_path), "--page-only"]) == 0
    assert (tmp_path / "index.html").is_file() and (tmp_path / "toy.csv").read_bytes() == before


@pytest.mark.parametrize("topic", topics())
def test_every_goal_of_a_benchmark_selects_one_row_of_its_csv(topic):
    """Each GOAL_CHECKS record of bench_<topic> selects exactly one row of the committed CSV
    (quick runs write other sizes, so this reads the full run in reports/benchmarks/)."""
    csv = ROOT / "reports" / "benchmarks" / f"{topic}.csv"
    if not csv.is_file():
        pytest.skip(f"no {csv.name} (run make bench)")
    df = pd.read_csv(csv)
    for goal in getattr(topic_module(topic), "GOAL_CHECKS", ()):
        assert len(select(df, goal.where)) == 1, f"{topic}: goal {goal.name!r} {goal.where} selects no single row"


MARKDOWN_GOALS = """
The **toy** benchmark times `fit` (see :func:`boundid.bench.goals.judge` and :class:`~boundid.bench.goals.Goal`),
*wall clock*; its replicate files are in [the data folder](data/), the runs in [runs](runs) and the
summary in [its index](done/) and [the CSV](toy.csv).

* **Quality**: `width_over_lp` = mean width over the LP width;
  `contains_truth`.
* ``stored`` = numbers kept between samples.

| case | rate |
|:--|--:|
| `a` | **4** |
"""

MARKDOWN_REPORT = """# Mutation testing

Generated by `make mutation`; score **69.4%** (:func:`tools.mutation.report`).

## By module

| module | killed |
|---|---:|
| `boundid/sets/box.py` | 1 |
"""


class _Rendered(HTMLParser):
    """The page's visible text (outside <style>, <script> and <code>), its hrefs, and the text
    of its <code> elements and headings."""

    def __init__(self):
        super().__init__()
        self.text, self.hrefs, self.code, self.headings = [], [], [], []
        self._skip, self._code, self._heading = 0, None, None

    def handle_starttag(self, tag, attrs):
        self._skip += tag in ("style", "script")
        if tag == "code":
            self._code = ""
        if tag in ("h2", "h3", "h4"):
            self._heading = (tag, "")
        if tag == "a":
            self.hrefs.append(dict(attrs).get("href", ""))

    def handle_endtag(self, tag):
        self._skip -= tag in ("style", "script")
        if tag == "code" and self._code is not None:
            self.code.append(self._code)
            self._code = None
        if self._heading and tag == self._heading[0]:
            self.headings.append(self._heading)
            self._heading = None

    def handle_data(self, data):
        if self._skip:
            return
        if self._code is not None:
            self._code += data
        else:
            self.text.append(data)
        if self._heading:
            self._heading = (self._heading[0], self._heading[1] + data)


def test_page_renders_markdown_and_links_no_folder(tmp_path):
    """A benchmark's description and a Markdown report beside the page are rendered: no literal
    **, backtick or :func: role in the page's text, code shown as code, tables as tables; a link to
    a folder without index.html is plain text, one with an index links the index, and no href of the
    page ends in "/" or names a folder without index.html."""
    _toy(tmp_path)
    (tmp_path / "mutation.md").write_text(MARKDOWN_REPORT)
    for folder in ("data", "runs", "done"):
        (tmp_path / folder).mkdir()
    (tmp_path / "done" / "index.html").write_text("<p>done</p>")
    text = write_page(tmp_path, goals={"toy": TOY_GOALS}, descriptions={"toy": MARKDOWN_GOALS}).read_text()
    page = _Rendered()
    page.feed(text)
    visible = "".join(page.text)
    for markup in ("**", "`", ":func:", ":class:"):
        assert markup not in visible, f"literal {markup!r} in the page's text"
    for code in ("fit", "boundid.bench.goals.judge", "boundid.bench.goals.Goal", "width_over_lp", "stored", "a",
                 "make mutation", "tools.mutation.report", "boundid/sets/box.py"):
        assert code in page.code, f"{code!r} not shown as code"
    assert "<strong>toy</strong>" in text and "<em>wall clock</em>" in text and "<strong>69.4%</strong>" in text
    assert "<li><strong>Quality</strong>:" in text
    assert text.count('<table class="data">') >= 4  # goals, the toy's rows, its Markdown table, the report's
    assert ("h2", "Mutation testing") in page.headings and ("h3", "By module") in page.headings
    assert 'href="mutation.md"' in text and 'href="#mutation"' in text
    for href in page.hrefs:
        target = tmp_path / href.split("#")[0] if href and not href.startswith(("#", "../")) else None
        assert not href.endswith("/"), f"a link to a folder: {href}"
        assert target is None or not target.is_dir(), f"a link to a folder: {href}"
    assert "the data folder" in visible and "runs" in visible  # the words stay, without a link
    assert 'href="done/index.html"' in text and 'href="toy.csv"' in text
