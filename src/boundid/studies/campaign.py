"""Monte Carlo campaigns: many noise draws of a study, per scenario, run with Dask, resumable.

Each replicate (scenario s, replicate r) re-draws the measurement noise with its own generator,
``SeedSequence(study seed, spawn_key=(crc32(s), r))`` -- the child ``SeedSequence.spawn`` would
give, keyed by the scenario's name so it does not depend on which scenarios run or in what order.
It runs every estimator of the study in *campaign mode*: no SDP ellipsoids and no validation
experiment (the exact LP bounds stay: they are the reference widths), and writes one tidy row per
estimator x regression x parameter (the columns of :func:`boundid.studies.runner.tidy_table` plus
``scenario, replicate, config_hash, time_s, replicate_time_s, bound_ratio, truth_error_ratio,
exact_bound, failure``) to one Parquet file::

    <out>/data/<scenario>__<config hash>__r<replicate>.parquet

The file is written under a temporary name and moved into place with ``os.replace`` (atomic), so
a replicate is either complete or absent. A campaign restarted after any interruption (Ctrl-C, a
killed worker or process, a crash) skips the files already there: nothing is recomputed or
duplicated. A file there that cannot be read back (truncated or damaged by other means) is moved
aside to ``<name>.corrupt`` and its replicate computed again; the result lists it.
The config hash covers the scenario's whole configuration (seed included), so editing
the study or a scenario starts fresh files instead of mixing old and new results; it does not cover
the code: after changing an estimator, run into a new folder.

Execution: ``dask.distributed`` -- a ``LocalCluster`` of K single-threaded worker processes, or an
existing cluster at ``scheduler`` ("tcp://host:port"); ``workers=0`` runs in this process (no
cluster; for tests and debugging). Dask re-runs a task whose worker died on another worker. The
workers write the files themselves: on a remote cluster ``out`` must be a folder they all share.

Speed (docs/scaling.md, reports/benchmarks/campaign.md): the replicate is the unit of parallelism,
so each one runs with ONE BLAS/OpenMP thread (``threadpoolctl``; a LocalCluster's workers also
start with OMP/OPENBLAS/MKL/NUMBA_NUM_THREADS=1): on a shared 2-core machine a multi-threaded BLAS
made the in-process loop 3x slower, and K workers would oversubscribe the cores. A LocalCluster's
workers start without dask's MALLOC_TRIM_THRESHOLD_, with their profiler off and their periodic
checks spaced out (:data:`WORKER_CONFIG`, :func:`local_cluster`); workers of an existing cluster
keep their own configuration (start them with the same settings for the same speed). Each worker imports the
replicate's modules and loads the numba kernels (``cache=True``: from their on-disk cache, never
compiled anew) once, when it joins (:func:`connect`, :func:`warm_up`), not in its first replicate.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import os
import time
import uuid
import zlib
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from threadpoolctl import ThreadpoolController

from boundid.errors import RUN_FAILURES, InputError, StudyError
from boundid.studies.config import StudyConfig, prior_box
from boundid.studies.data import acquire
from boundid.studies.excitation import design_excitation
from boundid.studies.progress import QUIET, Progress
from boundid.studies.registry import make_robot
from boundid.studies.runner import build_regressions, exact_optima, run_estimator, tidy_table
from boundid.studies.scenarios import Scenario

DATA_DIR = "data"
EXACT_LABEL = "LP exact"  # the estimator label of the exact LP bounds in the replicate rows


def campaign_config(cfg: StudyConfig, scenario: Scenario) -> StudyConfig:
    """The study in campaign mode under ``scenario``: its experiment overridden, no SDP ellipsoids,
    no validation experiment (``dataclasses.replace``; LP bounds kept)."""
    cfg = scenario.apply(cfg)
    return replace(cfg, exact=replace(cfg.exact, sdp=()),
                   experiment=replace(cfg.experiment, validation_duration_s=0.0))


def select_estimators(cfg: StudyConfig, labels: tuple[str, ...] | list[str] = ()) -> StudyConfig:
    """The study with only the estimators labelled ``labels``, in the study's order (empty: all of them);
    StudyError naming an unknown label. The exact optima are not estimators: they stay."""
    if not labels:
        return cfg
    known = [ec.label for ec in cfg.estimators]
    unknown = [lab for lab in labels if lab not in known]
    if unknown:
        raise StudyError(f"{cfg.file}: no estimator labelled {unknown}; the study has {known}.")
    return replace(cfg, estimators=tuple(ec for ec in cfg.estimators if ec.label in labels))


def config_hash(cfg: StudyConfig) -> str:
    """12 hex digits identifying everything a replicate's result depends on (not the file's path)."""
    return hashlib.sha256(repr(replace(cfg, file=Path(Path(cfg.file).name))).encode()).hexdigest()[:12]


def replicate_seed(seed: int, scenario: str, replicate: int) -> np.random.SeedSequence:
    """The replicate's seed sequence: the child (crc32(scenario), replicate) of ``SeedSequence(seed)``."""
    if replicate < 0:
        raise InputError(f"replicate numbers are >= 0, got {replicate}.")
    return np.random.SeedSequence(seed, spawn_key=(zlib.crc32(scenario.encode()), int(replicate)))


