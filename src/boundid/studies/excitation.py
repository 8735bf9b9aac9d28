"""The excitation of a study designed before the experiment, and the three criteria side by side.

``[experiment] excitation = "guaranteed" | "cond" | "logdet"`` draws ``[experiment.design]
candidates`` excitations of the experiment's own family (seeded by the study's seed, on a stream
of their own), scores each by the three criteria of :mod:`boundid.experiments.excitation_design`
on its design regression (the inverse-dynamic regressor of its noise-free motion, sampled at
``rate_hz``, at the study's [exact] e_max, within its prior box) and runs the experiment on the
criterion's best. The families:

- open loop (the direct-drive arm): the paper's torque law (31)-(32) with its ramps and peak torques,
  the sine amplitudes split at random, frequencies and phases random
  (:func:`boundid.experiments.excitation.random_multisine`); the motion by open-loop simulation of
  the truth;
- closed loop (the H4): the slow and fast Fourier segments within the workspace
  (:func:`boundid.experiments.trajectories.exciting_trajectory`);
- tracking (URDF arms): a Fourier trajectory within the joint limits
  (:func:`boundid.experiments.tracking.limited_fourier`).

:func:`compare_criteria` then puts the picks side by side (``[experiment.design] compare``, the page
reports/excitation/): each pick's rows at the study's row rate with
errors uniform within half the bound, and on them the exact LP widths, the study's OBE and WLS widths.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from boundid.errors import RUN_FAILURES, InputError, SolverError, StudyError, UnreachablePoseError
from boundid.experiments.excitation import RampedMultisine, random_multisine
from boundid.experiments.excitation_design import CRITERIA, ExcitationSearch, design_widths, search_excitation
from boundid.experiments.regression import Regression
from boundid.models import RobotModel
from boundid.sets import Polytope
from boundid.studies.config import ExcitationSearchConfig, StudyConfig, prior_box
from boundid.studies.data import tracking_config
from boundid.studies.estimation import run_estimator
from boundid.studies.h4_experiment import h4_config

#: the design's random streams: np.random.default_rng([seed, stream]) (the experiment's own rng is
#: default_rng(seed), untouched by the design)
DESIGN_STREAM, ERROR_STREAM = 32, 33
#: a parameter is *narrowed* on a recording when its exact width is below this fraction of its prior
#: width, and *narrowed for certain* by a trajectory when twice its design width is (then every
#: recording of the design rows whose errors are within the bound, with the truth in the prior box,
#: narrows it: :mod:`boundid.experiments.excitation_design`)
NARROWED = 0.99
#: the comparison's recordings: errors uniform within this fraction of the bound (zero errors give the
#: design set itself; errors that fill the bound cut the set far below what real data, whose bound is
#: chosen with a margin, leave)
ERROR_FRACTION = 0.5
#: the picks compared: the first candidate drawn (a random member of the family, undesigned; not the
#: study's own excitation, which the experiment draws from its own stream or takes from the paper) and
#: each criterion's best
PICKS = ("first draw", *CRITERIA)


@dataclass(frozen=True)
class Family:
    """The excitations an experiment can run: ``what`` in words, ``draw(rng)`` one of them and
    ``motion(excitation, rate_hz)`` its noise-free motion (t, q, qd, qdd) sampled at rate_hz."""

    what: str
    draw: Callable[[np.random.Generator], object]
    motion: Callable[[object, float], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]


def _fourier_motion(duration: float):
    def motion(traj, rate_hz: float):
        t = np.arange(0.0, duration, 1.0 / rate_hz)
        return (t, *traj.evaluate(t))
    return motion


def family(cfg: StudyConfig, model: RobotModel) -> Family:
    """The excitation family of the study's simulated experiment."""
    exp = cfg.experiment
    if exp.source != "simulate":
        raise StudyError(f"{cfg.file}: an excitation is designed, and the criteria compared, for a simulated "
                         "experiment (source = \"simulate\"); this study reads a recording (experiment.measured).")
    if exp.control == "open_loop":
        from boundid.experiments.simulation import simulate_open_loop

        ref = RampedMultisine.direct_drive_paper()

        def open_loop_motion(torque, rate_hz: float):
            run = simulate_open_loop(model, torque, exp.duration_s, exp.sample_period_s,
                                     coulomb_width=exp.coulomb_width_rad_s)
            step = max(1, int(round(1.0 / (rate_hz * exp.sample_period_s))))
            return run.t[::step], run.q[::step], run.qd[::step], run.qdd[::step]

        return Family("the paper's torque law (31)-(32): its ramps and peak torques, each joint's sine amplitude "
                      f"split at random, frequencies uniform in {0.1 * ref.max_frequency:g}-{ref.max_frequency:g} "
                      "rad/s, random phases; the motion simulated in open loop",
                      lambda rng: random_multisine(ref, rng), open_loop_motion)
    if exp.control == "tracking":
        from boundid.experiments.tracking import limited_fourier

        tcfg = replace(tracking_config(cfg), optimize_evals=0)
        return Family(f"rest-to-rest Fourier trajectories ({tcfg.harmonics} harmonics, period "
                      f"{min(tcfg.period_s, exp.duration_s):g} s) within the joint limits shrunk by "
                      f"{tcfg.margin:.0%} (positions, velocities, accelerations, torques of the truth)",
                      lambda rng: limited_fourier(model, rng, exp.duration_s, tcfg, {}, "identification"),
                      _fourier_motion(exp.duration_s))
    from boundid.experiments.trajectories import check_in_workspace, exciting_trajectory

    h4 = h4_config(cfg)

    def draw(rng):
        traj = exciting_trajectory(model, rng, duration=exp.duration_s, slow_fraction=h4.slow_fraction,
                                   fast_period=h4.fast_period)
        check_in_workspace(model, traj)
        return traj

    return Family(f"a slow Fourier segment ({h4.slow_fraction:.0%} of the run) then a fast one repeated every "
                  f"{h4.fast_period:g} s, scaled into the workspace", draw, _fourier_motion(exp.duration_s))


