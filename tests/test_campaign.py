"""Monte Carlo campaigns: seeds, scenarios, resumability after a kill, Dask cluster, summary, page.

Independent references: numpy's ``SeedSequence.spawn`` (the replicate seeds), the simulation's
true parameters and noise bound (a guaranteed set must hold the truth when the errors respect its
bound), the in-process run (a LocalCluster must give bit-identical results), the files on disk
before a SIGKILL (a restart must not recompute or duplicate them), and numpy sums for coverage.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from boundid.errors import StudyError
from boundid.experiments.measurement import TorqueNoise
from boundid.report.campaign_page import write_campaign_page
from boundid.studies import campaign
from boundid.studies.campaign import (
    campaign_config,
    config_hash,
    replicate_path,
    replicate_rows,
    replicate_seed,
    run_campaign,
    select_estimators,
    summarize,
)
from boundid.studies.config import load_study
from boundid.studies.scenarios import Scenario, load_campaign
from tiny_study import tiny_study

TINY = tiny_study("dd_tiny", 7) + """
[[estimators]]
method = "wls"
regressions = ["filtered_dynamic"]

[[estimators]]
method = "obe"
label = "OBE-factorized"
regressions = ["filtered_dynamic"]
e_max = 6.0

[exact]
regression = "filtered_dynamic"
e_max = 6.0
sdp = ["inner"]
"""

CAMPAIGN = """
[campaign]
replicates = 4

[[campaign.scenarios]]
name = "gaussian_high"
description = "Gaussian torque noise, sigma = 3 N m"
torque = { kind = "gaussian", level = 3.0 }

[[campaign.scenarios]]
name = "coarse_encoder"
encoder_counts_per_rev = 4096

[[campaign.scenarios]]
name = "outliers"
torque = { kind = "bounded_outliers", level = 0.5, outlier_rate = 0.001, outlier_size = 20.0 }

