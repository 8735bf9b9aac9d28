"""Nothing but boundid on stdout: no solver banner or log, whatever the solver versions.

Reference: the commands' own output as cli.py writes it. ``--json`` prints one JSON document and
nothing else, so the whole of stdout must parse with json.loads (no leading lines stripped);
``run --quiet`` and ``report --quiet`` print one verdict line per study, "<name>: OK: ..." or
"<name>: ATTENTION: ...", and nothing else. highspy 1.16 printed "Running HiGHS 1.16.0 (git hash:
...): Copyright ..." and a second line from its constructor (once per process, before any option
could be set), which broke both; every command runs here as a subprocess, a fresh process whose C
stdout is the captured one. The tiny studies construct HiGHS in their validation stage (the
best-approximation LP) and solve conic programs with Clarabel through cvxpy (the physically
consistent bounds of the direct-drive arm); certify solves its SDPs with Clarabel.
"""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from boundid.cli import build_parser
from tiny_study import tiny_study

BOUNDID = str(Path(sys.executable).with_name("boundid"))
#: words of solver banners and logs (HiGHS, Clarabel, cvxpy, SCS), none of which boundid prints
BANNER = re.compile(r"HiGHS|Clarabel|CVXPY|SCS|Running|Copyright|licen[cs]e|THIRD_PARTY")

STUDY = """
[[estimators]]
method = "wls"
regressions = ["filtered_dynamic"]

[[estimators]]
method = "obe"
regressions = ["filtered_dynamic"]
e_max = 6.0

[exact]
regression = "filtered_dynamic"
e_max = 6.0
"""


def _boundid(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([BOUNDID, *args], cwd=cwd, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "MPLBACKEND": "Agg"})


def _no_banner(res: subprocess.CompletedProcess) -> None:
    for stream, text in (("stdout", res.stdout), ("stderr", res.stderr)):
        bad = [line for line in text.splitlines() if BANNER.search(line)]
        assert not bad, f"solver output on {stream}: {bad}"


def _strict_json(text: str):
    def bad(name):
        raise ValueError(f"not strict JSON: {name}")
    return json.loads(text, parse_constant=bad)


def _certify_files(tmp: Path) -> list[str]:
    """A regression of 40 rows, p = 2, no prior box (so the exact bounds start with HiGHS), and an
    ellipsoid about the truth that contains its polytope."""
    rng = np.random.default_rng(3)
    W = rng.normal(size=(40, 2))
    theta = np.array([1.0, -2.0])
    pd.DataFrame({"w1": W[:, 0], "w2": W[:, 1], "y": W @ theta + rng.uniform(-0.5, 0.5, 40),
                  "e_max": 0.5}).to_csv(tmp / "rows.csv", index=False)
    (tmp / "final.json").write_text(json.dumps({"center": theta.tolist(), "shape": [[4.0, 0.0], [0.0, 4.0]]}))
    return ["--regression", "rows.csv", "--ellipsoid", "final.json"]


#: how to run each command that has --json, on small inputs it writes into the folder given
JSON_COMMANDS = {"certify": _certify_files}


def _json_commands() -> set[str]:
    """The subcommands of cli.py that take --json."""
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    return {name for name, p in sub.choices.items() if any("--json" in a.option_strings for a in p._actions)}


def test_every_json_command_is_tested():
    assert _json_commands() == set(JSON_COMMANDS), "add the new --json command to JSON_COMMANDS"


@pytest.mark.parametrize("command", sorted(JSON_COMMANDS))
def test_json_stdout_is_one_json_document(command, tmp_path):
    """The whole stdout parses as strict JSON (with the SDP comparison: HiGHS and Clarabel both run)."""
    res = _boundid([command, *JSON_COMMANDS[command](tmp_path), "--json"], tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    _no_banner(res)
    out = _strict_json(res.stdout)
    assert out["contains_polytope"] is True


def test_highs_prints_nothing_from_construction_to_run():
    """The working set's HiGHS, in a fresh process: silent from its constructor on."""
    code = ("from boundid.sets._working_set import _QuietHighs\n"
            "h = _QuietHighs()\n"
            "h.addVars(2, [0.0, 0.0], [1.0, 1.0])\n"
            "h.changeColsCost(2, [0, 1], [1.0, -1.0])\n"
            "h.run()\n"
            "assert h.getSolution().col_value == [0.0, 1.0]\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout == "" and res.stderr == ""


def _verdicts_only(res: subprocess.CompletedProcess, names: list[str]) -> None:
    """stdout is one verdict line per study, in order, and nothing else."""
    assert res.returncode == 0, res.stderr[-2000:]
    _no_banner(res)
    lines = res.stdout.splitlines()
    assert len(lines) == len(names), res.stdout
    for name, line in zip(names, lines, strict=True):
        assert re.fullmatch(rf"{name}: (OK|ATTENTION): .+\.", line), line


def test_run_quiet_prints_only_the_verdict_line(tmp_path):
    (tmp_path / "s.toml").write_text(tiny_study("dd_stdout", 7) + STUDY)
    _verdicts_only(_boundid(["run", "s.toml", "--quiet", "--out", "out"], tmp_path), ["dd_stdout"])


@pytest.mark.slow
def test_report_quiet_prints_only_the_verdict_lines(tmp_path):
    """Two studies, two at a time (as `make report` runs them on two cores): each in a study process
    forked from the fork server."""
    (tmp_path / "studies").mkdir()
    for name, seed in (("dd_a", 7), ("dd_b", 8)):
        (tmp_path / "studies" / f"{name}.toml").write_text(tiny_study(name, seed) + STUDY)
    res = _boundid(["report", "--studies", "studies", "--out", "out", "--quiet", "--jobs", "2"], tmp_path)
    _verdicts_only(res, ["dd_a", "dd_b"])
