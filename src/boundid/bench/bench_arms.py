"""Benchmark of full arms at the exact layer: LP bounds, SDP ellipsoids and physically consistent
bounds of URDF arms in base parameters, their peak memory, and how their times grow with p and N."""

from __future__ import annotations

import multiprocessing
import re
import resource
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pandas as pd

from boundid.bench.bench_physical import _urdf_states
from boundid.bench.bench_sets import _load
from boundid.bench.goals import Goal
from boundid.models import BaseParameterModel, UrdfRobot
from boundid.models.direct_drive import PHYSICAL, planar_arm_urdf
from boundid.sets import Polytope, sdp
from boundid.sets.physical import PhysicalSet

# The measurements of the six-joint UR5 (N = 8,600) when its goals were set, on an idle
# 2-core machine: the reference of `ratio_to_baseline`, not this run's numbers.
BASELINE_UR5_EXACT_S = 92.0
BASELINE_UR5_PHYSICAL_S = 47.0

NOISE = 0.2    # N m: half-width of the uniform torque noise of every row
E_MAX = 0.25   # N m: the strips' error bound (studies/ur5_urdf.toml)
PRIOR = 50.0   # the prior box: +-PRIOR about 0 for every parameter (studies/ur5_urdf.toml)

#: every joint's viscous (N m s/rad) and Coulomb (N m) friction and motor inertia (kg m^2), as studies/ur5_urdf.toml
JOINT_OPTIONS = {"viscous": 0.5, "coulomb": 1.0, "with_armature": True, "armature": 0.1}
_UR5_ARM = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint")
#: key: (label, example-robot-data name or None for the 2-link arm, joints kept or None for all);
#: the comment gives p, the number of base parameters
ROBOTS = {
    "arm2": ("2-link arm", None, None),              # p = 10
    "ur5-2": ("UR5, 2 joints", "ur5", _UR5_ARM[:2]),  # p = 12
    "ur5-3": ("UR5, 3 joints", "ur5", _UR5_ARM),      # p = 22
    "ur5": ("UR5, 6 joints", "ur5", None),            # p = 52
    "panda": ("Panda, 7 joints", "panda", None),      # p = 62
}
#: the headline cases: the issue's 8,600 rows of the six-joint UR5 (20 s at 1 kHz, low-pass
#: filtered, decimated by 10, low-speed rows masked), and as many rows per joint for the Panda
HEADLINE = {"ur5": 8_600, "panda": 8_600 * 7 // 6}
GRID_N = (2_000, 10_000, 50_000)
#: the arms whose exact stage takes minutes at N = 10,000 on 2 cores: their grid stops there (at 50,000 rows a
#: case would take tens of minutes; the exponent in N is fitted on the smaller arms and their two sizes)
LARGE, LARGE_MAX_N = ("ur5", "panda"), 10_000
QUICK_ROBOTS = ("arm2", "ur5-2", "ur5-3")
QUICK_N = (2_000, 10_000)
EXACT_PARTS = ("LP bounds", "outer ellipsoid", "inner ellipsoid", "John ellipsoid")
PARTS = (*EXACT_PARTS, "physical bounds")
#: rows of the 2-link arm every fresh process solves untimed before its case (see _fresh_case)
WARM_UP_ROWS = 200

GOALS = f"""
Full arms at the exact layer: the parts of the exact stage on URDF arms in base parameters, each
timed on its own (wall `time_s` and process CPU `cpu_s`), with the peak memory of the case.

**Regressions.** `BaseParameterModel(UrdfRobot(...))` with viscous friction 0.5 N m s/rad,
Coulomb friction 1.0 N m and a motor inertia 0.1 kg m^2 at every joint (as studies/ur5_urdf.toml):
the UR5 with its first two joints (shoulder pan and lift, p = 12), its three positioning joints
(p = 22) and all six (p = 52), the Panda with its seven (p = 62); and the direct-drive 2-link arm
written as a URDF (`planar_arm_urdf`, its own friction, no motor inertia, p = 10). Rows are exact
random states within the joint limits (no simulation: y = Y(q, qd, qdd) beta + e, as the physical
benchmark builds them), e uniform in +-{NOISE} N m, e_max = {E_MAX} N m, prior box +-{PRIOR:g} about 0
for every parameter; every draw is seeded by the case. `N` counts rows (one per joint and state).

**Parts**, on one polytope P = `Polytope.from_strips(W, y, e_max, box)`, as a study solves them
(each later part reuses what P caches: the LP bounds and frame, John's the inscribed ellipsoid):
`LP bounds` (`P.bounds()`); then the three ellipsoids by `sdp.polytope_ellipsoids`, which solves
the `inner ellipsoid` (`sdp.inner_ellipsoid`), the `outer ellipsoid` (`sdp.outer_ellipsoid`, its
LPs on two threads) and the `John ellipsoid` (`sdp.john_outer`: the inscribed one scaled, checked
on the known vertices) one after the other; each one's `time_s` is its own wall time there (their
CPU time is counted once, on the exact stage's row); `exact stage` is the wall time of the LP bounds
plus that of the three ellipsoids, as in a study's "exact optima" (the goal's measure); then
`physical bounds` (`model.physical_constraints()` and `PhysicalSet(..., plain=P).bounds()`: one
pseudo-inertia LMI per link, Clarabel, the 2p objectives on two threads, first on one shared working
set, then each one that still violates strips on a set of its own). A
part that raises has no time and says why in `detail`.

**Memory.** Each case runs in a fresh process (multiprocessing, "spawn"); `peak_rss_gb` is that
process's peak resident memory at the end of the case (`ru_maxrss`, 10^9 bytes), the same on all
its rows; it includes the imports and the regression. Before its case each process solves the five
parts untimed on {WARM_UP_ROWS} rows of the 2-link arm, so that one-time costs (compiled kernels read
from their cache, solver set-up: about 2 s) are not charged to the first part.

**Goals** (the issue's): the six-joint UR5 at N = {HEADLINE['ur5']:,} (the issue's size: a 20 s
recording at 1 kHz after filtering, decimation by 10 and the low-speed mask): exact stage <= 15 s,
physical bounds <= 10 s, peak memory <= 2 GB; the Panda at as many rows per joint (N =
{HEADLINE['panda']:,}): exact stage <= 30 s, physical bounds <= 20 s. When the goal was set, the
six-joint UR5's exact stage took 92 s and its physical bounds 47 s on an idle 2-core machine, on
the study's own recording (these rows are random states of the same p and N); `ratio_to_baseline`
on those two rows is this run's time over that one. These cases take minutes
each and do not run with --quick.

**Growth.** The five arms (p = 10, 12, 22, 52, 62) x N = 2,000, 10,000, 50,000, except N = 50,000
for p = 52 and 62, which would take tens of minutes a case (--quick: p <= 22, N = 2,000 and
10,000). Per part a row `what = exponent` holds `exp_p` and `exp_N`: the power law
t = c p^exp_p N^exp_N fitted by least squares of ln t on (1, ln p, ln N) over the grid (on a full
grid, exp_p is the mean over N of the slope at fixed N, exp_N the mean over p of the slope at fixed
p; `detail` gives each of those slopes). The row `what = dominant` names the part that takes
longest at the largest case. Every row records the 1-minute load average (2 shared cores).
"""


def _where(case: str, part: str) -> dict:
    return {"case": re.escape(case), "part": re.escape(part)}


def headline_case(key: str) -> str:
    """The `case` cell of a headline case."""
    return f"headline: {ROBOTS[key][0]}, N={HEADLINE[key]}"


def grid_case(key: str, N: int) -> str:
    """The `case` cell of a growth-grid case."""
    return f"grid: {ROBOTS[key][0]}, N={N}"


_SIZE = "{robot}, p = {p:.0f}, N = {N:,.0f}"
GOAL_CHECKS = (
    Goal("six-joint UR5: exact stage (LP bounds, outer, inner and John ellipsoids), time",
         _where(headline_case("ur5"), "exact stage"), "time_s", "<=", 15.0, "s", size=_SIZE, cpu_column="cpu_s"),
    Goal("six-joint UR5: physically consistent bounds, time", _where(headline_case("ur5"), "physical bounds"),
         "time_s", "<=", 10.0, "s", size=_SIZE, cpu_column="cpu_s"),
    Goal("six-joint UR5: peak memory of the case", _where(headline_case("ur5"), "exact stage"), "peak_rss_gb", "<=",
         2.0, "GB", size=_SIZE),
    Goal("Panda: exact stage (LP bounds, outer, inner and John ellipsoids), time",
         _where(headline_case("panda"), "exact stage"), "time_s", "<=", 30.0, "s", size=_SIZE, cpu_column="cpu_s"),
    Goal("Panda: physically consistent bounds, time", _where(headline_case("panda"), "physical bounds"),
         "time_s", "<=", 20.0, "s", size=_SIZE, cpu_column="cpu_s"),
)


def arm(key: str, folder) -> BaseParameterModel:
    """The arm ``key`` of :data:`ROBOTS` in base parameters; ``folder``: where the 2-link arm's URDF goes."""
    _, source, joints = ROBOTS[key]
    if source is None:
        return BaseParameterModel(UrdfRobot(planar_arm_urdf(folder), gravity=[0.0, 0.0, -PHYSICAL["g"]]))
    return BaseParameterModel(UrdfRobot(source, joints=joints, **JOINT_OPTIONS))


def regression(model: BaseParameterModel, N: int, seed) -> tuple[np.ndarray, np.ndarray]:
    """(W (N, p), y (N,)): the first N rows of ceil(N / n_joints) exact random states within the
    joint limits, y with uniform noise of +-NOISE N m (``seed``: any numpy seed)."""
    W, y = _urdf_states(model, -(-N // model.n_joints), NOISE, seed)
    return W[:N], y[:N]


def _info(res, keys) -> str:
    return ", ".join(f"{k.replace('_', ' ')} {res.info[k]}" for k in keys if k in res.info)


def _timed(solve):
    """(result or the exception it raised, wall s, CPU s) of solve()."""
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        res = solve()
    except Exception as exc:  # noqa: BLE001 - recorded in the row; the other parts still run
        res = exc
    return res, time.perf_counter() - t0, time.process_time() - c0


def _described(part: str, res, seconds: float, cpu: float, describe) -> tuple[str, float, float, str]:
    if isinstance(res, Exception):
        return part, np.nan, np.nan, f"failed after {seconds:.1f} s: {type(res).__name__}: {res}"
    return part, seconds, cpu, describe(res)


def _parts(model: BaseParameterModel, W: np.ndarray, y: np.ndarray) -> list[tuple[str, float, float, str]]:
    """[(part, wall s, CPU s, detail)] of :data:`PARTS` and the exact stage, on one polytope as a study
    solves it: the LP bounds, then the three ellipsoids by ``sdp.polytope_ellipsoids`` (one after the
    other, each with its own wall time; their CPU time is counted once, on the exact stage's row), then
    the physically consistent bounds. A part that
    raises gets NaN times and the error in its detail (the later parts still run)."""
    box = (np.full(model.p, -PRIOR), np.full(model.p, PRIOR))
    P = Polytope.from_strips(W, y, E_MAX, box=box)
    bounds, t_lp, c_lp = _timed(P.bounds)
    out = [_described("LP bounds", bounds, t_lp, c_lp,
                      lambda b: _info(b, ("lp_solves", "working_rows", "strips_reaching_box")))]
    ells, t_sdp, c_sdp = _timed(lambda: sdp.polytope_ellipsoids(P, ("outer", "inner", "john")))
    describe = {
        "outer": lambda r: _info(r, ("rounds", "strips_tightened", "support_lps")) + f", {len(r.strips)} strips in "
                                                                                     "the SDP",
        "inner": lambda r: _info(r, ("rounds", "working_sides")),
        "john": lambda r: f"reuses the inner ellipsoid; {_info(r, ('vertex_repair',))} on "
                          f"{r.info['vertices_checked']} known vertices"}
    for part, name in zip(EXACT_PARTS[1:], ("outer", "inner", "john"), strict=True):
        res, seconds = ells[name] if isinstance(ells, dict) else (ells, t_sdp)
        out.append(_described(part, res, seconds, np.nan, describe[name]))
    failed = isinstance(bounds, Exception) or isinstance(ells, Exception)
    out.append(("exact stage", np.nan if failed else t_lp + t_sdp, np.nan if failed else c_lp + c_sdp,
                "LP bounds, then the three ellipsoids as a study solves them (the outer one's LPs on two threads)"))
    phys, t, c = _timed(lambda: PhysicalSet(W, y, E_MAX, model.physical_constraints(), box=box, plain=P).bounds())
    out.append(_described("physical bounds", phys, t, c, lambda b: f"{b.method}, certificate {b.certificate}; "
                                                                  f"{_info(b, ('rounds', 'solves', 'working_rows'))}"))
    return out


def _row(what: str, case: str, robot: str, p, N, part: str, **kw) -> dict:
    base = {"what": what, "case": case, "robot": robot, "p": p, "N": N, "part": part, "time_s": np.nan,
            "cpu_s": np.nan, "peak_rss_gb": np.nan, "load_avg": _load(), "exp_p": np.nan, "exp_N": np.nan,
            "ratio_to_baseline": np.nan, "detail": ""}
    return {**base, **kw}


def case(key: str, N: int, name: str) -> list[dict]:
    """The rows of one case (``name`` in `case`), measured in this process: one per part and the exact
    stage (:func:`_parts`). ``peak_rss_gb`` is this process's peak resident
    memory when the case ends, GB (10^9 bytes): :func:`run` runs each case in a fresh process."""
    with tempfile.TemporaryDirectory() as folder:
        model = arm(key, folder)
        W, y = regression(model, N, seed=(list(ROBOTS).index(key), N))
        parts = _parts(model, W, y)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e9  # Linux: ru_maxrss in KiB
    common = {"case": name, "robot": ROBOTS[key][0], "p": model.p, "N": W.shape[0], "peak_rss_gb": peak}
    return [_row("stage" if part == "exact stage" else "part", part=part, time_s=t, cpu_s=c, detail=d, **common)
            for part, t, c, d in parts]


def _fresh_case(key: str, N: int, name: str) -> list[dict]:
    """:func:`case` after an untimed warm-up on the 2-link arm (this runs in a fresh process)."""
    with tempfile.TemporaryDirectory() as folder:
        model = arm("arm2", folder)
        _parts(model, *regression(model, WARM_UP_ROWS, seed=0))
    return case(key, N, name)


def in_fresh_process(key: str, N: int, name: str) -> list[dict]:
    """:func:`case` in a new process (spawned, so its peak memory is the case's alone); if the
    process dies, one row per part with no time and the error in ``detail``."""
    try:
        with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
            return pool.submit(_fresh_case, key, N, name).result()
    except Exception as exc:  # noqa: BLE001 - e.g. killed for lack of memory: recorded, the next case runs
        return [_row("part", name, ROBOTS[key][0], "", N, part, detail=f"the case's process failed: "
                     f"{type(exc).__name__}: {exc}") for part in (*PARTS, "exact stage")]


def exponents(p, N, t) -> tuple[float, float]:
    """(exp_p, exp_N) of the power law t = c p^exp_p N^exp_N, least squares of ln t on (1, ln p, ln N)
    over the entries with a finite positive t (p, N, t: equal-length sequences); NaN for a variable
    that takes a single value there, and both NaN when the fit is not determined."""
    p, N, t = (np.asarray(v, dtype=float) for v in (p, N, t))
    ok = np.isfinite(t) & (t > 0) & np.isfinite(p) & np.isfinite(N)
    logs = {"p": np.log(p[ok]), "N": np.log(N[ok])}
    varying = [k for k, v in logs.items() if v.size and np.ptp(v) > 0]
    X = np.column_stack([np.ones(int(ok.sum())), *(logs[k] for k in varying)])
    out = {"p": np.nan, "N": np.nan}
    if varying and np.linalg.matrix_rank(X) == X.shape[1] and X.shape[0] >= X.shape[1]:
        out.update(zip(varying, np.linalg.lstsq(X, np.log(t[ok]), rcond=None)[0][1:], strict=True))
    return float(out["p"]), float(out["N"])


def _slopes(g: pd.DataFrame) -> str:
    """The slope of ln t on ln p at each fixed N, and on ln N at each fixed p, of one part's grid rows."""
    at_n = ", ".join(f"{exponents(s.p, s.N, s.time_s)[0]:.2f} at N = {n:,}" for n, s in g.groupby("N"))
    at_p = ", ".join(f"{exponents(s.p, s.N, s.time_s)[1]:.2f} at p = {q}" for q, s in g.groupby("p"))
    return f"slope in ln p: {at_n}; in ln N: {at_p}"


def growth_rows(grid: pd.DataFrame) -> list[dict]:
    """From the grid's measured rows: one `exponent` row per part (and the exact stage), and the
    `dominant` row naming the part that takes longest at the largest case (largest p, then N)."""
    ok = grid[pd.to_numeric(grid.p, errors="coerce").notna()].astype({"p": int, "N": int})
    rows = []
    for part in (*PARTS, "exact stage"):
        g = ok[ok.part == part]
        e_p, e_n = exponents(g.p, g.N, g.time_s)
        rows.append(_row("exponent", "growth grid", "", "", "", part, exp_p=e_p, exp_N=e_n, detail=_slopes(g)))
    if ok.empty:
        return rows
    last = ok.sort_values(["p", "N"]).iloc[-1]
    big = ok[(ok.case == last.case) & ok.part.isin(PARTS)]
    top = big.loc[big.time_s.fillna(-1).idxmax()]
    rows.append(_row("dominant", last.case, last.robot, int(last.p), int(last.N), top.part, time_s=top.time_s,
                     cpu_s=top.cpu_s, peak_rss_gb=top.peak_rss_gb,
                     detail=f"the longest of the five parts at the largest case: {top.time_s:.3g} s of their "
                            f"{big.time_s.sum():.3g} s ({100 * top.time_s / big.time_s.sum():.0f} %)"))
    return rows


def baseline_ratio(row: dict) -> float:
    """time_s over the issue's baseline on the headline UR5's exact stage and physical bounds rows, else NaN."""
    baseline = {"exact stage": BASELINE_UR5_EXACT_S, "physical bounds": BASELINE_UR5_PHYSICAL_S}
    if row["case"] != headline_case("ur5") or row["part"] not in baseline:
        return np.nan
    return row["time_s"] / baseline[row["part"]]


def run(quick: bool = False) -> pd.DataFrame:
    """The headline cases (not with ``quick``), the growth grid and its exponents; each case in a
    fresh process, one after the other. Same data, same numbers: every draw is seeded."""
    rows = [] if quick else [r for key in HEADLINE for r in in_fresh_process(key, HEADLINE[key], headline_case(key))]
    for r in rows:
        r["ratio_to_baseline"] = baseline_ratio(r)
    grid = []
    for key in QUICK_ROBOTS if quick else ROBOTS:
        for N in QUICK_N if quick else GRID_N:
            if key in LARGE and N > LARGE_MAX_N:
                continue
            grid += in_fresh_process(key, N, grid_case(key, N))
    return pd.DataFrame(rows + grid + growth_rows(pd.DataFrame(grid)))
