"""Monte Carlo campaign throughput: replicates per minute, in-process and on a Dask LocalCluster."""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import pandas as pd

from boundid.bench.goals import Goal
from boundid.studies.campaign import run_campaign
from boundid.studies.config import load_study
from boundid.studies.scenarios import Scenario

STUDY = Path(__file__).resolve().parents[3] / "studies" / "direct_drive_rls.toml"

GOALS = """
Campaign throughput on the direct-drive study (studies/direct_drive_rls.toml) in campaign mode
(every estimator, exact LP bounds; no SDP ellipsoids, no validation experiment), with the
experiment SHORTENED to 5 s (2 s with --quick) instead of the study's 10 s.

- Cases: in this process (no cluster), and a dask.distributed LocalCluster of 1 and 2 worker
  processes (1 thread each). Each case runs the same replicates into a fresh folder; the wall
  time includes the cluster's start-up and shut-down (about 2 s), as a user would see it.
- `ratio` = replicates per minute of the case / that of the 1-worker LocalCluster (the reference).
- Goal: 2 workers >= 1.6x one worker on an idle 2-core machine; the campaign's overhead over the
  in-process loop (Dask start-up, scatter, Parquet files) stays under 20 % of the run.
- `mean_replicate_s`: one replicate's own wall time inside its worker (slower when the cores are
  shared); `load_avg_1min`: the machine's load when the case started. The 2 cores are shared with
  other jobs: the 2-worker speed-up is bounded by the cores free at the time of the run.
- Overhead: the in-process row's `ratio` is (1-worker campaign time) / (in-process loop time).
"""

_SIZE = "{replicates} replicates of a {duration_s:g} s experiment"
GOAL_CHECKS = (
    Goal("2 workers over 1 worker (replicates per minute)", {"case": r"LocalCluster, 2 workers"}, "ratio", ">=", 1.6,
         "x", size=_SIZE),
    Goal("campaign overhead: 1-worker campaign time / in-process loop time", {"case": "in-process loop"}, "ratio",
         "<=", 1.2, "x", size=_SIZE),
)


def _case(cfg, replicates: int, workers: int, label: str) -> dict:
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        res = run_campaign(cfg, replicates, (Scenario("study"),), Path(tmp) / "campaign", workers=workers)
        wall = time.perf_counter() - t0
        per = res.table.drop_duplicates(["scenario", "replicate"])["replicate_time_s"]
    return {"case": label, "workers": workers, "replicates": replicates, "wall_s": wall,
            "replicates_per_min": 60.0 * replicates / wall, "mean_replicate_s": float(per.mean()),
            "load_avg_1min": load}


def run(quick: bool = False) -> pd.DataFrame:
    cfg = load_study(STUDY)
    duration = 2.0 if quick else 5.0
    cfg = replace(cfg, experiment=replace(cfg.experiment, duration_s=duration))
    replicates = 4 if quick else 16
    # warm the numba caches in this process so the in-process case does not pay compilation
    run_campaign(cfg, 1, (Scenario("study"),), Path(tempfile.mkdtemp()) / "warm", workers=0)
    rows = [_case(cfg, replicates, 0, "in-process loop"), _case(cfg, replicates, 1, "LocalCluster, 1 worker"),
            _case(cfg, replicates, 2, "LocalCluster, 2 workers")]
    df = pd.DataFrame(rows)
    ref = df.loc[df["workers"] == 1, "replicates_per_min"].iloc[0]
    df["ratio"] = df["replicates_per_min"] / ref
    df["duration_s"] = duration
    return df