[[campaign.scenarios]]
name = "structural"
structural_error = 0.05
"""

BOUNDED = Scenario("bounded", "uniform noise, 0.5 N m", torque_noise=TorqueNoise("uniform", 0.5))
GAUSS = Scenario("gauss", "Gaussian noise, 1 N m", torque_noise=TorqueNoise("gaussian", 1.0))


@pytest.fixture(scope="module")
def cfg(tmp_path_factory):
    path = tmp_path_factory.mktemp("study") / "dd_tiny.toml"
    path.write_text(TINY)
    return load_study(path)


def test_replicate_seed_is_the_spawned_child():
    """The replicate's seed equals numpy's own spawn of SeedSequence(seed, (crc32(name),)) child r,
    and differs between replicates and scenarios."""
    import zlib

    parent = np.random.SeedSequence(7, spawn_key=(zlib.crc32(b"gauss"),))
    child = parent.spawn(4)[3]
    ours = replicate_seed(7, "gauss", 3)
    assert np.array_equal(ours.generate_state(8), child.generate_state(8))
    assert not np.array_equal(ours.generate_state(8), replicate_seed(7, "gauss", 2).generate_state(8))
    assert not np.array_equal(ours.generate_state(8), replicate_seed(7, "bounded", 3).generate_state(8))


def test_scenarios_parse_and_override_the_experiment(tmp_path, cfg):
    """[campaign] blocks become Scenarios applied with dataclasses.replace; bad keys name file and key."""
    path = tmp_path / "with_campaign.toml"
    path.write_text(TINY + CAMPAIGN)
    spec = load_campaign(replace(cfg, file=path))
    assert spec.replicates == 4
    assert [s.name for s in spec.scenarios] == ["gaussian_high", "coarse_encoder", "outliers", "structural"]
    high = spec.scenarios[0].apply(cfg).experiment
    assert high.torque_noise == TorqueNoise("gaussian", 3.0) and high.encoder_counts_per_rev == 65536
    coarse = spec.scenarios[1].apply(cfg).experiment
    assert coarse.encoder_counts_per_rev == 4096 and coarse.torque_noise == cfg.experiment.torque_noise
    out = spec.scenarios[2].apply(cfg).experiment
    assert out.torque_noise.outlier_rate == 0.001 and out.torque_noise.kind == "bounded_outliers"
    closed = replace(cfg, experiment=replace(cfg.experiment, control="closed_loop"))
    assert spec.scenarios[3].apply(closed).experiment.structural_error == 0.05
    with pytest.raises(StudyError, match="open-loop experiment simulates the identification model"):
        spec.scenarios[3].apply(cfg)  # the open-loop simulation has no structural error to add
    assert [s.name for s in spec.select(["outliers"])] == ["outliers"]
    with pytest.raises(StudyError, match="no scenario 'nope'"):
        spec.select(["nope"])
    bad = tmp_path / "bad.toml"
    bad.write_text(TINY + CAMPAIGN.replace("structural_error", "structural_eror"))
    with pytest.raises(StudyError, match=r"bad\.toml: campaign\.scenarios\[3\]\.structural_eror: unknown key"):
        load_campaign(replace(cfg, file=bad))
    # campaign mode drops the SDPs and keeps the LP bounds; the hash follows the scenario
    cc = campaign_config(cfg, spec.scenarios[0])
    assert cc.exact.sdp == () and cc.exact.lp_bounds and cfg.exact.sdp == ("inner",)
    assert config_hash(cc) != config_hash(campaign_config(cfg, spec.scenarios[1]))


def test_replicate_is_deterministic_and_guarantee_holds(cfg):
    """Same (scenario, replicate) -> same numbers; another replicate -> other noise. With uniform
    0.5 N m torque noise the equation errors respect e_max = 6 N m, so the OBE set and the LP
    bounds must contain every true parameter."""
    a = replicate_rows(cfg, BOUNDED, 1)
    b = replicate_rows(cfg, BOUNDED, 1)
    c = replicate_rows(cfg, BOUNDED, 2)
    num = ["center", "lo", "hi"]
    assert np.array_equal(a[num].to_numpy(), b[num].to_numpy())
    assert not np.allclose(a[num].to_numpy(), c[num].to_numpy())
    p = 9
    assert len(a) == 3 * p and set(a["estimator"]) == {"WLS", "OBE-factorized", "LP exact"}
    obe = a[a["estimator"] == "OBE-factorized"]
    assert np.all(obe["bound_ratio"] <= 1.0)
    for est in ("OBE-factorized", "LP exact"):
        g = a[a["estimator"] == est]
        assert np.all((g["lo"] <= g["truth"]) & (g["truth"] <= g["hi"])), est


def test_campaign_of_chosen_estimators(tmp_path, cfg):
    """[campaign] estimators = [labels]: a replicate runs those estimators only (and the exact LP
    bounds), with the same numbers as the same replicate of every estimator (checked against
    that replicate's rows), into files of their own (another config hash); unknown labels are
    refused naming the study's labels, in the file and in the call."""
    path = tmp_path / "chosen.toml"
    path.write_text(TINY + CAMPAIGN.replace("replicates = 4", 'replicates = 4\nestimators = ["WLS"]'))
    spec = load_campaign(replace(cfg, file=path))
    assert spec.estimators == ("WLS",)
    res = run_campaign(cfg, 1, (BOUNDED,), tmp_path / "c", workers=0, estimators=spec.estimators)
    assert set(res.table["estimator"]) == {"WLS", "LP exact"}
    assert [ec.label for ec in res.config.estimators] == ["WLS"]
    full = replicate_rows(cfg, BOUNDED, 0)
    key = ["estimator", "regression", "parameter"]
    ours = res.table.set_index(key)[["center", "lo", "hi", "truth_in_set"]].sort_index()
    theirs = full.set_index(key).loc[ours.index, ["center", "lo", "hi", "truth_in_set"]]
    pd.testing.assert_frame_equal(ours, theirs)
    assert config_hash(campaign_config(select_estimators(cfg, ["WLS"]), BOUNDED)) != \
        config_hash(campaign_config(cfg, BOUNDED))
    with pytest.raises(StudyError, match=r"no estimator labelled \['Box'\]"):
        run_campaign(cfg, 1, (BOUNDED,), tmp_path / "d", workers=0, estimators=("Box",))
    bad = tmp_path / "bad.toml"
    bad.write_text(TINY + CAMPAIGN.replace("replicates = 4", 'replicates = 4\nestimators = ["Box"]'))
    with pytest.raises(StudyError, match=r"campaign\.estimators: entries must be labels of the study's estimators"):
        load_campaign(replace(cfg, file=bad))


def _files(data_dir: Path) -> dict[str, float]:
    return {p.name: p.stat().st_mtime_ns for p in data_dir.glob("*.parquet")}


def test_in_process_campaign_resumes_and_summary(tmp_path, cfg):
    """A second call skips the finished replicates (files untouched), runs only the new ones and
    never duplicates rows; a stray temporary file is ignored; the summary's coverage equals a
    direct numpy count and the guaranteed sets cover the truth 100 % when the bound holds. The
    standard-form OBE breaks down on these regressors (SolverError): its failure is recorded, with
    NaN values, never replaced by another answer."""
    obe = next(e for e in cfg.estimators if e.method == "obe")
    cfg = replace(cfg, estimators=cfg.estimators + (
        replace(obe, label="OBE-standard", options=replace(obe.options, form="standard")),))
    out = tmp_path / "campaign"
    first = run_campaign(cfg, 2, (BOUNDED, GAUSS), out, workers=0)
    assert sorted(first.computed) == [("bounded", 0), ("bounded", 1), ("gauss", 0), ("gauss", 1)]
    before = _files(out / "data")
    (out / "data" / ".bounded__junk.tmp").write_bytes(b"half-written")
    second = run_campaign(cfg, 3, (BOUNDED, GAUSS), out, workers=0)
    assert sorted(second.computed) == [("bounded", 2), ("gauss", 2)]
    assert sorted(second.skipped) == sorted(first.computed)
    after = _files(out / "data")
    assert all(after[k] == v for k, v in before.items())
    t = second.table
    assert not t.duplicated(["scenario", "replicate", "estimator", "regression", "parameter"]).any()
    assert len(t) == 2 * 3 * 4 * 9
    std = t[t.estimator == "OBE-standard"]
    failed = std[std["kind"] == "failed"]
    assert len(failed) >= 9 and failed["center"].isna().all() and std.loc[std.kind != "failed", "failure"].isna().all()
    assert failed["failure"].str.startswith("SolverError: the standard-form OBE lost positive definiteness").all()
    s = summarize(t).set_index(["scenario", "estimator"])
    g = t[(t.scenario == "gauss") & (t.estimator == "WLS")]
    assert s.loc[("gauss", "WLS"), "coverage_pct"] == pytest.approx(
        100.0 * np.mean((g.lo.to_numpy() <= g.truth.to_numpy()) & (g.truth.to_numpy() <= g.hi.to_numpy())))
    assert s.loc[("gauss", "LP exact"), "width_ratio_median"] == pytest.approx(1.0)
    for sc in ("bounded", "gauss"):
        row = s.loc[(sc, "OBE-factorized")]
        assert row["bound_held_replicates"] >= 1 and row["coverage_bound_held_pct"] == 100.0
        assert row["width_ratio_median"] >= 1.0 - 1e-9  # an outer bound of the feasible set
    page = write_campaign_page(second)
    html = page.read_text()
    assert "Coverage of the truth" in html and "OBE-factorized" in html
    assert (out / "tables" / "coverage.csv").is_file()
    assert "Failures" in html
    for sc in ("bounded", "gauss"):
        assert s.loc[(sc, "OBE-standard"), "failed"] == failed.loc[failed.scenario == sc, "replicate"].nunique()


def test_unreadable_replicate_is_named_set_aside_and_recomputed(tmp_path, cfg, capsys):
    """`boundid campaign` meeting a truncated replicate file (a disk that filled up, a copy cut
    short) names it in one warning line, moves it to <name>.corrupt and computes it again; the
    recomputed rows equal the original ones (same seed: the reference), the others are untouched."""
    from boundid.cli import main

    argv = ["campaign", str(cfg.file), "--replicates", "2", "--workers", "0", "--out", str(tmp_path), "--quiet"]
    assert main(argv) == 0
    data = tmp_path / cfg.name / "campaign" / "data"
    path = replicate_path(data, "study", config_hash(campaign_config(cfg, load_campaign(cfg).scenarios[0])), 1)
    before, original = _files(data), pd.read_parquet(path)
    path.write_bytes(path.read_bytes()[:200])
    capsys.readouterr()
    assert main(argv) == 0
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"boundid: warning: replicate file {path} cannot be read (ArrowInvalid: ")
    assert line.endswith(f"moved to {path}.corrupt and computed again.")
    assert Path(f"{path}.corrupt").stat().st_size == 200
    timing = ["time_s", "replicate_time_s"]
    pd.testing.assert_frame_equal(pd.read_parquet(path).drop(columns=timing), original.drop(columns=timing))
    assert {k: v for k, v in _files(data).items() if k != path.name and k.endswith(".parquet")} == {
        k: v for k, v in before.items() if k != path.name}
    assert (tmp_path / cfg.name / "campaign" / "index.html").is_file()


