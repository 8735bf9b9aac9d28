"""Mutation testing of boundid with cosmic-ray: run the sampled configuration and report it.

    python tools/mutation.py run      # init + sample + execute every module of tools/mutation.toml
    python tools/mutation.py report   # write reports/benchmarks/mutation.md from the session databases

`run` never mutates the work tree: each worker gets a copy of src/, tests/ and pyproject.toml under
build/mutation/w<i>/ and its tests import that copy (PYTHONPATH). One cosmic-ray session (SQLite
database) per module lives in build/mutation/sessions/. Mutants not drawn by the seeded sample are
stored as "skipped" so that `cosmic-ray exec` runs the drawn ones only; a rerun resumes where the
last one stopped (`--fresh` starts over, `--rerun-survivors` re-judges the survivors only, after
tests were added).

`report` reads those databases and tools/mutation_equivalent.toml (the survivors judged equivalent,
keyed by module, operator and occurrence, each with its one-line reason) and writes the counts;
nothing in the page is typed by hand.
"""

from __future__ import annotations

import argparse
import datetime as dt
import hashlib
import json
import os
import random
import re
import shlex
import shutil
import subprocess
import sys
import time
import tomllib
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from cosmic_ray.work_db import WorkDB, WorkResultStorage, use_db
from cosmic_ray.work_item import TestOutcome, WorkerOutcome, WorkResult

ROOT = Path(__file__).resolve().parent.parent
CONFIG = ROOT / "tools" / "mutation.toml"
EQUIVALENT = ROOT / "tools" / "mutation_equivalent.toml"
BUILD = ROOT / "build" / "mutation"
SESSIONS = BUILD / "sessions"
THREADS = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}


def load_config() -> dict:
    with open(CONFIG, "rb") as f:
        return tomllib.load(f)


def slug(module: str) -> str:
    return module.removeprefix("src/boundid/").removesuffix(".py").replace("/", ".")


def test_command(cfg: dict, module: str) -> str:
    """The pytest command judging the mutants of `module` (run from a worker directory)."""
    args = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider",
            "-m", "'not slow and not browser'", *cfg["modules"][module]]
    if module not in cfg["jit_modules"]:
        args += [f"--deselect {t}" for t in cfg["nojit_deselect"]]
    return " ".join(args)


def module_env(cfg: dict, module: str, workdir: Path) -> dict:
    env = dict(os.environ, **THREADS, PYTHONPATH=str(workdir / "src"))
    env.pop("NUMBA_DISABLE_JIT", None)
    if module not in cfg["jit_modules"]:
        env["NUMBA_DISABLE_JIT"] = "1"
    return env


def source_digest(module: str) -> str:
    return hashlib.sha256((ROOT / module).read_bytes()).hexdigest()[:16]


def sample_digest(cfg: dict, module: str) -> str:
    """Changes when anything deciding this module's sample or judge changes (then the sample is redrawn)."""
    key = json.dumps([source_digest(module), cfg["seed"], cfg["fraction"], cfg["min_sites"],
                      cfg["exclude_operators"], cfg["definitions"].get(module), cfg["modules"][module],
                      module in cfg["jit_modules"], cfg["timeout"]])
    return hashlib.sha256(key.encode()).hexdigest()[:16]