def joint_bounds(cfg: StudyConfig, n_joints: int) -> np.ndarray:
    """[exact] e_max per joint (n,)."""
    return np.broadcast_to(np.asarray(cfg.exact.e_max, dtype=float), (n_joints,)).copy()


def design_rows(model: RobotModel, fam: Family, excitation, rate_hz: float, e_joint: np.ndarray):
    """(t (N,), W (N n, p), joint (N n,), e (N n,)): the inverse-dynamic regressor of the excitation's
    noise-free motion at rate_hz, rows sample-major, and each row's bound (its joint's)."""
    t, q, qd, qdd = fam.motion(excitation, rate_hz)
    W = model.regressor(q, qd, qdd).reshape(-1, model.p)
    joint = np.tile(np.arange(model.n_joints), len(t))
    return t, W, joint, e_joint[joint]


@dataclass
class ExcitationDesign:
    """The search of one study: its ``criterion`` (whose pick the experiment runs), ``settings``,
    the ``family`` in words, the ``search`` (every candidate's scores) and its wall time ``time_s``."""

    criterion: str
    settings: ExcitationSearchConfig
    family: str
    search: ExcitationSearch
    time_s: float

    @property
    def chosen(self) -> int:
        """Index of the candidate the experiment runs."""
        return self.search.best(self.criterion)

    @property
    def excitation(self):
        """The chosen excitation (a torque law or a trajectory)."""
        return self.search.candidates[self.chosen]