def test_measured_study_is_refused(cfg):
    """A campaign re-draws simulated noise: a measured-data study is refused with a StudyError."""
    measured = replace(cfg, experiment=replace(cfg.experiment, source="measured"))
    with pytest.raises(StudyError, match="measured data"):
        run_campaign(measured, 1, (BOUNDED,), "unused", workers=0)


def test_task_chunks_amortise_and_balance():
    """Consecutive replicates per task: all of them once, in order; about TASKS_PER_WORKER tasks per
    worker, at most MAX_PER_TASK replicates in one, and one replicate per task when there are few."""
    todo = [("s", r) for r in range(60)]
    for workers, size in [(1, 7), (2, 3), (4, 1), (100, 1)]:
        chunks = campaign.task_chunks(todo, workers)
        assert [t for c in chunks for t in c] == todo
        assert max(len(c) for c in chunks) == size
    assert max(len(c) for c in campaign.task_chunks(todo * 10, 1)) == campaign.MAX_PER_TASK
    assert campaign.task_chunks([], 2) == []


def test_local_cluster_matches_in_process(tmp_path, cfg, monkeypatch):
    """A real dask.distributed LocalCluster (1 worker process, both replicates in one task) writes
    the same numbers as the in-process run of the same replicates."""
    monkeypatch.setattr(campaign, "TASKS_PER_WORKER", 1)
    assert campaign.task_chunks([0, 1], 1) == [[0, 1]]
    ref = run_campaign(cfg, 2, (GAUSS,), tmp_path / "serial", workers=0).table
    res = run_campaign(cfg, 2, (GAUSS,), tmp_path / "dask", workers=1)
    assert res.workers == 1 and sorted(res.computed) == [("gauss", 0), ("gauss", 1)]
    key = ["scenario", "replicate", "estimator", "regression", "parameter"]
    a, b = ref.sort_values(key).reset_index(drop=True), res.table.sort_values(key).reset_index(drop=True)
    pd.testing.assert_frame_equal(a[key + ["center", "lo", "hi"]], b[key + ["center", "lo", "hi"]])