@functools.cache
def _thread_pools() -> ThreadpoolController:
    """The BLAS/OpenMP pools of this process, found once (``threadpool_limits`` looks for them anew at every
    call: 8 ms, 2 % of a replicate); made at the first replicate, after the imports that load them."""
    return ThreadpoolController()


def one_thread():
    """Context: every BLAS/OpenMP pool of this process limited to one thread."""
    return _thread_pools().limit(limits=1)


def replicate_path(data_dir: Path, scenario: str, chash: str, replicate: int) -> Path:
    """The Parquet file of one replicate: ``<scenario>__<config hash>__r<replicate, 6 digits>.parquet``
    in ``data_dir`` (the hash of :func:`config_hash`: a changed study writes new files)."""
    return Path(data_dir) / f"{scenario}__{chash}__r{replicate:06d}.parquet"


def replicate_rows(cfg: StudyConfig, scenario: Scenario, replicate: int) -> pd.DataFrame:
    """Run one replicate in campaign mode and return its tidy rows (nothing written).

    bound_ratio (guaranteed estimators): max_k |y_k - w_k^T theta_true| / e_max on the estimator's
    own regression -- <= 1 means the errors respect the bound, so the set must contain the truth.
    truth_error_ratio: the same on the exact optima's regression with its e_max.
    exact_bound: that e_max in words ("6 N m", :meth:`boundid.studies.runner.ExactResult.bound_text`).
    Failed estimators (any of :data:`boundid.errors.RUN_FAILURES`) get rows with NaN values, kind
    "failed" and the reason; so do the exact LP bounds ("LP exact") when their computation fails.
    """
    t_start = time.perf_counter()
    ccfg = campaign_config(cfg, scenario)
    rng = np.random.default_rng(replicate_seed(cfg.seed, scenario.name, replicate))
    model = make_robot(ccfg.robot, ccfg.robot_options)
    # a designed excitation: the same search in every replicate (seeded by the study's seed alone), so the
    # same pick, as the study's own run
    design = design_excitation(ccfg, model) if ccfg.experiment.excitation != "default" else None
    data = acquire(ccfg, model, rng, design.excitation if design is not None else None)
    regressions = build_regressions(model, data.recording, ccfg.preprocessing, ccfg.regressions)
    estimates, extra, failures = {}, {}, []
    for ec in ccfg.estimators:
        if ec.bound_from_exact and not np.isscalar(ec.e_max):  # one bound per joint: per row of its regression
            ec = replace(ec, e_max=np.asarray(ec.e_max, dtype=float)[regressions[ccfg.exact.regression].joint])
        for regname in ec.regressions:
            reg = regressions[regname]
            try:
                est = run_estimator(ec, reg, model, ccfg.prior)
            except RUN_FAILURES as exc:
                failures.append((ec.label, ec.method, regname, f"{type(exc).__name__}: {exc}"))
                continue
            estimates[(ec.label, regname)] = est
            ratio = np.nan
            if est.guaranteed and ec.e_max is not None:
                ratio = float(np.max(np.abs(reg.y - reg.W @ model.theta_true) / ec.e_max))
            extra[(ec.label, regname)] = (float(est.time_s), ratio, None)
    exact = None
    if ccfg.exact.regression is not None:
        t0 = time.perf_counter()
        try:
            exact = exact_optima(ccfg, regressions[ccfg.exact.regression], model, {}, QUIET)
        except RUN_FAILURES as exc:
            failures.append((EXACT_LABEL, "LP", ccfg.exact.regression, f"{type(exc).__name__}: {exc}"))
        else:  # data that contradict the bound are a finding (no LP rows), a failed LP is a failure
            lp_failure = exact.errors.get("consistency") or (exact.errors.get("bounds") if exact.consistent else None)
            if lp_failure:
                failures.append((EXACT_LABEL, "LP", ccfg.exact.regression, lp_failure))
            extra[(EXACT_LABEL, ccfg.exact.regression)] = (time.perf_counter() - t0, np.nan, None)
    table = tidy_table(ccfg, model, estimates, exact)
    for label, method, regname, reason in failures:
        extra[(label, regname)] = (np.nan, np.nan, reason)
        table = pd.concat([table, pd.DataFrame({
            "study": ccfg.name, "estimator": label, "method": method, "regression": regname,
            "parameter": list(model.param_names), "unit": list(model.param_units), "center": np.nan, "lo": np.nan,
            "hi": np.nan, "truth": model.theta_true, "prior": prior_box(model, ccfg.prior)[0], "kind": "failed",
            "level": np.nan,
            "truth_in_set": pd.array([pd.NA] * model.p, dtype="boolean"),
            "truth_in_all_intervals": pd.array([pd.NA] * model.p, dtype="boolean")})],
            ignore_index=True)
    keys = list(zip(table["estimator"], table["regression"], strict=True))
    table["time_s"] = [extra[k][0] for k in keys]
    table["bound_ratio"] = [extra[k][1] for k in keys]
    table["failure"] = pd.Series([extra[k][2] for k in keys], dtype="string")
    table["level"] = pd.to_numeric(table["level"], errors="coerce").astype(float)
    table.insert(1, "scenario", scenario.name)
    table.insert(2, "replicate", int(replicate))
    table["config_hash"] = config_hash(ccfg)
    table["truth_error_ratio"] = exact.truth_error_ratio if exact is not None else np.nan
    table["exact_bound"] = pd.Series([exact.bound_text() if exact is not None else None] * len(table), dtype="string")
    table["replicate_time_s"] = time.perf_counter() - t_start
    return table