def design_excitation(cfg: StudyConfig, model: RobotModel, criterion: str | None = None) -> ExcitationDesign:
    """Search the study's excitation family ([experiment.design]) and keep ``criterion``'s best
    (default: [experiment] excitation)."""
    criterion = criterion or cfg.experiment.excitation
    if criterion not in CRITERIA:
        raise StudyError(f"{cfg.file}: experiment.excitation = {criterion!r} designs nothing; choose among "
                         f"{', '.join(CRITERIA)}.")
    settings = cfg.experiment.design
    fam = family(cfg, model)
    e_joint = joint_bounds(cfg, model.n_joints)
    _, half = prior_box(model, cfg.prior)
    def rows(excitation):
        _, W, _, e = design_rows(model, fam, excitation, settings.rate_hz, e_joint)
        return W, e

    t0 = time.perf_counter()
    search = search_excitation(fam.draw, rows, settings.candidates, np.random.default_rng([cfg.seed, DESIGN_STREAM]),
                               half, errors=(InputError, UnreachablePoseError, SolverError))
    return ExcitationDesign(criterion, settings, fam.what, search, time.perf_counter() - t0)


@dataclass
class Pick:
    """One trajectory of the comparison: its ``label`` (a criterion, or "first draw"), candidate
    index, rows, and per parameter (p,) widths over the prior width: ``design`` (eq. (1) of
    :mod:`boundid.experiments.excitation_design` at the study's row rate), ``exact`` (LP bounds of
    the simulated recording), ``obe``, ``wls`` (the study's estimators on it; None if it has none
    or the run failed, ``failures`` says why); ``truth_inside``: the truth in the exact bounds."""

    label: str
    candidate: int
    rows: int
    design: np.ndarray
    exact: np.ndarray
    obe: np.ndarray | None
    wls: np.ndarray | None
    truth_inside: bool
    failures: dict[str, str]


@dataclass
class CriteriaComparison:
    """The picks of one study's search side by side (:func:`compare_criteria`)."""

    study: str
    title: str
    design: ExcitationDesign
    picks: list[Pick]
    names: tuple[str, ...]
    rate_hz: float
    bound: str
    obe_label: str | None
    wls_label: str | None
    time_s: float
    #: (p,) design widths over the prior widths of all the candidates' search rows stacked: inside each
    #: candidate's design set (more rows), so a parameter it leaves at the prior width no candidate
    #: narrows; for the rest-to-rest Fourier families also a real experiment (the candidates in turn)
    pooled: np.ndarray | None = None

    def summary(self) -> pd.DataFrame:
        """One row per pick: its criteria's values, the mean widths, how many parameters it narrows for
        certain (and on its recording) and those it does not narrow for certain."""
        sc = self.design.search.scores
        rows = []
        for pk in self.picks:
            rows.append({"trajectory": pk.label, "candidate": pk.candidate,
                         "cond(W)": sc.loc[pk.candidate, "cond"], "ln det": sc.loc[pk.candidate, "logdet"],
                         "design width (search)": sc.loc[pk.candidate, "guaranteed"],
                         "design width": float(pk.design.mean()), "exact width": float(pk.exact.mean()),
                         "OBE width": float(pk.obe.mean()) if pk.obe is not None else np.nan,
                         "WLS 95 % width": float(pk.wls.mean()) if pk.wls is not None else np.nan,
                         "narrowed for certain": int(np.sum(2 * pk.design < NARROWED)),
                         "narrowed on the recording": int(np.sum(pk.exact < NARROWED)),
                         "not narrowed for certain": ", ".join(n for n, w in zip(self.names, pk.design, strict=True)
                                                               if not 2 * w < NARROWED) or "none",
                         "truth in exact bounds": pk.truth_inside})
        return pd.DataFrame(rows).set_index("trajectory")

    def widths(self, kind: str) -> pd.DataFrame:
        """Per parameter (rows) and pick (columns): the ``kind`` ("design", "exact", "obe", "wls") widths."""
        return pd.DataFrame({pk.label: getattr(pk, kind) for pk in self.picks if getattr(pk, kind) is not None},
                            index=pd.Index(self.names, name="parameter"))

    def not_guaranteed(self) -> list[str]:
        """Parameters that all the candidates' search rows together (at rate_hz) leave at NARROWED of
        the prior width or more in their design set: data within the bound exist (zero errors, the
        truth at the prior's centre) whose exact interval is that wide, so no candidate tried
        guarantees to narrow them (each one's rows are among those rows: a larger design set). A
        recording with other errors may still narrow them. Without ``pooled``: those that no single
        candidate's design set narrows."""
        w = self.design.search.widths if self.pooled is None else self.pooled[None, :]
        return [n for n, j in zip(self.names, range(w.shape[1]), strict=True) if np.all(w[:, j] >= NARROWED)]


