"""Cost of the excitation search (:mod:`boundid.studies.excitation`): per candidate, the guaranteed
criterion's exact LP bounds against the classical cond and log det, and the whole search and
side-by-side comparison of three studies."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from boundid.bench.bench_sets import _load
from boundid.errors import InputError, SolverError, UnreachablePoseError
from boundid.experiments.excitation_design import classical_scores, design_widths
from boundid.studies.campaign import one_thread
from boundid.studies.config import StudyConfig, load_study, prior_box
from boundid.studies.excitation import (
    DESIGN_STREAM,
    compare_criteria,
    design_excitation,
    design_rows,
    family,
    joint_bounds,
)
from boundid.studies.registry import make_robot

ROOT = Path(__file__).resolve().parents[3]

#: the studies timed: one per excitation family (open loop, closed loop, tracking)
STUDIES = ("direct_drive_rls", "h4_obe", "ur5_urdf")
#: candidates of each search ([experiment.design] candidates, replaced): full run, --quick
CANDIDATES, QUICK_CANDIDATES = 8, 4
#: each scoring (and design regression) is timed as the best of REPEATS runs, one run when it takes
#: over LONG_S seconds
REPEATS, LONG_S = 3, 1.0
#: what design_excitation refuses and replaces by the next draw (as :func:`design_excitation`)
REFUSED = (InputError, UnreachablePoseError, SolverError)

GOALS = f"""
Cost of the excitation search (`[experiment] excitation = "guaranteed" | "cond" | "logdet"`,
:mod:`boundid.studies.excitation`) on three studies, one per excitation family:
studies/direct_drive_rls.toml (open loop: the paper's torque law with random amplitudes, frequencies
and phases, simulated), studies/h4_obe.toml (closed loop: slow and fast Fourier segments within the
workspace) and studies/ur5_urdf.toml (tracking: a Fourier trajectory within the joint limits of the
six-joint UR5 in base parameters). Each study runs with its own [experiment.design] settings
(`rate_hz`: the design regression's sample rate) except `candidates`, replaced
(`dataclasses.replace` on `cfg.experiment.design`) by **{CANDIDATES}** (--quick:
**{QUICK_CANDIDATES}**). `p`: the model's parameters; `N`: rows of one candidate's design regression
(joints x samples at `rate_hz`) on the candidate rows, of one pick's regression at the study's row
rate on the compare_criteria row.

**Per candidate** (`case = candidate`, numbered as the search numbers them), drawn from the search's
own random stream (`default_rng([seed, {DESIGN_STREAM}])`), so they are the candidates the search
then scores: `draw_s` the family's `draw(rng)` (one run: it consumes the stream), `rows_s` its
design regression (`design_rows`: the noise-free motion, simulated for the open loop, and its
inverse-dynamic regressor), `guaranteed_s` the guaranteed criterion (`design_widths`: the exact LP
bounds of the design set, HiGHS), `classical_s` the two classical ones together (`classical_scores`:
cond of the column-scaled W by SVD, and log det W^T W). Each of these three is the best of {REPEATS}
runs (one when a run takes over {LONG_S:g} s), wall clock, with the process CPU time of that run in
the `_cpu_s` column beside it (CPU counts every thread of the process, e.g. HiGHS's: it may exceed
wall). Everything runs with one BLAS/OpenMP thread (`boundid.studies.campaign.one_thread`), as
`boundid report` runs a study and the excitation page: with the default BLAS threads on the 2 shared
cores the SVD of `classical_scores` took either 0.1-0.3 ms or about 23 ms on the same rows (waiting
for a BLAS thread to be scheduled), which would make the ratio a measure of the load. **`ratio` =
guaranteed_s / classical_s**: what the guaranteed criterion costs against the classical ones,
measured side by side on the same rows in the same run (`cpu_ratio` the same on CPU time). `time_s`,
`cpu_s`: the candidate's sum (draw, rows, both scorings). The row `median over candidates` gives
each column's median over the study's candidates. A draw the family refuses (as the search does: out
of the workspace or limits) gets a row with its reason in `detail` and is replaced by the next draw.

**Whole calls**, after the per-candidate rows (warm: one-time costs such as solver set-up were paid
before, and an untimed warm-up LP and SVD ran before the first study): `design_excitation`
(`design_excitation(cfg, model, "guaranteed")`: draws and scores the same candidates by all three
criteria, so its time is about the sum of the candidate rows); `compare_criteria`
(`compare_criteria(cfg, model, design)` given that search, so the search is not counted twice: the
side-by-side page's own cost: each distinct pick of the first draw and the three criteria's bests
simulated at the study's row rate, its design widths there (the LP bounds of the design set again,
on those rows), the exact LP bounds of a recording with errors within half the bound and the study's
OBE and WLS on it; `detail` says how many distinct picks). `search + comparison` is their sum: the
cost of one study on the excitation page (`boundid excitation`, or `boundid report` for a study with
`[experiment.design] compare = true`), whose `compare_criteria(cfg, model)` runs the search itself.
Every row records the 1-minute load average when it was measured (`load_avg`; 2 shared cores).

