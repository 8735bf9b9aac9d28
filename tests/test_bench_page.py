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