def _study_estimator(cfg: StudyConfig, method: str):
    """The study's first estimator of ``method`` (the factorized OBE first), or None."""
    ecs = [ec for ec in cfg.estimators if ec.method == method]
    if method == "obe":
        ecs.sort(key=lambda ec: getattr(ec.options, "form", "") != "factorized")
    return ecs[0] if ecs else None


def compare_criteria(cfg: StudyConfig, model: RobotModel, design: ExcitationDesign | None = None) -> CriteriaComparison:
    """Each criterion's pick of the study's search (and the first candidate drawn) at the study's row
    rate (1 / (sample period x decimation)), with errors uniform within ERROR_FRACTION of the bound
    (the same draw for every pick, seeded): the design, exact, OBE and WLS widths over the prior widths."""
    t_start = time.perf_counter()
    design = design or design_excitation(cfg, model, "guaranteed")
    fam = family(cfg, model)
    exp = cfg.experiment
    rate = 1.0 / (exp.sample_period_s * cfg.preprocessing.decimation)
    e_joint = joint_bounds(cfg, model.n_joints)
    center, half = prior_box(model, cfg.prior)
    box = (center - half, center + half)
    obe_ec, wls_ec = _study_estimator(cfg, "obe"), _study_estimator(cfg, "wls")
    theta = np.asarray(model.theta_true, dtype=float)
    picks, done = [], {}
    for label in PICKS:
        k = 0 if label == "first draw" else design.search.best(label)
        if k in done:
            picks.append(replace(done[k], label=label))
            continue
        t, W, joint, e = design_rows(model, fam, design.search.candidates[k], rate, e_joint)
        err = np.random.default_rng([cfg.seed, ERROR_STREAM]).uniform(-1.0, 1.0, len(e)) * (ERROR_FRACTION * e)
        y = W @ theta + err
        b = Polytope(W, y, e, box=box).bounds()
        failures, rel = {}, {}
        reg = Regression(W, y, joint, np.repeat(np.arange(len(t)), model.n_joints),
                         np.repeat(t, model.n_joints), "inverse_dynamic", model.param_names)
        for kind, ec in (("obe", obe_ec), ("wls", wls_ec)):
            rel[kind] = None
            if ec is None:
                continue
            try:
                est = run_estimator(replace(ec, e_max=e) if ec.e_max is not None else ec, reg, model, cfg.prior)
            except RUN_FAILURES as exc:
                failures[kind] = f"{type(exc).__name__}: {exc}"
                continue
            lo, hi = est.intervals
            rel[kind] = (np.asarray(hi) - np.asarray(lo)) / (2 * half)
        pk = Pick(label, k, W.shape[0], design_widths(W, e, half), (b.hi - b.lo) / (2 * half), rel["obe"],
                  rel["wls"], bool(np.all((b.lo <= theta) & (theta <= b.hi))), failures)
        done[k] = pk
        picks.append(pk)
    rows = [design_rows(model, fam, c, design.settings.rate_hz, e_joint) for c in design.search.candidates]
    pooled = design_widths(np.vstack([r[1] for r in rows]), np.concatenate([r[3] for r in rows]), half)
    e_text = ", ".join(f"{v:g}" for v in np.unique(e_joint))
    return CriteriaComparison(cfg.name, cfg.title, design, picks, tuple(model.param_names), rate,
                              f"{e_text} N m", obe_ec.label if obe_ec else None, wls_ec.label if wls_ec else None,
                              time.perf_counter() - t_start, pooled)
