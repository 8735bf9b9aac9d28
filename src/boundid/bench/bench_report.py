"""Time of `make report`'s work: `boundid report` on the repository's studies, in a fresh process."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

from boundid.bench.goals import Goal

ROOT = Path(__file__).resolve().parents[3]

GOALS = """
`boundid report` -- what `make report` runs once the environment is installed -- on the repository's
studies (every studies/*.toml: the two papers' H4 and direct-drive studies, the TX40 on its real
recording, and the full arms: the six-joint UR5 and the Panda), into a temporary folder, in a fresh
Python process, as a user would start it: imports, simulation, every estimator, the exact optima (LP
bounds, SDP ellipsoids), the validation experiments and the pages with their figures. The studies
run at once, one per core (`--jobs`' default: each in a process of its own, the longest experiments
first). `wall_s`: its wall time; `cpu_s`: user + system CPU time of the command and its study
processes together (what the work would take on one idle core), with the 1-minute load average when
it started. The rows "study <name>" give each study's own run time as its page records it (the sum
of its stages: data, regressions, estimators, exact optima, physical bounds, validation; the page
and its figures not included), so the cost of each study is visible. The run is repeated ROUNDS
times (the machine is shared: one run's wall time varies by a third); the rows are those of the
median round, `wall_min_s` and `wall_max_s` the range over the rounds. With --quick the run is
skipped (it has no smaller size).

Goal (time of a report): `make report` <= 30 s, install excluded.
"""

GOAL_CHECKS = (
    Goal("make report (studies and pages, install excluded)", {"case": "boundid report"}, "wall_s", "<=", 30.0, "s",
         size="{studies} studies, median of {rounds} runs ({wall_min_s:.1f}-{wall_max_s:.1f} s)", cpu_column="cpu_s"),
)


#: runs of `boundid report`; the median one is reported
ROUNDS = 3


def run(quick: bool = False) -> pd.DataFrame:
    studies = sorted((ROOT / "studies").glob("*.toml"))
    if quick:
        return pd.DataFrame([{"case": "boundid report", "studies": len(studies), "wall_s": float("nan"),
                              "cpu_s": float("nan"), "load_avg_1min": os.getloadavg()[0]}])
    rounds = sorted((_one_run(len(studies)) for _ in range(ROUNDS)), key=lambda df: float(df["wall_s"].iloc[0]))
    walls = [float(df["wall_s"].iloc[0]) for df in rounds]
    out = rounds[len(rounds) // 2].copy()
    out["rounds"] = ROUNDS
    out.loc[0, "wall_min_s"], out.loc[0, "wall_max_s"] = min(walls), max(walls)
    return out


def _one_run(n_studies: int) -> pd.DataFrame:
    """One `boundid report` into a temporary folder: its row and one row per study."""
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import sys; from boundid.cli import main; sys.exit(main())", "report",
                        "--studies", str(ROOT / "studies"), "--out", str(Path(tmp) / "reports"), "--quiet"],
                       check=True, cwd=ROOT)
        wall = time.perf_counter() - t0
        per_study = [{"case": f"study {folder.name}", "studies": 1, "wall_s": _stage_time(folder),
                      "cpu_s": float("nan"), "load_avg_1min": load}
                     for folder in sorted((Path(tmp) / "reports").iterdir()) if (folder / "tables/setup.csv").is_file()]
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return pd.DataFrame([{"case": "boundid report", "studies": n_studies, "wall_s": wall, "cpu_s": cpu,
                          "load_avg_1min": load}] + per_study)


def _stage_time(folder: Path) -> float:
    """The study's run time [s] from its page's set-up table ("run time" = "<seconds> s (stages...)")."""
    setup = pd.read_csv(folder / "tables" / "setup.csv", index_col=0).iloc[:, 0]
    return float(str(setup["run time"]).split()[0])
