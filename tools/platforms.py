"""The tests and the studies under several OpenBLAS kernels and without numba's JIT.

    python tools/platforms.py test      # make test-platforms: the sets and estimators tests per kernel, then no JIT
    python tools/platforms.py compare   # make platforms-report: every study under two kernels, results.csv compared

A numerical test asserts the contract (a guaranteed set contains what it must, or the estimator says
loudly why not), never which branch rounding takes on one CPU: `test` runs the sets and estimators
tests under each OpenBLAS kernel of ``--kernels`` (OPENBLAS_CORETYPE) that this CPU can execute and
this OpenBLAS build has, then the tests of the compiled kernels with a numpy twin (or another
independent reference) once with numba's JIT disabled (NUMBA_DISABLE_JIT=1). A kernel is skipped,
with a line saying why, when the CPU lacks its instructions (forcing it would die of SIGILL), when
OpenBLAS does not run it when asked (threadpoolctl's ``architecture`` says which kernel runs), or
when it is the same kernel as one already run.

`compare` runs `boundid run` on every studies/*.toml under two kernels, writes the studies'
regression rows from a child process under each kernel, and compares each study's results.csv: every
non-numeric column (keys, kinds, containment flags) and the pattern of non-finite numbers must be
identical, and the numbers must agree to PLATFORM_RTOL (:mod:`boundid.report.study_page`, which
states it on every study page) where both kernels gave the study the same regression rows (to
SAME_ROWS, rounding) and the estimator is a continuous function of them. Other rows (a study whose
rows differ, the limited polytope) are compared on their verdicts only, and their largest
differences are reported. Writes
reports/benchmarks/platforms.md; exits 1 if a verdict differs or a checked number exceeds the
tolerance.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

#: regression rows the same under both kernels: relative difference at most this (rounding); rows that
#: differ more are compared on their verdicts only: an estimator's conditioning amplifies their
#: difference (the TX40's 61-parameter LP bounds: rows 1.1e-11 apart gave bounds 4.7e-8 apart)
SAME_ROWS = 1e-12
ROOT = Path(__file__).resolve().parent.parent
REPORT = ROOT / "reports" / "benchmarks" / "platforms.md"
#: one BLAS/OpenMP/numba thread per process: the runs use 2 pytest workers (or 2 studies) on 2 cores, as `make test`
THREADS = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
PYTEST = ["-m", "pytest", "-n", "2", "-q", "-p", "no:cacheprovider", "-m", "not slow and not browser"]

#: OpenBLAS kernels (OPENBLAS_CORETYPE): the CPU flags (/proc/cpuinfo names) their instructions need, and
#: the names threadpoolctl may report for them (a DYNAMIC_LIST build aliases Katmai ... Northwood to the
#: Prescott kernels and reports the first alias, Katmai; Zen runs the Haswell kernels)
KERNELS = {
    "Prescott": ({"pni"}, {"Prescott", "Katmai"}),
    "Nehalem": ({"ssse3", "sse4_1", "sse4_2"}, {"Nehalem"}),
    "Sandybridge": ({"avx"}, {"Sandybridge"}),
    "Haswell": ({"avx2", "fma"}, {"Haswell"}),
    "Zen": ({"avx2", "fma"}, {"Zen", "Haswell"}),
    "SkylakeX": ({"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"}, {"SkylakeX"}),
    "Cooperlake": ({"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl", "avx512_bf16"}, {"Cooperlake"}),
    "SapphireRapids": ({"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl", "avx512_bf16", "avx512_fp16"},
                       {"SapphireRapids"}),
}
#: the label of the kernel OpenBLAS picks for this CPU itself (no OPENBLAS_CORETYPE)
DEFAULT = "default"
#: the kernels `test` runs by default: one of each x86-64 family the OpenBLAS of numpy and scipy has (SSE3,
#: SSE4, AVX, AVX2 + FMA, AVX-512); Zen runs the Haswell kernels, and these builds have no Cooperlake or
#: SapphireRapids kernel (asked for, they run SkylakeX)
TEST_KERNELS = ["Prescott", "Nehalem", "Sandybridge", "Haswell", "SkylakeX"]

#: the sets and estimators tests, run under every kernel
KERNEL_TESTS = [
    "tests/test_ellipsoid.py", "tests/test_polytope.py", "tests/test_polytope_cut.py", "tests/test_sdp.py",
    "tests/test_sdp_failures.py", "tests/test_set_families.py", "tests/test_set_gaps.py", "tests/test_vertex_lp.py",
    "tests/test_scaling.py", "tests/test_obe.py", "tests/test_obe_gaps.py", "tests/test_obe_guarantee.py",
    "tests/test_obe_numerics.py", "tests/test_recursions.py", "tests/test_recursion_gaps.py",
    "tests/test_rls_kalman.py", "tests/test_least_squares.py", "tests/test_physical.py",
    "tests/test_physical_gaps.py", "tests/test_physical_stage.py", "tests/test_estimate_gaps.py",
    "tests/test_certify.py",
]
#: the tests of the numba kernels against a numpy twin or another independent reference, run once without
#: the JIT: the set recursions' loops against their numpy steps, the RLS/Kalman loop against its numpy
#: update and filterpy, the vertex simplex and the working-set LP (with the compiled strip blocks) against
#: linprog, the Wolfe-Atwood MVEE (the lower end of the SDP volume bracket) against the SDP ellipsoids, the
#: OBE steps against exact arithmetic, the H4 kernels against the numpy kinematics, the hold integrator
#: against solve_ivp. Not the randomized OBE harness (tests/test_obe_guarantee.py, 1.5 min uncompiled; it
#: runs under every kernel).
NO_JIT_TESTS = [
    "tests/test_recursions.py", "tests/test_recursion_gaps.py", "tests/test_rls_kalman.py",
    "tests/test_vertex_lp.py", "tests/test_polytope.py", "tests/test_sdp.py", "tests/test_obe.py",
    "tests/test_obe_gaps.py", "tests/test_obe_numerics.py", "tests/test_h4_model.py", "tests/test_experiments.py",
]

#: method names (results.csv column ``method``) of estimators with a discrete choice that rounding may flip:
#: the limited polytope keeps the strips nearest to active at the LP's bound vertices
DISCRETE_METHODS = ("Limited polytope",)
#: numeric columns of results.csv reported together
FAMILIES = {"center": ("center",), "lo, hi": ("lo", "hi"), "truth, prior": ("truth", "prior"), "level": ("level",)}

#: run in a child process under a kernel: numpy's and scipy's BLAS libraries as threadpoolctl sees them
PROBE = """
import json, numpy, scipy, scipy.linalg, threadpoolctl
print(json.dumps({"numpy": numpy.__version__, "scipy": scipy.__version__,
                  "blas": [{k: i.get(k) for k in ("internal_api", "version", "architecture", "filepath")}
                           for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"]}))
"""


def cpu_flags() -> set[str] | None:
    """The CPU's flags from /proc/cpuinfo (Linux), None where they cannot be read."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return None


def kernel_env(kernel: str) -> dict:
    """The environment of a run under ``kernel`` (DEFAULT: OpenBLAS's own choice), one thread each."""
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    env.update(THREADS)
    if kernel != DEFAULT:
        env["OPENBLAS_CORETYPE"] = kernel
    return env


def probe(env: dict) -> dict:
    """numpy, scipy and their BLAS libraries (version, kernel) in a child process with ``env``; raises
    RuntimeError naming the signal if it dies (SIGILL: an instruction this CPU lacks)."""
    r = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True)
    if r.returncode < 0:
        raise RuntimeError(f"the probe died of {signal.Signals(-r.returncode).name}")
    if r.returncode:
        raise RuntimeError(f"the probe failed: {(r.stderr.strip().splitlines() or [f'exit {r.returncode}'])[-1]}")
    return json.loads(r.stdout)


def check_kernel(kernel: str, flags: set[str] | None) -> tuple[dict | None, str]:
    """(the probe under ``kernel``, "") if the tests can run on it, else (None, why not)."""
    if kernel != DEFAULT:
        if kernel not in KERNELS:
            return None, f"unknown to this tool (known: {', '.join(KERNELS)})"
        if flags is None:
            return None, "the CPU's flags cannot be read (no /proc/cpuinfo): forcing it could crash with SIGILL"
        missing = sorted(KERNELS[kernel][0] - flags)
        if missing:
            return None, f"this CPU lacks {', '.join(missing)} (forcing it would crash with SIGILL)"
    try:
        info = probe(kernel_env(kernel))
    except RuntimeError as exc:
        return None, str(exc)
    openblas = [b for b in info["blas"] if b["internal_api"] == "openblas"]
    if not openblas:
        return None, "numpy and scipy do not use OpenBLAS here: " + ", ".join(b["internal_api"] for b in info["blas"])
    if kernel != DEFAULT:
        ran = {b["architecture"] for b in openblas}
        if not ran <= KERNELS[kernel][1]:
            return None, (f"OpenBLAS did not take it: OPENBLAS_CORETYPE={kernel} runs {', '.join(sorted(ran))} "
                          "(this build has no such kernel)")
    return info, ""


def kernels_of(info: dict) -> str:
    """The kernel(s) threadpoolctl reports for the OpenBLAS libraries of a probe."""
    return ", ".join(sorted({b["architecture"] for b in info["blas"] if b["internal_api"] == "openblas"}))


def run_tests(label: str, env: dict, files: list[str]) -> tuple[int, float]:
    """pytest on ``files`` with ``env``: (exit code, wall time in s)."""
    print(f"\n== platforms: {label}: {len(files)} test files", flush=True)
    t0 = time.perf_counter()
    rc = subprocess.call([sys.executable, *PYTEST, *files], cwd=ROOT, env=env)
    return rc, time.perf_counter() - t0


def cmd_test(args) -> int:
    """The sets and estimators tests under each usable kernel, then the no-JIT run; 1 if any run failed."""
    flags, runs, seen = cpu_flags(), [], {}
    for kernel in args.kernels:
        info, why = check_kernel(kernel, flags)
        if info is None:
            print(f"platforms: skipping OpenBLAS kernel {kernel}: {why}")
            continue
        ran = kernels_of(info)
        if ran in seen:
            print(f"platforms: skipping OpenBLAS kernel {kernel}: it runs {ran}, as {seen[ran]} did")
            continue
        seen[ran] = kernel
        runs.append((f"OPENBLAS_CORETYPE={kernel} (threadpoolctl: {ran})", kernel_env(kernel), KERNEL_TESTS))
    runs.append(("NUMBA_DISABLE_JIT=1", {**kernel_env(DEFAULT), "NUMBA_DISABLE_JIT": "1"}, NO_JIT_TESTS))
    results = [(label, *run_tests(label, env, files)) for label, env, files in runs]
    print("\nplatforms: summary")
    for label, rc, wall in results:
        print(f"  {'passed' if rc == 0 else f'FAILED (pytest exit {rc})'}: {label}, {wall:.0f} s")
    return int(any(rc for _, rc, _ in results))


def cmd_data(args) -> int:
    """Write every regression's rows (W, y) of each study to one .npz (run in a child process per kernel)."""
    from boundid.studies.config import load_study
    from boundid.studies.data import acquire
    from boundid.studies.registry import make_robot
    from boundid.studies.regressions import build_regressions

    arrays = {}
    for path in args.studies:
        cfg = load_study(path)
        model = make_robot(cfg.robot, cfg.robot_options)
        data = acquire(cfg, model, np.random.default_rng(cfg.seed))
        for name, reg in build_regressions(model, data.recording, cfg.preprocessing, cfg.regressions).items():
            arrays[f"{cfg.name}/{name}/W"], arrays[f"{cfg.name}/{name}/y"] = reg.W, reg.y
    np.savez(args.out, **arrays)
    return 0


def data_difference(a, b, study: str) -> float:
    """Largest relative difference max |a - b| / max |a| over a study's regression rows (inf if their shapes differ)."""
    worst = 0.0
    for key in (k for k in a.files if k.startswith(study + "/")):
        x, y = a[key], b[key]
        if x.shape != y.shape:
            return float("inf")
        worst = max(worst, float(np.max(np.abs(x - y), initial=0.0) / max(np.max(np.abs(x), initial=0.0), 1e-300)))
    return worst


def relative_differences(x: np.ndarray, y: np.ndarray, width: np.ndarray) -> np.ndarray:
    """|x - y| / max(|x|, |y|, width), 0 where x and y are equal (inf and nan included)."""
    equal = (x == y) | (np.isnan(x) & np.isnan(y))
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.abs(x - y) / np.fmax(np.fmax(np.abs(x), np.abs(y)), width)
    return np.where(equal, 0.0, rel)


def compare_study(a, b, data_rel: float, rtol: float) -> dict:
    """One study's results.csv under the two kernels (DataFrames ``a``, ``b``) compared, see the module's docstring."""
    out = {"rows": len(a), "columns": len(a.columns), "data": data_rel, "checked": 0, "verdicts": [],
           "numbers": [], "families": {}, "unchecked": {}}
    if list(a.columns) != list(b.columns) or len(a) != len(b):
        out["verdicts"].append(f"shapes differ: {a.shape} and {b.shape}")
        return out
    numeric = [c for c in a.columns if a[c].dtype.kind == "f" and b[c].dtype.kind == "f"]
    categorical = [c for c in a.columns if c not in numeric]
    out["categorical"], out["numeric"] = categorical, numeric
    for c in categorical:
        differ = int((a[c].fillna("<NA>").astype(str) != b[c].fillna("<NA>").astype(str)).sum())  # NA != NA
        if differ:
            out["verdicts"].append(f"column {c}: {differ} rows differ")
    for c in numeric:
        x, y = a[c].to_numpy(float), b[c].to_numpy(float)
        differ = int(np.sum((np.isfinite(x) != np.isfinite(y)) | (~np.isfinite(x) & (x != y) & ~np.isnan(x))))
        if differ:
            out["verdicts"].append(f"column {c}: {differ} rows finite under one kernel only (or infinite of "
                                   "another sign)")
    width = np.fmax(np.abs(a["hi"] - a["lo"]).to_numpy(float), np.abs(b["hi"] - b["lo"]).to_numpy(float))
    width = np.where(np.isfinite(width), width, 0.0)
    discrete = a["method"].astype(str).str.startswith(DISCRETE_METHODS).to_numpy()
    checked = ~discrete if data_rel <= SAME_ROWS else np.zeros(len(a), bool)
    out["checked"] = int(checked.sum())
    for fam, cols in FAMILIES.items():
        cols = [c for c in cols if c in numeric]
        if not cols:
            continue
        rel = np.max([relative_differences(a[c].to_numpy(float), b[c].to_numpy(float), width) for c in cols], axis=0)
        for key, rows in (("families", checked), ("unchecked", ~checked)):
            if rows.any():
                out[key][fam] = float(np.max(rel[rows]))
        over = int(np.sum(rel[checked] > rtol))
        if over:
            out["numbers"].append(f"{fam}: {over} checked rows differ by more than {rtol:g}")
    return out


def run_studies(kernel: str, out: Path, studies: list[Path]) -> dict:
    """`boundid run` on ``studies`` and their regression rows (``out``/data.npz) under ``kernel``; its probe."""
    info, why = check_kernel(kernel, cpu_flags())
    if info is None:
        raise SystemExit(f"platforms: cannot compare under OpenBLAS kernel {kernel}: {why}")
    env = kernel_env(kernel)
    print(f"== platforms: the studies under {kernel} (threadpoolctl: {kernels_of(info)})", flush=True)
    boundid = Path(sys.executable).with_name("boundid")
    subprocess.run([str(boundid), "run", *map(str, studies), "--out", str(out), "--quiet", "--jobs", "2"],
                   cwd=ROOT, env=env, check=True)
    subprocess.run([sys.executable, __file__, "data", str(out / "data.npz"), *map(str, studies)],
                   cwd=ROOT, env=env, check=True)
    return info


def _g(x: float) -> str:
    return f"{x:.2g}"


def _kernel_name(kernel: str, info: dict) -> str:
    """How the report names a kernel: as asked for, and as threadpoolctl saw it run."""
    asked = "OpenBLAS's own choice for this CPU" if kernel == DEFAULT else f"OPENBLAS_CORETYPE={kernel}"
    return f"{asked} (threadpoolctl: {kernels_of(info)})"


def write_report(kernels: list[str], infos: list[dict], results: dict, rtol: float, wall: float) -> None:
    """reports/benchmarks/platforms.md from the comparison (every number from this run)."""
    import numba

    from boundid.bench.goals import cpu_model

    fams = list(FAMILIES)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    names = [_kernel_name(k, i) for k, i in zip(kernels, infos, strict=True)]
    categorical = sorted({c for r in results.values() for c in r.get("categorical", ())})
    blas = "; ".join(f"{Path(b['filepath']).parent.name.removesuffix('.libs')} OpenBLAS {b['version']}"
                     for b in infos[0]["blas"])
    out = ["# Studies across OpenBLAS kernels", "",
           f"Generated by `make platforms-report` (tools/platforms.py compare) on {dt.date.today()}, commit "
           f"`{commit.stdout.strip()}`, in {wall:.0f} s: every studies/*.toml run by `boundid run` under kernel A "
           f"and kernel B, its results.csv compared row by row.", "",
           f"- Kernels: A = {names[0]}, B = {names[1]}; CPU {cpu_model()}.",
           f"- Versions: numpy {infos[0]['numpy']}, scipy {infos[0]['scipy']} ({blas}), numba {numba.__version__}, "
           f"Python {platform.python_version()}.",
           "- Verdicts: every non-numeric column (" + ", ".join(f"`{c}`" for c in categorical) + ") and which "
           "numbers are finite must be identical.",
           f"- Numbers: relative difference |a - b| / max(|a|, |b|, hi - lo) (hi - lo: the row's interval width, so "
           f"that a value near 0 is measured against its interval), at most {rtol:g} "
           "(`boundid.report.study_page.PLATFORM_RTOL`, stated on every study page) on the rows it is checked on: "
           f"the study's regression rows agree between the kernels to {SAME_ROWS:g}, rounding (column `regression "
           "rows differ`: their largest relative difference; an estimator's conditioning amplifies a larger "
           "difference: the TX40's 61-parameter LP bounds turned rows 1.1e-11 apart into bounds 4.7e-8 apart), "
           "and the estimator is a continuous function of them "
           "(not the limited polytope, whose choice of strips may flip). The other rows are compared on their "
           "verdicts only; their largest differences are in the second table. A study's regression rows may "
           "differ between kernels although its inputs do not: a simulated encoder rounds the angle to counts, "
           "so a last-digit difference can flip a count, and a feedback loop (a tracking controller) then "
           "follows a slightly different path.",
           "",
           "| study | rows | columns (non-numeric + numeric) | regression rows differ | verdicts identical | "
           "rows checked | " + " | ".join(f"{f}: largest" for f in fams) + " | outcome |",
           "|---|---:|---:|---:|---|---:|" + "---:|" * len(fams) + "---|"]
    for study, r in results.items():
        fam = [_g(r["families"][f]) if f in r["families"] else "–" for f in fams]
        columns = f"{len(r['categorical'])} + {len(r['numeric'])}" if "numeric" in r else str(r["columns"])
        out.append(f"| {study} | {r['rows']} | {columns} | {_g(r['data'])} | "
                   f"{'no' if r['verdicts'] else 'yes'} | {r['checked']} | " + " | ".join(fam)
                   + f" | {'; '.join(r['verdicts'] + r['numbers']) or 'pass'} |")
    out += ["", "Rows compared on their verdicts only (largest relative difference, not checked):", "",
            "| study | rows | why | " + " | ".join(fams) + " |", "|---|---:|---|" + "---:|" * len(fams)]
    for study, r in results.items():
        if r["rows"] - r["checked"]:
            why = ("its regression rows differ between the kernels" if r["data"] > rtol
                   else "the limited polytope (a discrete choice of strips)")
            out.append(f"| {study} | {r['rows'] - r['checked']} | {why} | "
                       + " | ".join(_g(r["unchecked"][f]) if f in r["unchecked"] else "–" for f in fams) + " |")
    REPORT.write_text("\n".join(out) + "\n", encoding="utf-8")


def cmd_compare(args) -> int:
    """Every study under the two kernels, results.csv compared, platforms.md written; 1 on a difference."""
    import pandas as pd

    from boundid.report.study_page import PLATFORM_RTOL

    t0 = time.perf_counter()
    studies = sorted((ROOT / "studies").glob("*.toml"))
    with tempfile.TemporaryDirectory(prefix="platforms-") as tmp:
        outs = [Path(tmp) / f"k{i}" for i in range(2)]
        infos = [run_studies(k, o, studies) for k, o in zip(args.kernels, outs, strict=True)]
        data = [np.load(o / "data.npz") for o in outs]
        names = sorted({p.parent.name for o in outs for p in o.glob("*/results.csv")})
        results = {}
        for name in names:
            a, b = (pd.read_csv(o / name / "results.csv") for o in outs)
            results[name] = compare_study(a, b, data_difference(*data, name), PLATFORM_RTOL)
    write_report(args.kernels, infos, results, PLATFORM_RTOL, time.perf_counter() - t0)
    failed = [name for name, r in results.items() if r["verdicts"] or r["numbers"]]
    for name, r in results.items():
        largest = "; ".join(f"{f} {_g(v)}" for f, v in r["families"].items())
        outcome = "; ".join(r["verdicts"] + r["numbers"]) or "pass"
        print(f"platforms: {name}: {r['rows']} rows, regression rows differ by {_g(r['data'])}, {r['checked']} rows "
              f"checked{f' (largest: {largest})' if largest else ''}: {outcome}")
    print(f"platforms: {REPORT.relative_to(ROOT)} written; tolerance {PLATFORM_RTOL:g}; "
          + (f"FAILED: {', '.join(failed)}" if failed else "every study passes"))
    return int(bool(failed))


def main() -> int:
    """Command line: test | compare | data (compare's child step)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("test", help="the sets and estimators tests under each kernel, then without numba's JIT")
    t.add_argument("--kernels", nargs="+", default=TEST_KERNELS, metavar="KERNEL",
                   help=f"OPENBLAS_CORETYPE values (known: {', '.join(KERNELS)}; '{DEFAULT}': OpenBLAS's own "
                        f"choice); default: {' '.join(TEST_KERNELS)}")
    t.set_defaults(func=cmd_test)
    c = sub.add_parser("compare", help="every study under two kernels; writes reports/benchmarks/platforms.md")
    c.add_argument("--kernels", nargs=2, default=["Haswell", DEFAULT], metavar="KERNEL",
                   help=f"the two kernels (default: Haswell and '{DEFAULT}', OpenBLAS's choice for this CPU)")
    c.set_defaults(func=cmd_compare)
    d = sub.add_parser("data", help="(compare's child step) write the studies' regression rows to an .npz")
    d.add_argument("out", help="the .npz to write")
    d.add_argument("studies", nargs="+", help="study files")
    d.set_defaults(func=cmd_data)
    args = ap.parse_args()
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