def run_replicate(cfg: StudyConfig, scenario: Scenario, replicate: int, data_dir: str | Path) -> str:
    """Compute one replicate and move its Parquet file into place atomically; returns its path.

    A file already there is kept as it is (a task re-run after a lost worker does not duplicate it).
    """
    data_dir = Path(data_dir)
    path = replicate_path(data_dir, scenario.name, config_hash(campaign_config(cfg, scenario)), replicate)
    if path.exists():
        return str(path)
    with one_thread():  # one replicate per core: a multi-threaded BLAS only oversubscribes
        table = replicate_rows(cfg, scenario, replicate)
    tmp = data_dir / f".{path.stem}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp"
    try:
        pq.write_table(pa.Table.from_pandas(table, preserve_index=False), tmp)  # = to_parquet, 2 ms sooner
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return str(path)


@dataclass
class CampaignResult:
    """table: every completed replicate of the requested scenarios (rows as in :func:`replicate_rows`);
    computed / skipped: the (scenario, replicate) pairs run now / found already done;
    set_aside: (new path, reason) of each replicate file found unreadable, moved aside and recomputed;
    elapsed_s: wall time of this call; workers: the number of Dask workers (0: in-process)."""

    config: StudyConfig
    scenarios: tuple[Scenario, ...]
    replicates: int
    out: Path
    table: pd.DataFrame
    computed: list[tuple[str, int]] = field(default_factory=list)
    skipped: list[tuple[str, int]] = field(default_factory=list)
    set_aside: list[tuple[str, str]] = field(default_factory=list)
    elapsed_s: float = 0.0
    workers: int = 0


_KEY_COLUMNS = ("scenario", "replicate", "estimator", "regression", "parameter", "kind", "config_hash")


