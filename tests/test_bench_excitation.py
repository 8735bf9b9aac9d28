"""The excitation-search benchmark (boundid.bench.bench_excitation): a small search of the direct-drive
study times every part of every candidate and the two whole calls, the search scores the very
candidates the benchmark timed, a refused draw is recorded and replaced, and the runner's Markdown
states what was measured (studies, candidates, the ratio).

Reference: design_excitation's own scores (the candidate rows must reproduce them: same seeded
stream), and the ratio's definition guaranteed_s / classical_s; the direct-drive study (p = 9,
open loop) keeps each case under a second.
"""

import json
import re

import numpy as np
import pandas as pd
import pytest

from boundid.bench import bench_excitation as B
from boundid.bench.__main__ import run_topic, topics
from boundid.errors import InputError
from boundid.studies.excitation import Family

TIMES = ["draw_s", "rows_s", "guaranteed_s", "classical_s", "time_s"]
CPU = ["draw_cpu_s", "rows_cpu_s", "guaranteed_cpu_s", "classical_cpu_s", "cpu_s"]


@pytest.fixture(scope="module")
def direct_drive():
    B.warm_up()
    return pd.DataFrame(B.study_rows("direct_drive_rls", 2))


def test_the_topic_is_registered():
    assert "excitation" in topics()
    assert not getattr(B, "GOAL_CHECKS", ())  # a cost table: no goal stated


def test_every_candidate_has_positive_times_and_the_ratio_of_its_two_scorings(direct_drive):
    df = direct_drive
    assert list(df.columns) == list(B._row("", "").keys())
    assert list(df.case) == ["candidate", "candidate", "median over candidates", "design_excitation",
                             "compare_criteria", "search + comparison"]
    assert (df.study == "direct_drive_rls").all() and (df.p == 9).all() and (df.candidates == 2).all()
    cand = df[df.case == "candidate"]
    assert list(cand.candidate) == [0, 1] and (cand.N == 202).all()   # 2 joints x 101 samples at 10 Hz
    values = cand[TIMES + CPU + ["ratio", "cpu_ratio"]].to_numpy(dtype=float)
    assert np.all(np.isfinite(values)) and np.all(values > 0), cand[TIMES + CPU]
    assert np.allclose(cand.ratio, cand.guaranteed_s / cand.classical_s)
    assert np.allclose(cand.time_s, cand[TIMES[:-1]].sum(axis=1))
    assert (cand.ratio > 1).all()   # an LP per parameter bound against one SVD and one slogdet
    assert np.all(np.isfinite(df.load_avg)) and (df.load_avg >= 0).all()


def test_the_whole_calls_are_timed_and_score_the_timed_candidates(direct_drive):
    rows = direct_drive.set_index("case")
    for case in ("design_excitation", "compare_criteria", "search + comparison"):
        assert np.isfinite(rows.time_s[case]) and rows.time_s[case] > 0 and rows.cpu_s[case] > 0, case
    assert "the same scores as the candidate rows" in rows.detail["design_excitation"]
    assert rows.time_s["search + comparison"] == pytest.approx(rows.time_s["design_excitation"]
                                                             + rows.time_s["compare_criteria"])
    assert rows.N["compare_criteria"] > rows.N["design_excitation"]   # the study's row rate, not the search's
    assert re.search(r"\d distinct picks? of 4 ", rows.detail["compare_criteria"])


def test_a_refused_draw_is_recorded_and_replaced(monkeypatch):
    """A family whose every other draw is refused: 2 candidates take 4 draws, 2 of them refused."""
    cfg = B.study_config("direct_drive_rls", 2)
    model = B.make_robot(cfg.robot, cfg.robot_options)
    real = B.family(cfg, model)
    calls = []

    def draw(rng):
        calls.append(1)
        if len(calls) % 2:
            raise InputError("out of the limits")
        return real.draw(rng)

    monkeypatch.setattr(B, "family", lambda *_: Family("test", draw, real.motion))
    rows, scores = B.candidate_rows(cfg, model)
    assert len(scores) == 2 and len(rows) == 4
    refused = [r for r in rows if not np.isfinite(r["candidate"])]
    assert [r["detail"] for r in refused] == ["draw 0 refused: InputError: out of the limits",
                                              "draw 2 refused: InputError: out of the limits"]
    assert [r["candidate"] for r in rows if np.isfinite(r["candidate"])] == [0, 1]


def test_the_runner_writes_a_markdown_that_states_what_it_measured(tmp_path, monkeypatch):
    """`--quick` on the direct-drive study alone: QUICK_CANDIDATES candidates, and the Markdown names
    the studies, both candidate counts, the ratio and the whole calls, with the machine line."""
    monkeypatch.setattr(B, "STUDIES", ("direct_drive_rls",))
    md = run_topic("excitation", tmp_path, quick=True)
    df = pd.read_csv(tmp_path / "excitation.csv")
    assert (df.candidates == B.QUICK_CANDIDATES).all()
    assert (df.case == "candidate").sum() == B.QUICK_CANDIDATES
    assert json.loads((tmp_path / "excitation.json").read_text())["quick"] is True
    assert md == (tmp_path / "excitation.md").read_text()
    for text in ("# Benchmark: excitation", "studies/direct_drive_rls.toml", "studies/h4_obe.toml",
                 "studies/ur5_urdf.toml", f"**{B.CANDIDATES}**", f"**{B.QUICK_CANDIDATES}**",
                 "guaranteed_s / classical_s", "design_excitation", "compare_criteria", "Machine:", "(--quick).",
                 "No goals stated.", "| study", "ratio"):
        assert text in md, text