No goal is stated: the table is the cost, to be read against the study's other stages.
"""


def _timed(fn, repeats: int = 1):
    """(fn()'s last result, best wall s, CPU s of that run) over ``repeats`` runs (one when a run
    takes over LONG_S)."""
    best, cpu, out = np.inf, np.nan, None
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        wall, c = time.perf_counter() - t0, time.process_time() - c0
        if wall < best:
            best, cpu = wall, c
        if wall > LONG_S:
            break
    return out, best, cpu


def _row(study: str, case: str, **kw) -> dict:
    base = {"study": study, "case": case, "candidate": np.nan, "p": np.nan, "N": np.nan, "candidates": np.nan,
            "rate_hz": np.nan, "draw_s": np.nan, "draw_cpu_s": np.nan, "rows_s": np.nan, "rows_cpu_s": np.nan,
            "guaranteed_s": np.nan, "guaranteed_cpu_s": np.nan, "classical_s": np.nan, "classical_cpu_s": np.nan,
            "ratio": np.nan, "cpu_ratio": np.nan, "time_s": np.nan, "cpu_s": np.nan, "load_avg": _load(),
            "detail": ""}
    return {**base, **kw}


def study_config(name: str, candidates: int) -> StudyConfig:
    """studies/<name>.toml with [experiment.design] candidates replaced by ``candidates``."""
    cfg = load_study(ROOT / "studies" / f"{name}.toml")
    design = replace(cfg.experiment.design, candidates=candidates)
    return replace(cfg, experiment=replace(cfg.experiment, design=design))


def warm_up() -> None:
    """One small LP bounds problem and SVD, untimed: solver and BLAS set-up is not charged to a case."""
    W = np.random.default_rng(0).normal(size=(60, 4))
    with one_thread():
        design_widths(W, 1.0, np.ones(4))
        classical_scores(W, np.ones(4))


def candidate_rows(cfg: StudyConfig, model) -> tuple[list[dict], list[tuple[float, float, float]]]:
    """The per-candidate rows of one study (its search's draws, timed part by part) and each scored
    candidate's (guaranteed, cond, logdet), as the search scores them."""
    settings, name = cfg.experiment.design, cfg.name
    fam = family(cfg, model)
    e_joint = joint_bounds(cfg, model.n_joints)
    _, half = prior_box(model, cfg.prior)
    rng = np.random.default_rng([cfg.seed, DESIGN_STREAM])
    common = {"p": model.p, "candidates": settings.candidates, "rate_hz": settings.rate_hz}
    rows, scores = [], []
    for i in range(2 * settings.candidates):
        if len(scores) == settings.candidates:
            break
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            cand = fam.draw(rng)
            draw_s, draw_cpu = time.perf_counter() - t0, time.process_time() - c0
            (_, W, _, e), rows_s, rows_cpu = _timed(
                lambda c=cand: design_rows(model, fam, c, settings.rate_hz, e_joint), REPEATS)
        except REFUSED as exc:
            rows.append(_row(name, "candidate", **common, time_s=time.perf_counter() - t0,
                             cpu_s=time.process_time() - c0, detail=f"draw {i} refused: {type(exc).__name__}: {exc}"))
            continue
        widths, g_s, g_cpu = _timed(lambda W=W, e=e: design_widths(W, e, half), REPEATS)
        (cond, logdet), c_s, c_cpu = _timed(lambda W=W: classical_scores(W, half), REPEATS)
        scores.append((float(widths.mean()), cond, logdet))
        rows.append(_row(name, "candidate", candidate=len(scores) - 1, N=W.shape[0], **common,
                         draw_s=draw_s, draw_cpu_s=draw_cpu, rows_s=rows_s, rows_cpu_s=rows_cpu,
                         guaranteed_s=g_s, guaranteed_cpu_s=g_cpu, classical_s=c_s, classical_cpu_s=c_cpu,
                         ratio=g_s / c_s, cpu_ratio=g_cpu / c_cpu if c_cpu > 0 else np.nan,
                         time_s=draw_s + rows_s + g_s + c_s, cpu_s=draw_cpu + rows_cpu + g_cpu + c_cpu,
                         detail=f"draw {i}; guaranteed {widths.mean():.3g}, cond {cond:.3g}, ln det {logdet:.4g}"))
    return rows, scores


def _median_row(rows: list[dict]) -> dict:
    """Each timing column's median over the scored candidates of ``rows``."""
    df = pd.DataFrame([r for r in rows if np.isfinite(r["candidate"])])
    cols = ["draw_s", "draw_cpu_s", "rows_s", "rows_cpu_s", "guaranteed_s", "guaranteed_cpu_s", "classical_s",
            "classical_cpu_s", "ratio", "cpu_ratio", "time_s", "cpu_s"]
    first = rows[0]
    return _row(first["study"], "median over candidates", p=first["p"], N=df["N"].median(),
                candidates=first["candidates"], rate_hz=first["rate_hz"],
                **{c: float(df[c].median()) for c in cols}, detail=f"median over {len(df)} candidates")


def study_rows(name: str, candidates: int) -> list[dict]:
    """The rows of one study: its candidates, their median, design_excitation, compare_criteria and
    their sum; with one BLAS/OpenMP thread, as a study and the excitation page run."""
    with one_thread():
        return _study_rows(name, candidates)


def _study_rows(name: str, candidates: int) -> list[dict]:
    cfg = study_config(name, candidates)
    model = make_robot(cfg.robot, cfg.robot_options)
    rows, scores = candidate_rows(cfg, model)
    rows.append(_median_row(rows))
    settings = cfg.experiment.design
    common = {"p": model.p, "candidates": settings.candidates, "rate_hz": settings.rate_hz}
    load = _load()
    design, d_s, d_cpu = _timed(lambda: design_excitation(cfg, model, "guaranteed"))
    sc = design.search.scores
    same = np.allclose(sc[["guaranteed", "cond", "logdet"]].to_numpy(), np.array(scores), rtol=1e-9, atol=0.0)
    rows.append(_row(name, "design_excitation", N=int(sc["rows"].median()), **common, time_s=d_s, cpu_s=d_cpu,
                     load_avg=load,
                     detail=f"{len(sc)} candidates scored, {len(design.search.failed)} draws refused; "
                            + ("the same scores as the candidate rows" if same else
                               "scores DIFFER from the candidate rows")
                            + f"; picks: guaranteed {design.search.best('guaranteed')}, cond "
                              f"{design.search.best('cond')}, logdet {design.search.best('logdet')}"))
    load = _load()
    comp, c_s, c_cpu = _timed(lambda: compare_criteria(cfg, model, design))
    distinct = len({pk.candidate for pk in comp.picks})
    rows.append(_row(name, "compare_criteria", N=comp.picks[0].rows, **common, time_s=c_s, cpu_s=c_cpu,
                     load_avg=load,
                     detail=f"{distinct} distinct pick{'s' * (distinct != 1)} of {len(comp.picks)} (first draw, "
                            f"guaranteed, cond, logdet) at {comp.rate_hz:g} Hz: design widths, exact LP bounds, "
                            f"{comp.obe_label or 'no OBE'}, {comp.wls_label or 'no WLS'}"))
    rows.append(_row(name, "search + comparison", **common, time_s=d_s + c_s, cpu_s=d_cpu + c_cpu,
                     detail="design_excitation + compare_criteria"))
    return rows


def run(quick: bool = False) -> pd.DataFrame:
    """Every study of :data:`STUDIES` with CANDIDATES (``quick``: QUICK_CANDIDATES) candidates, one after
    the other in this process. Same studies, same candidates: every draw is seeded by the study."""
    warm_up()
    n = QUICK_CANDIDATES if quick else CANDIDATES
    return pd.DataFrame([r for name in STUDIES for r in study_rows(name, n)])