def prepare_worker(i: int) -> Path:
    """A fresh copy of the sources and tests that worker `i` mutates in place."""
    w = BUILD / f"w{i}"
    if w.exists():
        shutil.rmtree(w)
    w.mkdir(parents=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc", "*.egg-info")
    shutil.copytree(ROOT / "src", w / "src", ignore=ignore)
    shutil.copytree(ROOT / "tests", w / "tests", ignore=ignore)
    shutil.copy(ROOT / "pyproject.toml", w / "pyproject.toml")
    return w


def write_session_config(cfg: dict, module: str) -> Path:
    path = SESSIONS / f"{slug(module)}.toml"
    path.write_text(
        "[cosmic-ray]\n"
        f'module-path = "{module}"\n'
        f"timeout = {float(cfg['timeout'])}\n"
        "excluded-modules = []\n"
        f"test-command = {json.dumps(test_command(cfg, module))}\n"
        '[cosmic-ray.distributor]\nname = "local"\n'
    )
    return path


def draw_sample(cfg: dict, module: str, db: WorkDB) -> tuple[int, int]:
    """Mark every mutant outside the seeded stratified sample as skipped; return (population, drawn)."""
    excluded = [re.compile(p) for p in cfg["exclude_operators"]]
    definitions = re.compile(cfg["definitions"].get(module, ".*"))
    sites = defaultdict(list)
    for item in db.work_items:
        (m,) = item.mutations
        if any(p.search(m.operator_name) for p in excluded) or not definitions.search(m.definition_name or ""):
            continue
        sites[(tuple(m.start_pos), tuple(m.end_pos))].append(item.job_id)
    # a seeded shuffle of the sites, of which the first k are drawn (a smaller fraction draws a subset),
    # and at each drawn site one variant chosen by the site's own seed
    keys = sorted(sites)
    random.Random(f"{cfg['seed']}:{module}").shuffle(keys)
    k = min(len(keys), max(cfg["min_sites"], round(cfg["fraction"] * len(keys))))
    drawn = {random.Random(f"{cfg['seed']}:{module}:{s}").choice(sorted(sites[s])) for s in keys[:k]}
    # results already judged for drawn mutants are kept; everything else is (re)marked skipped
    kept = {job for job, r in db.results if job in drawn and r.worker_outcome != WorkerOutcome.SKIPPED}
    _delete_results(db, [item.job_id for item in db.work_items if item.job_id not in kept])
    skip = [item.job_id for item in db.work_items if item.job_id not in drawn]
    db.set_multiple_results(skip, WorkResult(worker_outcome=WorkerOutcome.SKIPPED))
    return sum(len(v) for v in sites.values()), len(drawn)


def init_module(cfg: dict, module: str, workdir: Path, fresh: bool) -> Path:
    """The module's cosmic-ray session (all mutants, redone when the source changes) and its sample."""
    db_path = SESSIONS / f"{slug(module)}.sqlite"
    src_stamp, sample_stamp = SESSIONS / f"{slug(module)}.source", SESSIONS / f"{slug(module)}.digest"
    conf = write_session_config(cfg, module)
    if fresh or not db_path.exists() or not src_stamp.exists() or src_stamp.read_text() != source_digest(module):
        db_path.unlink(missing_ok=True)
        sample_stamp.unlink(missing_ok=True)
        subprocess.run(["cosmic-ray", "init", str(conf), str(db_path)], cwd=workdir, check=True,
                       env=dict(os.environ, PATH=f"{Path(sys.executable).parent}:{os.environ['PATH']}"))
        src_stamp.write_text(source_digest(module))
    digest = sample_digest(cfg, module)
    if sample_stamp.exists() and sample_stamp.read_text() == digest:
        return db_path
    with use_db(str(db_path), WorkDB.Mode.open) as db:
        population, drawn = draw_sample(cfg, module, db)
    (SESSIONS / f"{slug(module)}.sample.json").write_text(json.dumps({"population": population, "drawn": drawn}))
    sample_stamp.write_text(digest)
    return db_path


def baseline(cfg: dict, module: str, workdir: Path) -> None:
    """The unmutated tests must pass, or every mutant would count as killed."""
    out = subprocess.run(_argv(cfg, module), cwd=workdir, env=module_env(cfg, module, workdir),
                         capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"baseline tests fail for {module} (fix them before mutating):\n{out.stdout[-3000:]}")


def _argv(cfg: dict, module: str) -> list[str]:
    return shlex.split(test_command(cfg, module))


def execute(cfg: dict, module: str, workdir: Path, rerun_survivors: bool) -> float:
    db_path = SESSIONS / f"{slug(module)}.sqlite"
    if rerun_survivors:
        with use_db(str(db_path), WorkDB.Mode.open) as db:
            items = {i.job_id: i.mutations[0] for i in db.work_items}
            again = [job for job, r in db.results if r.test_outcome == TestOutcome.SURVIVED
                     and (module, items[job].operator_name, items[job].occurrence) not in equivalent_keys()]
            _delete_results(db, again)
    with use_db(str(db_path), WorkDB.Mode.open) as db:
        pending = sum(1 for _ in db.pending_work_items)
    if not pending:
        return 0.0
    baseline(cfg, module, workdir)
    t0 = time.time()
    subprocess.run(["cosmic-ray", "exec", str(SESSIONS / f"{slug(module)}.toml"), str(db_path)], cwd=workdir,
                   check=True, env=dict(module_env(cfg, module, workdir),
                                        PATH=f"{Path(sys.executable).parent}:{os.environ['PATH']}"))
    return time.time() - t0


def _delete_results(db: WorkDB, job_ids=None) -> None:
    """Forget the results of `job_ids` (all when None), so that `cosmic-ray exec` runs them again."""
    with db._session_maker.begin() as session:
        query = session.query(WorkResultStorage)
        if job_ids is not None:
            query = query.filter(WorkResultStorage.job_id.in_(list(job_ids)))
        query.delete(synchronize_session=False)


def run(args) -> None:
    cfg = load_config()
    SESSIONS.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    workers = [prepare_worker(i) for i in range(cfg["workers"])]
    modules = list(cfg["modules"])
    for m in modules:
        init_module(cfg, m, workers[0], args.fresh)
    if args.only:
        modules = [m for m in modules if any(o in m for o in args.only)]
    # longest-first onto the two workers (cost ~ drawn mutants x size of the test set)
    def cost(m):
        drawn = json.loads((SESSIONS / f"{slug(m)}.sample.json").read_text())["drawn"]
        return drawn * len(cfg["modules"][m])
    queues = [[] for _ in workers]
    loads = [0.0] * len(workers)
    for m in sorted(modules, key=cost, reverse=True):
        i = loads.index(min(loads))
        queues[i].append(m)
        loads[i] += cost(m)

    def work(i):
        for m in queues[i]:
            secs = execute(cfg, m, workers[i], args.rerun_survivors)
            print(f"[w{i}] {m}: {secs:.0f} s", flush=True)

    with ThreadPoolExecutor(len(workers)) as pool:
        list(pool.map(work, range(len(workers))))
    (BUILD / "wall_seconds").write_text(f"{time.time() - t0:.0f}")


def _line(module: str, start_pos) -> str:
    lines = (ROOT / module).read_text().splitlines()
    return lines[start_pos[0] - 1].strip()


def equivalent_keys() -> dict:
    """(module, operator, occurrence) -> reason, from tools/mutation_equivalent.toml."""
    if not EQUIVALENT.exists():
        return {}
    with open(EQUIVALENT, "rb") as f:
        return {(e["module"], e["operator"], int(e["occurrence"])): e["reason"]
                for e in tomllib.load(f).get("equivalent", [])}


def collect(cfg: dict) -> tuple[list[dict], dict]:
    equivalent = equivalent_keys()
    rows, used = [], set()
    for module in cfg["modules"]:
        db_path = SESSIONS / f"{slug(module)}.sqlite"
        if not db_path.exists():
            raise SystemExit(f"no session for {module}: run `make mutation` first")
        with use_db(str(db_path), WorkDB.Mode.open) as db:
            results = dict(db.results)
            for item in db.work_items:
                r = results.get(item.job_id)
                if r is not None and r.worker_outcome == WorkerOutcome.SKIPPED:
                    continue
                (m,) = item.mutations
                key = (module, m.operator_name, m.occurrence)
                if r is None:
                    status = "pending"
                elif r.test_outcome == TestOutcome.KILLED:
                    status = "timeout" if r.output == "timeout" else "killed"
                elif r.test_outcome == TestOutcome.SURVIVED:
                    status = "equivalent" if key in equivalent else "survived"
                else:
                    status = "incompetent"
                if key in equivalent:
                    used.add(key)
                rows.append({"module": module, "operator": m.operator_name, "occurrence": m.occurrence,
                             "line": m.start_pos[0], "code": _line(module, m.start_pos), "status": status,
                             "reason": equivalent.get(key, "")})
    stale = [k for k in equivalent if k not in used]
    return rows, {"stale": stale}


def report(args) -> None:
    cfg = load_config()
    rows, extra = collect(cfg)
    count = defaultdict(int)
    for r in rows:
        count[r["status"]] += 1
    total = len(rows)
    detected = count["killed"] + count["timeout"]
    score = detected / max(total - count["equivalent"], 1)          # a pending mutant counts as a survivor
    judged = total - count["pending"]
    score_judged = detected / max(judged - count["equivalent"], 1)
    population = sum(json.loads((SESSIONS / f"{slug(m)}.sample.json").read_text())["population"]
                     for m in cfg["modules"])
    import cosmic_ray
    version = getattr(cosmic_ray, "__version__", None) or _dist_version("cosmic-ray")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "src", "tests"], cwd=ROOT, capture_output=True,
                           text=True).stdout.strip()
    wall = (BUILD / "wall_seconds").read_text() if (BUILD / "wall_seconds").exists() else "?"
    out = [
        "# Mutation testing",
        "",
        f"Generated by `make mutation` (tools/mutation.py) from the cosmic-ray session databases on "
        f"{dt.date.today().isoformat()}, commit `{commit}`{' (src/tests modified)' if dirty else ''}; "
        f"last run's wall time {wall} s on {cfg['workers']} workers.",
        "",
        f"- Tool: cosmic-ray {version}; judge: the module's fast tests (`pytest -x -m 'not slow and not browser'`), "
        "numba JIT disabled except for the regression-builder modules (tools/mutation.toml).",
        f"- Sample: seeded ({cfg['seed']}) stratified by module: {cfg['fraction']:.0%} of each module's mutation "
        f"sites (at least {cfg['min_sites']}), one operator variant per drawn site; "
        f"{total} mutants drawn from a population of {population} "
        "(bitwise/shift replacements of arithmetic operators and the Variable* operators excluded).",
        "",
        "| mutants | killed | timeout | incompetent | survived, equivalent | survived, real | pending | score |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|",
        f"| {total} | {count['killed']} | {count['timeout']} | {count['incompetent']} | {count['equivalent']} | "
        f"{count['survived']} | {count['pending']} | **{score:.1%}** |",
        "",
        "Score = (killed + timeout) / (mutants − equivalent), a pending (not yet judged) mutant counted as a "
        f"survivor; a timeout is a mutant the tests detected by running over {cfg['timeout']:.0f} s. Goal ≥ 90 %."
        + (f" Over the {judged} judged mutants only: {score_judged:.1%} "
           "(the run was stopped before judging the pending ones; `make mutation` resumes it)."
           if count["pending"] else ""),
        "",
        "## By module",
        "",
        "| module | drawn / population | killed | timeout | equivalent | survived, real |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for module in cfg["modules"]:
        mine = [r for r in rows if r["module"] == module]
        pop = json.loads((SESSIONS / f"{slug(module)}.sample.json").read_text())["population"]
        c = defaultdict(int)
        for r in mine:
            c[r["status"]] += 1
        out.append(f"| `{module.removeprefix('src/')}` | {len(mine)} / {pop} | {c['killed']} | {c['timeout']} | "
                   f"{c['equivalent']} | {c['survived']} |")
    out += ["", "## Equivalent survivors", "",
            "| module:line | operator (occurrence) | code | why equivalent |", "|---|---|---|---|"]
    for r in rows:
        if r["status"] == "equivalent":
            out.append(f"| `{r['module'].removeprefix('src/')}:{r['line']}` | {r['operator']} ({r['occurrence']}) | "
                       f"`{_cell(r['code'])}` | {r['reason']} |")
    real = [r for r in rows if r["status"] in ("survived", "incompetent", "pending")]
    out += ["", "## Survivors not judged equivalent (test gaps left open)", ""]
    if real:
        out += ["| module:line | operator (occurrence) | code | status |", "|---|---|---|---|"]
        out += [f"| `{r['module'].removeprefix('src/')}:{r['line']}` | {r['operator']} ({r['occurrence']}) | "
                f"`{_cell(r['code'])}` | {r['status']} |" for r in real]
    else:
        out.append("None.")
    if extra["stale"]:
        out += ["", f"Note: {len(extra['stale'])} entries of tools/mutation_equivalent.toml match no survivor."]
    path = ROOT / "reports" / "benchmarks" / "mutation.md"
    path.write_text("\n".join(out) + "\n")
    print(f"{path}: {total} mutants, {detected} detected, {count['equivalent']} equivalent, "
          f"{count['survived']} real survivors, score {score:.1%}")


def _cell(code: str) -> str:
    return code.replace("|", "\\|")


def _dist_version(name: str) -> str:
    from importlib.metadata import version
    return version(name)


def survivors(args) -> None:
    """List the survivors (with their diff) for triage."""
    cfg = load_config()
    for module in cfg["modules"]:
        db_path = SESSIONS / f"{slug(module)}.sqlite"
        if not db_path.exists():
            continue
        with use_db(str(db_path), WorkDB.Mode.open) as db:
            items = {i.job_id: i for i in db.work_items}
            for job, r in db.results:
                if r.test_outcome == TestOutcome.SURVIVED:
                    (m,) = items[job].mutations
                    print(f"== {module} {m.operator_name} {m.occurrence} line {m.start_pos[0]}")
                    print("\n".join(line for line in (r.diff or "").splitlines()
                                    if line.startswith(("+", "-")) and not line.startswith(("+++", "---"))))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--fresh", action="store_true", help="re-initialise every session")
    r.add_argument("--rerun-survivors", action="store_true", help="re-judge the survivors only")
    r.add_argument("--only", nargs="*", help="substrings of the modules to execute")
    sub.add_parser("report")
    sub.add_parser("survivors")
    args = p.parse_args()
    {"run": run, "report": report, "survivors": survivors}[args.cmd](args)


if __name__ == "__main__":
    main()
