"""Study files (TOML) parsed into validated, typed configuration.

A study names the robot, the experiment (simulated, or a measured-data file), the preprocessing,
the regression models, the estimators with their settings, the exact optima to compute, and the
seed. See ``studies/*.toml`` for commented examples.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import types
import typing
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from boundid.errors import InputError, StudyError
from boundid.estimators.method import Method
from boundid.estimators.protocol import SHAPE_LIMITS
from boundid.estimators.registry import METHODS
from boundid.experiments.measurement import TorqueNoise
from boundid.experiments.recording import ANGLE_UNITS, TIME_UNITS
from boundid.experiments.transmission import Transmission, TransmissionError
from boundid.models import RobotModel
from boundid.models import registry as robots
from boundid.studies import sizing
from boundid.studies.bounds import DEFAULT_RULE, SCALINGS, BoundRule
from boundid.studies.published import check_published, read_published
from boundid.studies.registry import experiment_options, make_robot
from boundid.studies.scenarios import read_campaign, read_torque_noise
from boundid.studies.schema import Section, range_text, read_toml

REGRESSIONS = ("inverse_dynamic", "filtered_dynamic", "supplied_energy", "filtered_power")
SDP_SETS = ("outer", "inner", "john")
# folders other commands write beside the study pages (boundid bench, boundid teach): a study may
# not take their name, or its report would replace them
RESERVED_NAMES = ("benchmarks", "teaching", "excitation")


@dataclass(frozen=True)
class MeasuredData:
    """A recording, CSV or Parquet with one row per sample (read by
    :func:`boundid.experiments.recording.read_recording`).

    file : the positions and torques, or the positions only when ``tau_file`` holds the torques
    time : the time column of ``file`` [``time_unit``], or None with ``sample_period_s`` [s]
    q, tau : one position column [``angle_unit``] and one torque column per joint (or motor):
        joint side [N m], or motor side converted by ``transmission``
    holdout_fraction : the share of the recording, at its end, kept out of identification: its
        torques are predicted by every estimate and the exact polytope (0: none)
    """

    file: Path
    time: str | None
    q: tuple[str, ...]
    tau: tuple[str, ...]
    tau_file: Path | None = None
    sample_period_s: float | None = None
    angle_unit: str = "rad"  # | "deg"
    time_unit: str = "s"  # | "ms"
    transmission: Transmission | None = None
    holdout_fraction: float = 0.0


#: [experiment] excitation: "default" keeps the experiment's own excitation (the paper's torques of the
#: open-loop experiment, a seeded random Fourier trajectory otherwise); the others design it
#: (:mod:`boundid.experiments.excitation_design`) by that criterion
EXCITATIONS = ("default", "guaranteed", "cond", "logdet")


@dataclass(frozen=True)
class ExcitationSearchConfig:
    """The ``[experiment.design]`` table: the excitation search's budget and settings.

    candidates : trajectories drawn (seeded by the study's seed) and scored by every criterion;
    rate_hz : Hz, the sample rate of each candidate's design regression (the search's rows);
    compare : whether ``boundid report`` writes this study's side-by-side of the three criteria
    (reports/excitation/) with exact, OBE and WLS widths of each criterion's pick.
    """

    candidates: int = 12
    rate_hz: float = 10.0
    compare: bool = False


@dataclass(frozen=True)
class ExperimentConfig:
    """The study's ``[experiment]`` table: where the data come from (``source``: "simulate" or
    "measured", the recording then in ``measured``), how a simulated experiment is run (``control``,
    duration, sample period, Coulomb smoothing width, torque noise, encoder resolution, structural
    error, the validation experiment's duration) and the robot's experiment ``options``. Every key
    is described in docs/study-files.md."""

    source: str  # "simulate" | "measured"
    control: str = "open_loop"  # "open_loop" (paper 001 torques) | "closed_loop" (H4 PI) | "tracking" (URDF arms)
    duration_s: float = 10.0
    sample_period_s: float = 0.0025
    coulomb_width_rad_s: float = 0.01
    torque_noise: TorqueNoise = TorqueNoise()
    encoder_counts_per_rev: int | None = None
    structural_error: float = 0.0
    validation_duration_s: float = 0.0
    options: dict = field(default_factory=dict)
    measured: MeasuredData | None = None
    excitation: str = "default"  # one of EXCITATIONS: "default" (the experiment's own) or a criterion
    design: ExcitationSearchConfig = ExcitationSearchConfig()


@dataclass(frozen=True)
class PreprocessingConfig:
    """How regressions are built from the recording.

    pairing : how the filtered/energy models pair each held torque u[k] with the state:
        "zoh_midpoint" (midpoint of the hold interval, velocity (q[k+1] - q[k]) / h) or "paper"
        (q[k] with the backward difference, as the direct-drive paper)
    lowpass_cutoff_hz : zero-phase Butterworth cut-off before the central differences that give
        qd and qdd for the inverse dynamic model (None: no filter)
    decimation : parallel filtering and decimation factor of the inverse dynamic rows
    min_speed_rad_s : rad/s, one threshold or a tuple of one per joint: drop the inverse-dynamic
        rows of a joint within the filters' reach of a sample where it moves slower than its
        threshold (there the model's sign(qd) is unreliable: at rest and at velocity reversals, and
        the zero-phase filters spread the error to the neighbouring rows); 0 keeps every row
    lambda_rad_s, discretisation : the filters lambda/(s + lambda), lambda s/(s + lambda)
    torque_timing : how the inverse dynamic rows time the recorded torque: "sample" (tau[k] is the
        torque at t_k, paired with the state at t_k) or "hold" (tau[k] was held over [t_k, t_{k+1}):
        the row at t_k takes (tau[k-1] + tau[k]) / 2,
        :func:`boundid.experiments.preprocessing.torque_at_samples`)
    """

    pairing: str = "zoh_midpoint"
    lowpass_cutoff_hz: float | None = None
    decimation: int = 1
    min_speed_rad_s: float | tuple[float, ...] = 0.0
    lambda_rad_s: float = 50.0
    discretisation: str = "tustin"  # | "paper"
    torque_timing: str = "sample"  # | "hold"


@dataclass(frozen=True)
class PriorConfig:
    """Prior knowledge: the box center +- half-width, shared by the OBE initial ellipsoid (which
    circumscribes it) and the exact polytope (which is intersected with it).

    center : "model" (the robot's a-priori values; unknown ones at 0) or "zero"
    relative_range : half-width as a fraction of |a-priori value| where one is known
    absolute_range : half-width where no a-priori value is known (or center = "zero"), in each
        parameter's unit
    """

    center: str = "zero"
    relative_range: float = 1.0
    absolute_range: float = 1000.0


def prior_box(model: RobotModel, prior: PriorConfig) -> tuple[np.ndarray, np.ndarray]:
    """The prior box (center, half_width), each (p,)."""
    known = np.isfinite(model.theta_prior) & (model.theta_prior != 0)
    if prior.center == "model":
        center = np.where(np.isfinite(model.theta_prior), model.theta_prior, 0.0)
        half = np.where(known, prior.relative_range * np.abs(center), prior.absolute_range)
    else:
        center = np.zeros(model.p)
        half = np.full(model.p, prior.absolute_range)
    return center, half


@dataclass(frozen=True)
class EstimatorConfig:
    """One [[estimators]] table: the registered method's name, the label, the regressions it runs on,
    its options (an instance of ``METHODS[method].options``) and the bound e_max of a method that
    needs one (None otherwise)."""

    method: str
    label: str
    regressions: tuple[str, ...]
    options: Any
    e_max: float | None = None
    bound_from_exact: bool = False  # no e_max of its own: the [exact] bound of its (exact) regression's rows


@dataclass(frozen=True)
class ExactConfig:
    """[exact]: the regression whose feasible polytope is bounded exactly, what to compute, and its
    bound: ``e_max`` a number (one bound on every row, in the regression's unit) or one per joint
    (each joint's rows), or ``e_max_rule``
    (a factor times gamma*, the smallest bound the data allow, :mod:`boundid.studies.bounds`)."""

    regression: str | None = None
    lp_bounds: bool = True
    sdp: tuple[str, ...] = ()
    projections: tuple[tuple[str, str], ...] = ()
    e_max: float | tuple[float, ...] | None = None  # one number, or one per joint
    volume_bracket: bool = True  # bracket the minimum-volume outer ellipsoid (needs sdp outer and inner)
    e_max_rule: BoundRule | None = None
    relaxed_q: int | None = None  # the q-relaxed bounds (at most q outliers) at the bound, when given

    @property
    def has_bound(self) -> bool:
        return self.e_max is not None or self.e_max_rule is not None


@dataclass(frozen=True)
class StudyConfig:
    """A study file, parsed and validated by :func:`load_study`: the study's name, title,
    description and seed, the robot and its options, the experiment, preprocessing, prior,
    regression models, estimators, the exact-optima settings (``[exact]``), the paper's metadata,
    the published tables and the file it was read from. Every key is described in
    docs/study-files.md."""

    name: str
    title: str
    description: str
    seed: int
    robot: str
    robot_options: dict
    experiment: ExperimentConfig
    preprocessing: PreprocessingConfig
    prior: PriorConfig
    regressions: tuple[str, ...]
    estimators: tuple[EstimatorConfig, ...]
    exact: ExactConfig
    paper: dict
    file: Path
    published: tuple = ()  # boundid.studies.published.PublishedTable, one per [[published]] table

    def with_seed(self, seed: int) -> StudyConfig:
        """The same study with another seed (an integer >= 0, as numpy's SeedSequence needs)."""
        if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
            raise InputError(f"the seed must be an integer >= 0, got {seed!r}.")
        return replace(self, seed=int(seed))


def _option_kind(hint) -> tuple[str, tuple]:
    """(kind, Literal choices) of an options field's type: "choice", "float", "int", "bool", "str"
    (an ``X | None`` is X with None allowed)."""
    args = tuple(a for a in typing.get_args(hint) if a is not type(None))
    if typing.get_origin(hint) is typing.Literal:
        return "choice", typing.get_args(hint)
    if args and typing.get_origin(hint) in (typing.Union, types.UnionType):
        return _option_kind(args[0])
    for kind, t in (("bool", bool), ("int", int), ("float", float), ("str", str)):
        if hint is t:
            return kind, ()
    raise TypeError(f"options field type {hint!r} is not one a study file can write")


def _describe(f: dataclasses.Field, hint) -> str:
    """One option for an error message: name, type, choices or range, default."""
    kind, choices = _option_kind(hint)
    m = f.metadata
    if kind == "choice":
        what = "one of " + ", ".join(map(repr, choices))
    else:
        allowed = range_text(m.get("lo"), m.get("hi"), m.get("strict_lo", False), m.get("strict_hi", False))
        what = {"float": "number", "int": "integer", "bool": "true or false", "str": "string"}[kind]
        what += f" {allowed}" if allowed else ""
    return f"{f.name} ({what}, {'optional' if f.default is None else f'default {f.default!r}'})"


def option_help(method: Method) -> str:
    """What an [[estimators]] table of ``method`` may hold, from its options dataclass."""
    hints = typing.get_type_hints(method.options)
    parts = [_describe(f, hints[f.name]) for f in dataclasses.fields(method.options)]
    keys = "method, label, regressions" + (", e_max (number > 0; on the [exact] regression alone, [exact]'s "
                                           "bound if left out)" if method.needs_bound else "")
    return (f"the {method.name} estimator takes {keys}"
            + (f" and the options {', '.join(parts)}" if parts else " and no options"))


def read_options(sec: Section, method: Method):
    """The ``method.options`` dataclass read from an [[estimators]] table: each field's type gives
    the value's type (Literal: the allowed strings), its metadata the range
    (:func:`boundid.estimators.method.option`); a number must be finite and in that range; a former
    name is refused naming the new one."""
    hints = typing.get_type_hints(method.options)
    values = {}
    for f in dataclasses.fields(method.options):
        for old in f.metadata.get("renamed_from", ()):
            if sec.has(old):
                raise sec.error(old, f"was renamed {f.name!r} (the estimator protocol's prior vocabulary: center0, "
                                     f"shape0); write {f.name} = {sec.data[old]!r}.")
        if not sec.has(f.name):
            continue
        kind, choices = _option_kind(hints[f.name])
        m = f.metadata
        if kind == "choice":
            values[f.name] = sec.str(f.name, choices=choices)
        elif kind == "float":
            values[f.name] = sec.float(f.name, lo=m.get("lo"), hi=m.get("hi"), strict_lo=m.get("strict_lo", False),
                                       strict_hi=m.get("strict_hi", False))
        elif kind == "int":
            values[f.name] = sec.int(f.name, lo=m.get("lo"), hi=m.get("hi"))
        elif kind == "bool":
            values[f.name] = sec.bool(f.name)
        else:
            values[f.name] = sec.str(f.name)
    return method.options(**values)


def _estimator(sec: Section, regressions: tuple[str, ...]) -> EstimatorConfig:
    name = sec.str("method", choices=tuple(METHODS))
    method = METHODS[name]
    regs = tuple(sec.list("regressions", choices=regressions))
    if not regs:
        raise sec.error("regressions", "names no regression model.")
    label = sec.str("label", default=name.upper())
    options = read_options(sec, method)
    e_max = sec.float("e_max", None, lo=0.0, strict_lo=True) if method.needs_bound else None
    sec.check_unknown(option_help(method))
    return EstimatorConfig(name, label, regs, options, e_max)


def _exact_bound(ex: Section) -> tuple[float | None, BoundRule | None]:
    """[exact] e_max, a number, or e_max_rule, a table { factor = ..., scaling = ... } (both keys
    optional: :data:`boundid.studies.bounds.DEFAULT_RULE`); load_study refuses both at once."""
    if isinstance(ex.data.get("e_max"), dict):
        raise ex.error("e_max", "is one number for every row, or a list of one per joint; a rule (a factor times "
                                "gamma*) is written e_max_rule = { factor = 2.0, scaling = \"one\" }.")
    if isinstance(ex.data.get("e_max"), list):
        e_max = tuple(float(v) for v in ex.list("e_max", of=(int, float)))
        if not e_max or not all(math.isfinite(v) and v > 0 for v in e_max):
            raise ex.error("e_max", f"must list one finite number > 0 per joint, got {list(e_max)}.")
    else:
        e_max = ex.float("e_max", None, lo=0.0, strict_lo=True)
    given = ex.has("e_max_rule")
    rule = ex.section("e_max_rule")
    factor = rule.float("factor", DEFAULT_RULE.factor, lo=1.0)
    scaling = rule.str("scaling", DEFAULT_RULE.scaling, choices=SCALINGS)
    rule.check_unknown("a bound rule takes factor (number >= 1: e_max = factor x gamma*) and scaling "
                       f"({', '.join(map(repr, SCALINGS))})")
    return e_max, BoundRule(factor, scaling) if given else None


def _bind_estimators(ex: Section, exact: ExactConfig, estimators: list[EstimatorConfig],
                     sections: list[Section]) -> list[EstimatorConfig]:
    """Every estimator that needs a bound has one: its own e_max, or, run on the exact regression
    alone, [exact]'s (the same number, or the same per-row bounds of its rule)."""
    out = []
    for e, sec in zip(estimators, sections, strict=True):
        if METHODS[e.method].needs_bound and e.e_max is None:
            if not (exact.has_bound and e.regressions == (exact.regression,)):
                raise sec.error("e_max", f"is required for a {e.method} estimator: the bound on |y - w^T theta| in "
                                         "the regression's unit (N m for the dynamic models, J for the energy model); "
                                         "or run it on the [exact] regression alone, whose e_max it then takes.")
            e = replace(e, e_max=exact.e_max, bound_from_exact=True)
        elif METHODS[e.method].needs_bound and exact.regression in e.regressions:
            if exact.e_max_rule is not None:
                raise ex.error("e_max_rule", f"is given, but estimator {e.label!r} bounds the same "
                                             f"{exact.regression} rows by e_max = {e.e_max}: remove its e_max to take "
                                             "the rule's bounds.")
            if e.e_max != exact.e_max:
                raise ex.error("e_max", f"is {exact.e_max} but estimator {e.label!r} bounds the same "
                                        f"{exact.regression} rows by e_max = {e.e_max}: a set is certified against "
                                        "the polytope of its own bound, so the two must be equal.")
        out.append(e)
    return out


def _transmission(tr: Section, n: int) -> Transmission:
    """[experiment.measured.transmission] of a motor-side recording with n position columns
    (checked by :class:`boundid.experiments.transmission.Transmission`)."""
    ratios = tr.list("gear_ratios", of=(int, float))
    coupling = tr.list("coupling", [], of=list)
    offsets = tr.list("joint_offsets_rad", [], of=(int, float))
    gains = tr.list("torque_gains", [], of=(int, float))
    tr.check_unknown()
    if len(ratios) != n:
        raise tr.error("gear_ratios", f"has {len(ratios)} number(s), columns.q names {n} joints: give one ratio "
                                      "(motor turns per joint turn) per joint.")
    try:
        return Transmission(tuple(ratios), tuple(tuple(e) for e in coupling), tuple(offsets) or None,
                            tuple(gains) or None)
    except TransmissionError as exc:
        raise tr.error(exc.key, exc.reason) from None


def _experiment(sec: Section, base: Path) -> ExperimentConfig:
    source = sec.str("source", choices=("simulate", "measured"))
    if source == "measured":
        m = sec.section("measured", required=True)
        period = m.float("sample_period_s", None, lo=0.0, strict_lo=True)  # first: a NaN is named before all else
        holdout = m.float("holdout_fraction", 0.0, lo=0.0, hi=0.5)
        file, tau_file = m.str("file"), m.str("tau_file", None)
        angle_unit = m.str("angle_unit", "rad", choices=tuple(ANGLE_UNITS))
        time_unit = m.str("time_unit", "s", choices=tuple(TIME_UNITS))
        cols = m.section("columns", required=True)
        time, q, tau = cols.str("time", None), tuple(cols.list("q")), tuple(cols.list("tau"))
        cols.check_unknown()
        transmission = _transmission(m.section("transmission"), len(q)) if m.has("transmission") else None
        m.check_unknown()
        if not q:
            raise cols.error("q", "names no column: give one position column per joint.")
        if len(q) != len(tau):
            raise cols.error("tau", f"names {len(tau)} columns but q names {len(q)}.")
        if time is not None and period is not None:
            raise m.error("sample_period_s", "is given with a time column (columns.time); keep one: "
                                             "sample_period_s is for a recording without a time column.")
        if time is None and period is None:
            raise cols.error("time", "is required unless experiment.measured.sample_period_s gives the sample "
                                     "period [s] of a recording without a time column.")
        measured = MeasuredData(file=(base / file).resolve(), time=time, q=q, tau=tau,
                                tau_file=None if tau_file is None else (base / tau_file).resolve(),
                                sample_period_s=period, angle_unit=angle_unit, time_unit=time_unit,
                                transmission=transmission, holdout_fraction=holdout)
        for key in ("excitation", "design"):
            if key in sec.data:          # (not sec.has: the key documentation's probe would read it as a key here)
                raise sec.error(key, "designs the excitation of a simulated experiment; this study reads a recording "
                                     "(experiment.measured): remove it, or simulate (source = \"simulate\").")
        sec.check_unknown()
        return ExperimentConfig(source="measured", measured=measured)
    noise = sec.section("noise")
    torque_noise = read_torque_noise(noise.section("torque"))
    counts = noise.int("encoder_counts_per_rev", None, lo=2)
    noise.check_unknown()
    exp = ExperimentConfig(
        source="simulate",
        control=sec.str("control", "open_loop", choices=("open_loop", "closed_loop", "tracking")),
        duration_s=sec.float("duration_s", 10.0, lo=0.0, strict_lo=True),
        sample_period_s=sec.float("sample_period_s", 0.0025, lo=0.0, strict_lo=True),
        coulomb_width_rad_s=sec.float("coulomb_width_rad_s", 0.01, lo=0.0),
        torque_noise=torque_noise,
        encoder_counts_per_rev=counts,
        structural_error=sec.float("structural_error", 0.0, lo=0.0),
        validation_duration_s=sec.float("validation_duration_s", 0.0, lo=0.0),
        excitation=sec.str("excitation", "default", choices=EXCITATIONS),
        design=_design(sec.section("design")),
    )
    known = experiment_options(exp.control)
    exp = replace(exp, options=sec.options("options", known, f"the {exp.control.replace('_', '-')} experiment"))
    sec.check_unknown()
    return exp


def _design(sec: Section) -> ExcitationSearchConfig:
    """[experiment.design]: the excitation search's settings."""
    out = ExcitationSearchConfig(candidates=sec.int("candidates", 12, lo=1, hi=10_000),
                                 rate_hz=sec.float("rate_hz", 10.0, lo=0.0, strict_lo=True),
                                 compare=sec.bool("compare", False))
    sec.check_unknown()
    return out


def check_design(exp: ExperimentConfig, model, path: Path) -> None:
    """Refuse a design rate the experiment cannot give (above its sample rate, or not a whole divisor
    of it for the open-loop experiment, whose motion is simulated at its samples) and a search over
    the resource budget (every candidate's rows)."""
    rate, fs = exp.design.rate_hz, 1.0 / exp.sample_period_s
    if rate > fs * (1 + 1e-9):
        raise StudyError(f"{path}: experiment.design.rate_hz = {rate:g} Hz is above the experiment's sample rate "
                         f"{fs:g} Hz; choose at most that (10 Hz scores a trajectory well).")
    step = fs / rate
    if exp.control == "open_loop" and abs(step - round(step)) > 1e-9 * step:
        raise StudyError(f"{path}: experiment.design.rate_hz = {rate:g} Hz does not divide the open-loop "
                         f"experiment's sample rate {fs:g} Hz (its motion is simulated at those samples); choose "
                         f"{fs:g} / k Hz, e.g. {fs / max(1, round(step)):g} Hz.")
    samples = round(exp.duration_s * rate) * exp.design.candidates
    sizing.check_budget(samples, model.n_joints, model.p, 1, f"{path}: experiment.design (rows of every candidate)")


def _check_size(cfg: StudyConfig, model) -> None:
    """Refuse up front an experiment too short for its regression models or over the resource budget."""
    exp, pp = cfg.experiment, cfg.preprocessing
    if exp.source != "simulate":
        return  # a recording is checked when it is read (boundid.studies.data)
    h, where = exp.sample_period_s, f"{cfg.file}: experiment"
    closed = exp.control in ("closed_loop", "tracking")
    if "inverse_dynamic" in cfg.regressions or closed:
        sizing.check_cutoff(h, pp.lowpass_cutoff_hz, pp.decimation, f"{cfg.file}: preprocessing.lowpass_cutoff_hz")
    sizing.check_length(exp.duration_s, h, model.n_joints, model.p, cfg.regressions, pp.lowpass_cutoff_hz,
                        pp.decimation, f"{where}.duration_s")
    duration = exp.duration_s
    if closed and exp.validation_duration_s > 0:  # the cross-validation trajectory
        sizing.check_length(exp.validation_duration_s, h, model.n_joints, model.p, ("inverse_dynamic",),
                            pp.lowpass_cutoff_hz, pp.decimation, f"{where}.validation_duration_s")
        duration += exp.validation_duration_s
    sizing.check_budget(round(duration / h) + 1, model.n_joints, model.p, len(cfg.regressions), where)


def _check_prior(cfg: StudyConfig, model) -> None:
    """Refuse a prior box the estimators cannot start from: a half-width whose circumscribing
    ellipsoid (squared semi-axes p h^2, :func:`boundid.estimators.protocol.ellipsoid_prior`) leaves
    :data:`~boundid.estimators.protocol.SHAPE_LIMITS`, or, on simulated data, a box that excludes
    the robot's true parameters (every guaranteed set starts inside it, so none could hold them)."""
    pr = cfg.prior
    ranges = (f"prior.absolute_range (now {pr.absolute_range:g})" if pr.center == "zero" else
              f"prior.relative_range (now {pr.relative_range:g}; parameters with an a-priori value) or "
              f"prior.absolute_range (now {pr.absolute_range:g}; the others)")
    center_key = f"prior.center (now {pr.center!r})"
    center, half = prior_box(model, pr)
    lo, hi = (np.sqrt(limit / model.p) for limit in SHAPE_LIMITS)

    def listing(bad: np.ndarray, what) -> str:
        items = [f"{model.param_names[j]} {what(j)}" for j in bad[:4]]
        return ", ".join(items) + (f" and {len(bad) - 4} more" if len(bad) > 4 else "")

    bad = np.flatnonzero((half < lo) | (half > hi))
    if bad.size:
        raise StudyError(f"{cfg.file}: [prior]: the prior box's half-widths must lie between {lo:.3g} and {hi:.3g} "
                         "(the estimators' ellipsoid through its corners must stay within floating point); "
                         f"{listing(bad, lambda j: f'has {half[j]:.3g} {model.param_units[j]}')}; change {ranges}, or "
                         f"{center_key}.")
    if cfg.experiment.source != "simulate":
        return  # the truth of a recording is unknown
    bad = np.flatnonzero(np.abs(model.theta_true - center) > half)
    if bad.size:
        raise StudyError(
            f"{cfg.file}: [prior]: the prior box excludes the true parameters of the simulated robot ("
            + listing(bad, lambda j: f"= {model.theta_true[j]:.4g} {model.param_units[j]} outside "
                                     f"[{center[j] - half[j]:.4g}, {center[j] + half[j]:.4g}]")
            + f"), so no guaranteed set, which starts inside the box, could hold them; widen the box: raise {ranges}, "
              f"or change {center_key}.")


def _min_speed(pp: Section, n: int) -> float | tuple[float, ...]:
    """preprocessing.min_speed_rad_s: one threshold [rad/s] for every joint, or a list of n (one per joint)."""
    key = "min_speed_rad_s"
    if not isinstance(pp.data.get(key), list):
        return pp.float(key, 0.0, lo=0.0)
    values = pp.list(key, of=(int, float))
    if len(values) != n or not all(math.isfinite(v) and v >= 0 for v in values):
        raise pp.error(key, f"must be one number >= 0 or a list of {n} numbers >= 0 (one per joint of the robot, "
                            f"rad/s), got {values!r}.")
    return tuple(float(v) for v in values)


def load_study(path: str | Path) -> StudyConfig:
    """Parse and validate a study file; raises :class:`StudyError` naming the file and key."""
    path = Path(path)
    if not path.is_file():
        raise StudyError(f"{path}: no such study file (studies live in studies/*.toml).")
    top = Section(read_toml(path), "", path)
    st = top.section("study", required=True)
    name = st.plain_name("name")
    if name.casefold() in RESERVED_NAMES:
        raise st.error("name", f"{name!r} is the folder of another command's reports "
                               f"({', '.join(RESERVED_NAMES)}); choose another name.")
    rb = top.section("robot", required=True)
    robot = rb.str("model", choices=tuple(robots.ROBOTS))
    robot_options = rb.options("options", robots.robot_options(robot), f"robot {robot!r}")
    rb.check_unknown()
    source = robot_options.get("source") if robot == "urdf" else None
    if isinstance(source, str) and not Path(source).expanduser().is_absolute() and (path.parent / source).is_file():
        robot_options = robot_options | {"source": str((path.parent / source).resolve())}  # a URDF next to the study
    model = make_robot(robot, robot_options)  # the model checks the option values
    experiment = _experiment(top.section("experiment", required=True), path.parent)
    pp = top.section("preprocessing")
    preprocessing = PreprocessingConfig(
        pairing=pp.str("pairing", "zoh_midpoint", choices=("zoh_midpoint", "paper")),
        lowpass_cutoff_hz=pp.float("lowpass_cutoff_hz", None, lo=0.0, strict_lo=True),
        decimation=pp.int("decimation", 1, lo=1),
        min_speed_rad_s=_min_speed(pp, model.n_joints),
        lambda_rad_s=pp.float("lambda_rad_s", 50.0, lo=0.0, strict_lo=True),
        discretisation=pp.str("discretisation", "tustin", choices=("tustin", "paper")),
        torque_timing=pp.str("torque_timing", "sample", choices=("sample", "hold")),
    )
    pp.check_unknown()
    pr = top.section("prior")
    prior = PriorConfig(
        center=pr.str("center", "zero", choices=("model", "zero")),
        relative_range=pr.float("relative_range", 1.0, lo=0.0, strict_lo=True),
        absolute_range=pr.float("absolute_range", 1000.0, lo=0.0, strict_lo=True),
    )
    pr.check_unknown()
    regressions = tuple(top.list("regressions", choices=REGRESSIONS))
    if not regressions:
        raise top.error("regressions", f"names no regression model; choose among {', '.join(REGRESSIONS)}.")
    estimator_sections = top.sections("estimators")
    estimators = tuple(_estimator(s, regressions) for s in estimator_sections)
    if not estimators:
        raise top.error("estimators", "no [[estimators]] table: a study needs at least one estimator.")
    labels = [e.label for e in estimators]
    if len(set(labels)) != len(labels):
        raise top.error("estimators", f"labels must be unique, got {labels}; set `label` on each.")
    ex = top.section("exact")
    e_max, rule = _exact_bound(ex)
    exact = ExactConfig(
        regression=ex.str("regression", None, choices=regressions),
        lp_bounds=ex.bool("lp_bounds", True),
        sdp=tuple(ex.list("sdp", [], choices=SDP_SETS)),
        projections=tuple(tuple(pair) for pair in ex.list("projections", [], of=list)),
        e_max=e_max,
        volume_bracket=ex.bool("volume_bracket", True),
        e_max_rule=rule,
        relaxed_q=ex.int("relaxed_q", None, lo=0),
    )
    for pair in exact.projections:
        if len(pair) != 2 or not all(isinstance(x, str) for x in pair):
            raise ex.error("projections", f"each entry must be a pair of parameter names, got {pair!r}.")
        unknown = [x for x in pair if x not in model.param_names]
        if unknown:
            raise ex.error("projections", f"{unknown[0]!r} is not a parameter of the {robot} model; its parameters "
                                          f"are {', '.join(model.param_names)}.")
        if pair[0] == pair[1]:
            raise ex.error("projections", f"{pair!r} names one parameter twice; a projection needs two.")
    if exact.regression is not None and not exact.has_bound:
        raise ex.error("e_max", "is required with `regression`: the exact polytope needs the error bound, a number "
                                "(N m), or give e_max_rule = { factor = 2.0, scaling = \"one\" } (a factor times "
                                "gamma*, the smallest bound the data allow).")
    if exact.regression is None and exact.e_max_rule is not None:
        raise ex.error("e_max_rule", "needs `regression`: gamma* is computed on the exact regression.")
    designs = experiment.excitation != "default" or experiment.design.compare
    if designs and (exact.e_max is None):
        raise StudyError(f"{path}: experiment.excitation = {experiment.excitation!r} (or experiment.design.compare) "
                         "scores trajectories at the bound before any data exist: give [exact] e_max as a number "
                         "(or one per joint), not e_max_rule.")
    if designs:
        check_design(experiment, model, path)
    ex.check_unknown()
    cfg = StudyConfig(
        name=name,
        title=st.str("title"),
        description=st.str("description", ""),
        seed=st.int("seed", 0, lo=0),
        robot=robot,
        robot_options=robot_options,
        experiment=experiment,
        preprocessing=preprocessing,
        prior=prior,
        regressions=regressions,
        estimators=estimators,
        exact=exact,
        paper=dict(top.raw("paper", {})),
        file=path,
        published=read_published(top, path.parent),
    )
    if top.has("campaign"):  # boundid campaign's schema, refused here as there
        read_campaign(top.section("campaign"), labels)
    st.check_unknown()
    top.check_unknown()
    if exact.e_max is not None and exact.e_max_rule is not None:  # last: boundid.docs reads every key first
        raise ex.error("e_max_rule", "and e_max are both given: keep one, the number or the rule.")
    cfg = replace(cfg, estimators=tuple(_bind_estimators(ex, exact, list(estimators), estimator_sections)))
    if experiment.measured is not None and experiment.measured.holdout_fraction > 0 \
            and "inverse_dynamic" not in regressions:
        raise StudyError(f"{path}: experiment.measured.holdout_fraction: the held-out torques are predicted by the "
                         "inverse_dynamic rows' estimates; add \"inverse_dynamic\" to regressions (with an estimator "
                         "on it), or remove holdout_fraction.")
    if isinstance(exact.e_max, tuple) and len(exact.e_max) != model.n_joints:
        raise ex.error("e_max", f"lists {len(exact.e_max)} bounds but the {robot} model has {model.n_joints} joints: "
                                "give one per joint, in the model's joint order, or one number for every row.")
    _check_size(cfg, model)
    _check_prior(cfg, model)
    check_published(cfg.published, model, path)
    return cfg