def read_replicate(path: str | Path) -> pd.DataFrame:
    """One replicate file; InputError naming it when it cannot be read back (e.g. truncated) or
    does not hold a replicate's rows."""
    path = Path(path)
    try:
        table = pq.ParquetFile(path).read().to_pandas()  # = pd.read_parquet, 2 ms sooner
    except (OSError, ValueError) as exc:  # pyarrow: ArrowInvalid (a ValueError), ArrowIOError (an OSError)
        raise InputError(f"replicate file {path} cannot be read ({type(exc).__name__}: {exc})") from None
    missing = [c for c in _KEY_COLUMNS if c not in table.columns]
    if table.empty or missing:
        raise InputError(f"replicate file {path} holds no replicate rows (missing columns {missing})")
    return table


def set_aside(path: Path) -> Path:
    """Move an unreadable replicate file to ``<name>.corrupt`` (``<name>.<k>.corrupt`` if taken); returns it."""
    target, k = path.with_name(f"{path.name}.corrupt"), 1
    while target.exists():
        target, k = path.with_name(f"{path.name}.{k}.corrupt"), k + 1
    os.replace(path, target)
    return target


def _pending(cfg: StudyConfig, scenarios, replicates: int, data_dir: Path):
    """(to run, done, set aside): a replicate whose file cannot be read back is set aside and run again;
    ``set aside`` lists (new path, reason)."""
    todo, done, aside = [], [], []
    for sc in scenarios:
        chash = config_hash(campaign_config(cfg, sc))
        for r in range(replicates):
            path = replicate_path(data_dir, sc.name, chash, r)
            if path.exists():
                try:
                    read_replicate(path)
                except InputError as exc:
                    aside.append((str(set_aside(path)), str(exc)))
            (done if path.exists() else todo).append((sc, r))
    return todo, done, aside


def load_results(cfg: StudyConfig, scenarios, replicates: int, out: str | Path) -> pd.DataFrame:
    """The completed replicates r < ``replicates`` of ``scenarios`` under ``out`` (current configuration only)."""
    data_dir = Path(out) / DATA_DIR
    files = []
    for sc in scenarios:
        chash = config_hash(campaign_config(cfg, sc))
        files += [p for r in range(replicates) if (p := replicate_path(data_dir, sc.name, chash, r)).exists()]
    if not files:
        return pd.DataFrame()
    try:
        return pd.concat([read_replicate(p) for p in files], ignore_index=True)
    except InputError as exc:
        raise InputError(f"{exc}; run the campaign again: it moves the file aside and computes the replicate "
                         "anew.") from None


def run_campaign(cfg: StudyConfig, replicates: int, scenarios: tuple[Scenario, ...], out: str | Path, *,
                 workers: int = 1, scheduler: str | None = None, estimators: tuple[str, ...] = (),
                 progress: Progress = QUIET) -> CampaignResult:
    """Run the missing replicates 0..replicates-1 of each scenario and return all of them.

    out : campaign folder (``reports/<study>/campaign``); results go to ``out/data/``
    workers : LocalCluster worker processes (1 thread each); 0 runs in this process
    scheduler : address of an existing Dask scheduler (then ``workers`` is ignored)
    estimators : labels of the estimators each replicate runs (``[campaign] estimators``; empty: all).
        The result's ``config`` holds only those, and its files are apart from a campaign of others
        (the config hash covers them).
    """
    if replicates < 1:
        raise InputError(f"replicates must be >= 1, got {replicates}.")
    if workers < 0:
        raise InputError(f"workers must be >= 0 (0: in this process), got {workers}.")
    if not scenarios:
        raise StudyError(f"{cfg.file}: no scenario to run.")
    cfg = select_estimators(cfg, estimators)
    for sc in scenarios:
        sc.apply(cfg)  # refuses measured data before anything starts
    out = Path(out)
    data_dir = out / DATA_DIR
    data_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    todo, done, aside = _pending(cfg, scenarios, replicates, data_dir)
    computed: list[tuple[str, int]] = []
    n_workers = 0
    with progress.stage(f"{cfg.name}: campaign, {len(todo)} replicates to run ({len(done)} done)"):
        if todo and scheduler is None and workers == 0:
            for sc, r in todo:
                run_replicate(cfg, sc, r, data_dir)
                computed.append((sc.name, r))
        elif todo:
            n_workers = _run_dask(cfg, todo, data_dir, workers, scheduler, computed)
    table = load_results(cfg, scenarios, replicates, out)
    return CampaignResult(cfg, tuple(scenarios), replicates, out, table, computed,
                          [(sc.name, r) for sc, r in done], aside, time.perf_counter() - t0, n_workers)