SCRIPT = """
import sys
from boundid.experiments.measurement import TorqueNoise
from boundid.studies.campaign import run_campaign
from boundid.studies.config import load_study
from boundid.studies.scenarios import Scenario
cfg = load_study(sys.argv[1])
run_campaign(cfg, int(sys.argv[3]), (Scenario("bounded", torque_noise=TorqueNoise("uniform", 0.5)),), sys.argv[2],
             workers=0)
"""


def test_killed_campaign_restarts_where_it_stopped(tmp_path, cfg):
    """SIGKILL a campaign process after its first replicate files appear; the re-run computes
    exactly the missing replicates, leaves the finished files untouched, and every file on disk
    is a complete Parquet file (no half-written replicate)."""
    out, n = tmp_path / "killed", 8
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT, str(cfg.file), str(out), str(n)],
                            start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    data = out / "data"
    deadline = time.monotonic() + 120
    try:
        while time.monotonic() < deadline and proc.poll() is None and len(list(data.glob("*.parquet"))) < 2:
            time.sleep(0.05)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    assert proc.returncode == -signal.SIGKILL, proc.stderr.read().decode()[-2000:]
    before = _files(data)
    assert 1 <= len(before) < n
    for name in before:
        assert len(pd.read_parquet(data / name)) == 3 * 9
    res = run_campaign(cfg, n, (BOUNDED,), out, workers=0)
    chash = config_hash(campaign_config(cfg, BOUNDED))
    done = {replicate_path(data, "bounded", chash, r).name for _, r in res.skipped}
    assert done == set(before)
    assert len(res.computed) + len(res.skipped) == n and not set(res.computed) & set(res.skipped)
    after = _files(data)
    assert len(after) == n and all(after[k] == v for k, v in before.items())
    assert sorted(res.table.drop_duplicates(["replicate"])["replicate"]) == list(range(n))
    assert not res.table.duplicated(["replicate", "estimator", "regression", "parameter"]).any()


@pytest.mark.slow  # ~15 s: cluster start, a worker restart
def test_killed_dask_worker_is_replaced_and_campaign_completes(tmp_path, cfg):
    """On an existing cluster (the --scheduler path), SIGKILL the only worker process mid-campaign:
    the nanny restarts it, Dask re-runs the lost task, and the campaign ends with every replicate
    exactly once; the files written before the kill are untouched."""
    import threading

    from dask.distributed import Client, LocalCluster

    out, n = tmp_path / "worker_killed", 6
    data = out / "data"
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster, \
            Client(cluster) as client:
        (pid,) = client.run(os.getpid).values()
        box: dict = {}

        def campaign():
            try:
                box["result"] = run_campaign(cfg, n, (BOUNDED,), out, scheduler=cluster.scheduler_address)
            except Exception as exc:  # noqa: BLE001 -- re-raised in the test thread below
                box["error"] = exc

        thread = threading.Thread(target=campaign)
        thread.start()
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and thread.is_alive() and not list(data.glob("*.parquet")):
            time.sleep(0.02)
        before = _files(data)
        os.kill(pid, signal.SIGKILL)
        thread.join(timeout=180)
        assert not thread.is_alive() and "error" not in box, box.get("error")
        (new_pid,) = client.run(os.getpid).values()
    res = box["result"]
    assert new_pid != pid and 1 <= len(before) < n
    after = _files(data)
    assert len(after) == n and all(after[k] == v for k, v in before.items())
    assert sorted(res.table.drop_duplicates(["replicate"])["replicate"]) == list(range(n))
    assert not res.table.duplicated(["replicate", "estimator", "regression", "parameter"]).any()