#: environment of a LocalCluster's worker processes, set before they import numpy or numba
WORKER_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}

#: dask configuration of a LocalCluster's workers: fewer wake-ups of the worker's own threads, which
#: take the GIL from the replicate (measured in a worker, 12 replicates of the 5 s arm experiment:
#: 30-80 ms of CPU per replicate on other threads with dask's defaults, 3-5 ms with these). The
#: statistical profiler (a stack sample every 10 ms, for the dashboard) is off; the event loop's
#: health check runs every second instead of every 20 ms, the memory monitor (pause and spill at
#: the memory limit) every second instead of every 100 ms, the system monitor (dashboard) every 5 s.
WORKER_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
                 "distributed.worker.memory.monitor-interval": "1s", "distributed.admin.system-monitor.interval": "5s"}


def local_cluster(workers: int):
    """A dask ``LocalCluster`` of ``workers`` single-threaded worker processes, one BLAS/numba thread each,
    configured by :data:`WORKER_CONFIG`.

    Dask's default environment for its workers also sets MALLOC_TRIM_THRESHOLD_=65536, which turns off
    glibc's adaptive mmap threshold: every array above 128 kB is then mapped and unmapped anew, and a
    replicate costs 25 % more CPU (reports/benchmarks/campaign.md); the workers start without it.
    """
    import dask
    from dask.distributed import LocalCluster

    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None, **WORKER_CONFIG}):
        return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                            env=WORKER_ENV)


_WARMED: set[str] = set()  # the configurations this process has warmed up for


def warm_up(cfg: StudyConfig) -> None:
    """Load the kernels a replicate of ``cfg`` uses, once per process and configuration: one replicate
    of the study with its experiment cut to a fifth (whole samples), results discarded. The numba
    kernels compiled without a signature load from their disk cache at their first call (~0.2-0.3 s
    in all); here, not in the worker's first real replicate. A configuration that cannot run so
    short is only logged: its real replicates report their own failures."""
    chash = config_hash(cfg)
    if chash in _WARMED:
        return
    _WARMED.add(chash)
    h = cfg.experiment.sample_period_s
    short = replace(cfg, experiment=replace(cfg.experiment, duration_s=max(1, round(cfg.experiment.duration_s
                                                                                   / 5 / h)) * h))
    try:
        with one_thread():
            replicate_rows(short, Scenario("study"), 0)
    except Exception as exc:  # a warm-up only: nothing of it is kept
        logging.getLogger(__name__).warning("campaign warm-up skipped (%s: %s)", type(exc).__name__, exc)


def _warm_plugin(cfg: StudyConfig):
    """A dask WorkerPlugin that warms each worker up for ``cfg`` (:func:`warm_up`) when it joins."""
    from dask.distributed import WorkerPlugin

    class WarmUp(WorkerPlugin):
        name = "boundid-warm-up"

        def setup(self, worker):
            warm_up(cfg)

    return WarmUp()


def connect(cfg: StudyConfig, scheduler: str | None = None, workers: int = 1):
    """(client, cluster): a Client of the cluster at ``scheduler``, else of a new :func:`local_cluster`
    (then ``cluster`` is it, for the caller to close); every worker, present and future, warmed up
    for ``cfg`` (:func:`warm_up`) before its first replicate."""
    from dask.distributed import Client

    cluster = None if scheduler is not None else local_cluster(workers)
    client = Client(scheduler if scheduler is not None else cluster)
    client.register_plugin(_warm_plugin(cfg))
    return client, cluster


def run_replicates(cfg: StudyConfig, tasks: list[tuple[Scenario, int]], data_dir: str | Path) -> list[str]:
    """:func:`run_replicate` for each (scenario, replicate) of ``tasks``, in order (one Dask task
    of several replicates; each one's file is in place as soon as it is done)."""
    return [run_replicate(cfg, sc, r, data_dir) for sc, r in tasks]


#: replicates per Dask task: about this many tasks per worker (the last ones to finish keep the
#: workers' loads even), at most MAX_PER_TASK replicates each (a lost worker re-runs at most that many)
TASKS_PER_WORKER, MAX_PER_TASK = 8, 8


def task_chunks(todo: list, workers: int) -> list[list]:
    """``todo`` cut into consecutive tasks for ``workers`` workers: a task carries several
    replicates, so that the scheduler's cost per task (a few ms, reports/benchmarks/campaign.md)
    is paid once for all of them, and there are still about TASKS_PER_WORKER tasks per worker."""
    size = max(1, min(MAX_PER_TASK, len(todo) // (TASKS_PER_WORKER * max(1, workers))))
    return [todo[i:i + size] for i in range(0, len(todo), size)]


def _run_dask(cfg, todo, data_dir: Path, workers: int, scheduler: str | None, computed: list) -> int:
    from dask.distributed import as_completed

    client, cluster = connect(cfg, scheduler, workers)
    try:
        slots = sum(client.nthreads().values()) or workers
        # cfg goes with each task (a few kB), not scattered: scattered data dies with its worker,
        # and the tasks that need it would then be cancelled instead of re-run elsewhere
        futures = {client.submit(run_replicates, cfg, chunk, str(data_dir.resolve()),
                                 key=f"campaign-{cfg.name}-{chunk[0][0].name}-{chunk[0][1]}-{len(chunk)}",
                                 pure=False): chunk
                   for chunk in task_chunks(todo, slots)}
        for fut in as_completed(futures):
            fut.result()  # re-raises a replicate's error here
            computed.extend((sc.name, r) for sc, r in futures[fut])
        return len(client.scheduler_info(n_workers=-1)["workers"])
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


# ------------------------------------------------------------------------------ summary


def _with_exact_width(table: pd.DataFrame) -> pd.DataFrame:
    key = ["scenario", "replicate", "parameter"]
    exact = table[table["kind"] == "exact"][key + ["lo", "hi"]]
    exact = exact.assign(exact_width=exact["hi"] - exact["lo"]).drop(columns=["lo", "hi"])
    return table.merge(exact, on=key, how="left")


def summarize(table: pd.DataFrame) -> pd.DataFrame:
    """Per scenario x estimator x regression: coverage of the truth, width over the exact width,
    bias and RMSE, time per replicate.

    coverage_pct : % of (replicate, parameter) intervals lo <= truth <= hi
    coverage_bound_held_pct : the same over the replicates whose errors respect the estimator's
        bound (bound_ratio <= 1; guaranteed sets; for "LP exact" truth_error_ratio <= 1): must be 100
    contains_truth_pct : % of the completed replicates whose set (guaranteed, confidence, or the exact
        polytope) contains the whole true vector (``truth_in_set``); NaN without a set (a point estimate)
    contains_truth_bound_held_pct : the same over the replicates whose errors respect the estimator's
        bound (guaranteed sets and "LP exact"): must be 100
    bound_held_replicates : completed replicates whose errors respect the estimator's bound (the same)
    empty_replicates : "LP exact" only: replicates whose data contradict the exact bound, so that the
        feasible polytope is empty (no LP rows; the exact stage ran: ``truth_error_ratio`` is finite).
        They count among its replicates, as sets that do not contain the truth (contains_truth_pct);
        a scenario where every replicate is empty gets an "LP exact" row of its own
    width_ratio_median : median over replicates and parameters of (hi - lo) / exact LP width
    bias_rel_pct, rmse_rel_pct : mean over parameters of |mean(center - truth)| / |truth| and
        sqrt(mean((center - truth)^2)) / |truth| (parameters with truth 0 left out), in %
    time_s : mean estimator time per replicate [s]; failed : replicates where it failed
    """
    if table.empty:
        raise InputError("no campaign results to summarise: run some replicates first.")
    t = _with_exact_width(table)
    t = t.assign(covered=(t["lo"] <= t["truth"]) & (t["truth"] <= t["hi"]), err=t["center"] - t["truth"],
                 width_ratio=(t["hi"] - t["lo"]) / t["exact_width"])
    lp = t[t["estimator"] == EXACT_LABEL]
    ran = t[np.isfinite(t["truth_error_ratio"].astype(float))] if "truth_error_ratio" in t else t.iloc[:0]
    empty = {sc: set(g["replicate"]) - set(lp.loc[lp["scenario"] == sc, "replicate"])
             for sc, g in ran.groupby("scenario", sort=False)}
    rows = []
    for (sc, lab, reg), g in t.groupby(["scenario", "estimator", "regression"], sort=False):
        ok = g[g["kind"] != "failed"]
        held = ok[ok["truth_error_ratio" if lab == EXACT_LABEL else "bound_ratio"] <= 1.0]
        in_set = ok.drop_duplicates("replicate")["truth_in_set"].astype("boolean")
        in_set_held = held.drop_duplicates("replicate")["truth_in_set"].astype("boolean")
        per = ok.groupby("parameter", sort=False).agg(bias=("err", "mean"), mse=("err", lambda e: np.mean(e ** 2)),
                                                      truth=("truth", "first"))
        nz = per[per["truth"] != 0]
        kind = ok["kind"].iloc[0] if len(ok) else "failed"
        bounded = kind in ("guaranteed", "exact")
        n_empty = len(empty.get(sc, ())) if lab == EXACT_LABEL else 0
        rows.append({
            "scenario": sc, "estimator": lab, "regression": reg, "kind": kind,
            "level": ok["level"].iloc[0] if len(ok) else np.nan,
            "replicates": g["replicate"].nunique() + n_empty,
            "failed": g.loc[g["kind"] == "failed", "replicate"].nunique(),
            "coverage_pct": 100.0 * ok["covered"].mean() if len(ok) else np.nan,
            "bound_held_replicates": held["replicate"].nunique() if bounded else np.nan,
            "coverage_bound_held_pct": 100.0 * held["covered"].mean() if bounded and len(held) else np.nan,
            "contains_truth_pct": (100.0 * float(in_set.sum()) / (int(in_set.notna().sum()) + n_empty)
                                   if in_set.notna().any() or n_empty else np.nan),
            "contains_truth_bound_held_pct": (100.0 * float(in_set_held.mean()) if bounded
                                              and in_set_held.notna().any() else np.nan),
            "width_ratio_median": float(np.nanmedian(ok["width_ratio"])) if ok["width_ratio"].notna().any() else np.nan,
            "bias_rel_pct": 100.0 * float(np.mean(np.abs(nz["bias"]) / np.abs(nz["truth"]))) if len(nz) else np.nan,
            "rmse_rel_pct": 100.0 * float(np.mean(np.sqrt(nz["mse"]) / np.abs(nz["truth"]))) if len(nz) else np.nan,
            "time_s": float(ok.drop_duplicates("replicate")["time_s"].mean()) if len(ok) else np.nan,
            "empty_replicates": n_empty if lab == EXACT_LABEL else np.nan,
        })
    reg = lp["regression"].iloc[0] if len(lp) else "exact"
    for sc, reps in empty.items():
        if reps and not ((lp["scenario"] == sc).any()):  # every replicate empty: no row of LP exact at all
            rows.append({"scenario": sc, "estimator": EXACT_LABEL, "regression": reg, "kind": "exact",
                         "level": np.nan, "replicates": len(reps), "failed": 0, "coverage_pct": np.nan,
                         "bound_held_replicates": 0, "coverage_bound_held_pct": np.nan,
                         "contains_truth_pct": 0.0, "contains_truth_bound_held_pct": np.nan,
                         "width_ratio_median": np.nan, "bias_rel_pct": np.nan, "rmse_rel_pct": np.nan,
                         "time_s": np.nan, "empty_replicates": len(reps)})
    return pd.DataFrame(rows)


def parameter_errors(table: pd.DataFrame) -> pd.DataFrame:
    """Per scenario x estimator x regression x parameter: truth, bias = mean(center - truth) and
    RMSE = sqrt(mean((center - truth)^2)) over the replicates, in the parameter's unit."""
    ok = table[table["kind"] != "failed"].assign(err=lambda d: d["center"] - d["truth"])
    return (ok.groupby(["scenario", "estimator", "regression", "parameter", "unit"], sort=False)
            .agg(truth=("truth", "first"), bias=("err", "mean"),
                 rmse=("err", lambda e: float(np.sqrt(np.mean(e ** 2)))), replicates=("replicate", "nunique"))
            .reset_index())
