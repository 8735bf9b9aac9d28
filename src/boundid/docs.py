"""``python -m boundid.docs``: write ``docs/study-files.md``, every study-file key, from the parser.

The study-file parser (:func:`boundid.studies.config.load_study` and
:func:`boundid.studies.scenarios.load_campaign`) *is* the schema: it reads every key through a
:class:`boundid.studies.schema.Section` typed look-up (``str`` with its choices, ``float`` with its
range, ``options`` with a table of defaults ...). :func:`study_keys` runs that parser on a probe
Section that answers every look-up with a valid value and records it (key, type, default,
choices, range, required), once for each choice of every key that has choices, so that keys read
only under one choice (``[experiment.measured]`` when ``source = "measured"``, an estimator's
options under its ``method``) are found with that condition. Nothing else about the schema is
written here: a new key appears in the document by itself, and needs only its sentence in
:data:`DESCRIPTIONS` (the generator refuses a key without one, and a sentence for a key that
is gone). ``tests/test_docs.py`` fails when the committed file differs from the generated one.
"""

from __future__ import annotations

import argparse
import builtins
import dataclasses
import re
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from boundid.estimators.registry import METHODS
from boundid.studies import schema
from boundid.studies.schema import Section, describe_option, range_text

#: former option names the parser refuses, naming the new one (an options field's ``renamed_from``)
RENAMED = frozenset(old for m in METHODS.values() for f in dataclasses.fields(m.options)
                    for old in f.metadata.get("renamed_from", ()))

MISSING = object()  # the probe's "no default given": the parser calls the look-up without one (required)

#: one sentence per key (dotted path; "[]" marks an array of tables) and per table
DESCRIPTIONS = {
    "regressions": "The regression models built from the data; each estimator picks among them.",
    "study": "What the study is called and how its page introduces it.",
    "study.name": "A plain name (letters, digits, _ and -): the report folder <out>/<name>/.",
    "study.title": "The title of the study's page.",
    "study.description": "The set-up in words, the first paragraphs of the page and its entry in the index.",
    "study.seed": "The root of every random draw (noise, replicates): same seed, same numbers.",
    "robot": "The robot model.",
    "robot.model": "Which model (`boundid list` shows each with its parameters).",
    "robot.options": "The model's own settings (its true physical values or geometry); each option's "
                     "default is listed below. With model = \"urdf\": `viscous` [N m s/rad], `coulomb` [N m], "
                     "`armature` [kg m^2] and `offset` [N m] take one number for every joint or a list of one "
                     "per joint (a list is used as given; the number 0, the default, means not given: the "
                     "URDF's friction, no Ia_j or off_j parameters); `coupled_motors` lists the motors that "
                     "turn with several joints, each a table {motor, joints, ratios, armature, viscous, "
                     "coulomb}: its row of the transmission (q_m = sum ratios x q over joints, 1-based), its "
                     "rotor inertia Iam, viscous fvm and Coulomb fsm friction scaled to its own joint "
                     "(N^2 J, N^2 b, |N| c with N its own ratio; >= 0), adding the parameters Iam<m>, "
                     "fvm<m>, fsm<m>. The Staubli TX40's wrist: coupled_motors = [{motor = 6, joints = [5, "
                     "6], ratios = [32, 32], armature = 9.64e-3, viscous = 0.616, coulomb = 1.95}].",
    "experiment": "Where the data come from: a simulation of the robot, or a recording.",
    "experiment.source": "\"simulate\" runs the robot model; \"measured\" reads the recording named in "
                         "[experiment.measured].",
    "experiment.measured": "The recording: CSV or Parquet, one row per sample; one file, or the positions and the "
                           "torques in two; joint side, or motor side with a [experiment.measured.transmission]. "
                           "Implausible units are refused naming the likely mistake (a sample period over 0.1 s, a "
                           "joint spanning over 100 rad, a column that never changes).",
    "experiment.measured.file": "Path of the recording, relative to the study file: every column, or the positions "
                                "(and the time column) when tau_file holds the torques.",
    "experiment.measured.tau_file": "Path of a second file holding the torque columns, relative to the study file; "
                                    "same row count as file, row k the same sample. Absent: the torques are in file.",
    "experiment.measured.sample_period_s": "Sample period [s] of a recording without a time column (row k at k "
                                           "times it); exclusive with columns.time.",
    "experiment.measured.angle_unit": "Unit of the position columns (motor side with a transmission).",
    "experiment.measured.time_unit": "Unit of the time column (sample_period_s is always in s).",
    "experiment.measured.columns": "The recording's column names.",
    "experiment.measured.columns.time": "Time [time_unit], uniformly spaced (relative jitter below 1e-3): the "
                                        "filters and differences assume one sample period. Absent: sample_period_s "
                                        "gives it.",
    "experiment.measured.columns.q": "Positions [angle_unit], one column per joint (per motor with a transmission), "
                                     "in the model's joint order.",
    "experiment.measured.columns.tau": "Torques, as many columns as q: joint torques [N m], or with a transmission the "
                                       "motors' logged signal (tau_m = torque_gains x signal).",
    "experiment.measured.transmission": "Motor-side recording: q = R^-1 q_m + joint_offsets_rad, tau = R^T "
                                        "(torque_gains x signal), with R = diag(gear_ratios) plus the coupling terms "
                                        "(q_m = R q; virtual work gives tau). Absent: the columns are joint side.",
    "experiment.measured.transmission.gear_ratios": "One per joint, motor turns per joint turn, sign allowed (the "
                                                    "diagonal of R).",
    "experiment.measured.transmission.coupling": "Entries [motor, joint, ratio] (1-based, motor != joint): "
                                                 "R[motor, joint] = ratio, a motor that also turns with another joint "
                                                 "(a coupled wrist: [6, 5, 32] for a TX40's motor 6 turning with q5 + "
                                                 "q6). Absent: none.",
    "experiment.measured.transmission.joint_offsets_rad": "Joint-side offsets [rad], one per joint, added after the "
                                                          "conversion (a motor-side encoder offset c is -R^-1 c "
                                                          "here). Absent: 0.",
    "experiment.measured.transmission.torque_gains": "Motor torque per unit of the logged signal (e.g. N m/A), one "
                                                     "per motor, non-zero. Absent: 1 (the log holds motor torques "
                                                     "in N m).",
    "experiment.control": "\"open_loop\": the direct-drive paper's torques (31)-(32); \"closed_loop\": PI "
                          "control along a Fourier-series trajectory (the H4 experiment); \"tracking\": a "
                          "Fourier trajectory within the joint limits tracked by computed torque + PID (URDF arms).",
    "experiment.duration_s": "Length of the identification experiment [s].",
    "experiment.sample_period_s": "Sample period h of the recording [s].",
    "experiment.coulomb_width_rad_s": "Simulation only: tanh(qd / width) stands for sign(qd) [rad/s].",
    "experiment.structural_error": "Scale of the robot behaviour the identification model leaves out "
                                   "(H4 closed loop; 0: none, 1: the simulated robot as built).",
    "experiment.validation_duration_s": "Length of a second, different trajectory for cross-validation [s] "
                                        "(closed loop and tracking; 0: none).",
    "experiment.options": "Settings of the closed-loop experiment; each option's default is listed below.",
    "experiment.excitation": "The identification run's excitation: \"default\" the experiment's own (the paper's "
                             "torques in open loop, a seeded random Fourier trajectory otherwise), or designed before "
                             "the experiment by a criterion: \"guaranteed\" (the smallest exact design set at [exact] "
                             "e_max), \"cond\" (the smallest condition number of W), \"logdet\" (the largest "
                             "ln det W^T W); see experiment.design.",
    "experiment.design": "The excitation search (experiment.excitation, and the page of the three criteria side by "
                         "side, reports/excitation/).",
    "experiment.design.candidates": "Excitations drawn from the experiment's own family (seeded by the study's seed) "
                                    "and scored by every criterion: the search budget.",
    "experiment.design.rate_hz": "Sample rate of each candidate's design regression (its noise-free motion) [Hz].",
    "experiment.design.compare": "true: `boundid report` records each criterion's pick and writes the criteria side "
                                 "by side (exact, OBE and WLS widths) in reports/excitation/.",
    "experiment.noise": "What the measurement adds.",
    "experiment.noise.encoder_counts_per_rev": "Encoder resolution (e.g. 65536 for 16 bits); absent: exact angles.",
    "experiment.noise.torque": "Additive torque noise.",
    "experiment.noise.torque.kind": "Its distribution.",
    "experiment.noise.torque.level": "Standard deviation (gaussian) or half-width (uniform, bounded_outliers) [N m].",
    "experiment.noise.torque.outlier_rate": "bounded_outliers: share of samples that get an outlier.",
    "experiment.noise.torque.outlier_size": "bounded_outliers: size of an outlier [N m].",
    "preprocessing": "How the regression rows are built from the recording.",
    "preprocessing.pairing": "How the filtered and energy models pair each held torque with the state: "
                             "\"zoh_midpoint\" (midpoint of the hold interval) or \"paper\" (as the direct-drive "
                             "paper, backward difference).",
    "preprocessing.lowpass_cutoff_hz": "Zero-phase Butterworth cut-off before the central differences of the "
                                       "inverse dynamic model [Hz]; absent: no filter.",
    "preprocessing.decimation": "Parallel filtering and decimation factor of the inverse dynamic rows.",
    "preprocessing.min_speed_rad_s": "Drop the inverse-dynamic rows of a joint within the filters' reach of a "
                                     "sample where it is slower than this [rad/s] (sign(qd) is unreliable at rest, "
                                     "and the filters spread the error); one number, or a list of one per joint; "
                                     "0 keeps every row.",
    "preprocessing.lambda_rad_s": "Pole of the filters lambda/(s + lambda), lambda s/(s + lambda) [rad/s].",
    "preprocessing.discretisation": "Discretisation of those filters.",
    "preprocessing.torque_timing": "When each recorded torque acted, for the inverse dynamic rows: \"sample\" "
                                   "(tau[k] is the torque at the sample instant t_k, paired with the state at t_k: a "
                                   "torque measured at the sample) or \"hold\" (tau[k] was held over [t_k, t_k+1), as "
                                   "a simulator or a drive that applies each command until the next sample: the row "
                                   "at t_k takes (tau[k-1] + tau[k]) / 2, the torque at t_k, before the low-pass and "
                                   "decimation). With \"sample\", a held torque is half a sample late, an error of "
                                   "about (h/2) dtau/dt that grows with the trajectory's speed.",
    "prior": "Prior knowledge: a box, the OBE's initial set (circumscribed) and a bound of the exact polytope. "
             "On simulated data it must hold the robot's true parameters (a study that excludes them is refused).",
    "prior.center": "\"model\": the robot's a-priori values (unknown ones at 0); \"zero\": the origin.",
    "prior.relative_range": "Half-width as a fraction of |a-priori value| where one is known.",
    "prior.absolute_range": "Half-width where no a-priori value is known, in each parameter's unit.",
    "estimators[]": "One table per estimator ([[estimators]]); at least one.",
    "estimators[].method": "The estimator.",
    "estimators[].label": "Its name on the page (unique; default: the method in capitals).",
    "estimators[].regressions": "The regression models it runs on, among the study's `regressions`.",
    "estimators[].form": "OBE form: \"factorized\" (square root, the H4 paper's) or \"standard\".",
    "estimators[].criterion": "OBE update criterion.",
    "estimators[].e_max": "Needed by the set-membership methods: the bound on |y - w^T theta| in the regression's "
                          "unit (N m, or J for supplied energy); left out, an estimator run on the [exact] "
                          "regression alone takes [exact] e_max or e_max_rule.",
    "estimators[].forgetting": "RLS forgetting factor (1: none).",
    "estimators[].level": "Confidence level of the statistical set.",
    "estimators[].R": "Kalman measurement noise variance.",
    "estimators[].Q": "Kalman process noise variance (0: constant parameters).",
    "exact": "The exact optima, computed on one regression's rows.",
    "exact.regression": "The regression whose feasible polytope is solved; absent: no exact optima.",
    "exact.e_max": "The error bound of the polytope, one number for every row or a list of one per joint (each "
                   "joint's rows; equal to the e_max of an OBE on "
                   "the same rows); with `regression`, this or `e_max_rule` is required.",
    "exact.e_max_rule": "The bound as a rule: a factor times gamma*, the smallest bound the data allow (instead of "
                        "e_max); e_max_rule = {} is the default, 2 x gamma*, one bound on every row (the truth "
                        "needed 1.25-1.71 gamma* on MuJoCo UR5 recordings of three joints, 1.39-1.95 of six).",
    "exact.e_max_rule.factor": "e_max = factor x the smallest consistent bounds of the scaling (>= 1; 1 leaves one "
                               "point).",
    "exact.e_max_rule.scaling": "\"one\": one bound on every row; \"per_joint\": in proportion to each joint's own "
                                "gamma*; \"wls_spread\": in proportion to each joint's WLS residual spread.",
    "exact.lp_bounds": "Compute the exact parameter bounds (2p LPs).",
    "exact.relaxed_q": "Also bound the q-relaxed feasible set, the parameters that violate at most q rows (2p "
                       "MILPs by HiGHS, RELAXED_TIME_LIMIT_S each; an interval hull, outer: a bound cut short by "
                       "the limit is the MILP's dual bound, marked not proven). Practical for a few dozen "
                       "parameters; on the TX40's 61 the MILPs stop at their limit.",
    "exact.sdp": "SDP ellipsoids to compute: outer (S-procedure upper bound on the minimum-volume ellipsoid), "
                 "inner (largest inscribed), john.",
    "exact.volume_bracket": "With the outer and inner SDPs: bracket ln vol of the minimum-volume outer ellipsoid "
                            "(support LPs of P; its cost grows fast with p), so each set's excess over it is "
                            "bracketed on the page.",
    "exact.projections": "Pairs of parameter names whose 2-D projections of the sets are drawn.",
    "experiment.measured.holdout_fraction": "Share of the recording, at its end, kept out of identification "
                                            "(held-out validation): the estimates on the inverse_dynamic rows "
                                            "(which regressions must list) and their exact polytope predict its "
                                            "torques, with each band's coverage and width. 0: none.",
    "published[]": "A published table of the robot's parameter values ([[published]], one per table), held "
                   "against the data on the page: each value inside its exact interval or not, and the smallest "
                   "bound at which the data allow it.",
    "published[].label": "The table's name on the page (e.g. \"FIGAROH, first estimate\").",
    "published[].source": "Where the values come from: a citation key of docs/references.md and the table.",
    "published[].file": "A CSV file of names and values, relative to the study file (exclusive with values).",
    "published[].header": "Whether the file's first line is a header (skipped).",
    "published[].name_column": "The file's column of names (from 0): a parameter name, or a base parameter's "
                               "definition in standard parameters (\"Izz1 + 1.0*Ia1 + 0.05185*m3\").",
    "published[].value_column": "The file's column of values (from 0), in SI units as the model's.",
    "published[].values": "The values inline, {name = number} (exclusive with file).",
    "published[].names": "A source name -> the same quantity in the model's parameter names, where the two "
                         "models differ: {fs1 = \"fc1\", fv5 = \"fv5 + fvm6\"}.",
    "paper": "The paper's published values for the page's comparison table (free-form table).",
    "campaign": "A Monte Carlo campaign (boundid campaign): replicates of noise scenarios.",
    "campaign.replicates": "Replicates per scenario (the command's --replicates overrides it).",
    "campaign.estimators": ("Labels of the estimators each replicate runs (default: every [[estimators]] table); "
                            "the exact LP bounds always run. Fewer estimators, faster replicates."),
    "campaign.scenarios[]": "One table per scenario ([[campaign.scenarios]]); each overrides the experiment.",
    "campaign.scenarios[].name": "A plain name (files and page rows).",
    "campaign.scenarios[].description": "The scenario in words.",
    "campaign.scenarios[].encoder_counts_per_rev": "Overrides experiment.noise.encoder_counts_per_rev.",
    "campaign.scenarios[].structural_error": "Overrides experiment.structural_error (closed loop only).",
    "campaign.scenarios[].torque": "Overrides experiment.noise.torque (same keys).",
    "campaign.scenarios[].torque.kind": "As experiment.noise.torque.kind.",
    "campaign.scenarios[].torque.level": "As experiment.noise.torque.level [N m].",
    "campaign.scenarios[].torque.outlier_rate": "As experiment.noise.torque.outlier_rate.",
    "campaign.scenarios[].torque.outlier_size": "As experiment.noise.torque.outlier_size [N m].",
}

#: an estimator option without a sentence above takes its options dataclass's help line
#: (:func:`boundid.estimators.method.option`): the first method that declares the name
for _m in METHODS.values():
    for _f in dataclasses.fields(_m.options):
        if _f.metadata.get("help"):
            DESCRIPTIONS.setdefault(f"estimators[].{_f.name}", f"{_m.name}: {_f.metadata['help']}")


@dataclass
class Key:
    """One key of a study file as the parser reads it."""

    path: str  # dotted, "[]" after an array of tables
    kind: str  # "string", "number", "integer", "true or false", "list of strings", "table", ...
    required: bool = False
    default: Any = None
    default_note: str = ""  # "depends on method" (the default follows another key), "built in" (read if given)
    allowed: str = ""  # choices or range, in words
    when: dict[str, set[str]] = field(default_factory=dict)  # choice key -> its values under which it is read
    options: dict[str, Any] | None = None  # an option table: {option: default}
    options_by: dict[str, dict[str, Any]] = field(default_factory=dict)  # 'model = "h4"' -> its options


def _dotted(section: Section, key: str) -> str:
    return re.sub(r"\[\d+\]", "[]", f"{section.path}.{key}" if section.path else key)


class _AnyKey(dict):
    """The probe's parsed file: it has every key (``"campaign" in data``), each an empty table."""

    def __contains__(self, key) -> bool:
        return True


class _Probe(Section):
    """A Section that answers every typed look-up with a valid value and records the look-up."""

    seen: dict[str, Key]
    forced: dict[str, str]
    optional: set[str]

    def __init__(self, data, path, file):
        super().__init__(data if isinstance(data, dict) else {}, path, file)

    def _note(self, key: str, kind: str, default: Any = MISSING, allowed: str = "", **extra) -> str:
        path = _dotted(self, key)
        self._read.add(key)
        if path not in _Probe.seen:
            guarded = default is MISSING and path in _Probe.optional  # read only if given, default in the code
            _Probe.seen[path] = Key(path, kind, default is MISSING and not guarded,
                                    None if default is MISSING else default, allowed=allowed,
                                    default_note="built in" if guarded else "", **extra)
        return path

    def has(self, key: str) -> bool:
        if key in RENAMED:  # a former name: the parser only looks for it to refuse it
            return False
        _Probe.optional.add(_dotted(self, key))  # read only if given: not required
        return True

    def str(self, key, default=MISSING, choices=None):
        allowed = tuple(choices) if choices is not None else ()
        path = self._note(key, "string", default, ", ".join(f'"{c}"' for c in allowed))
        if allowed:
            return _Probe.forced.get(path, allowed[0])
        return default if isinstance(default, str) or default is None else "probe"  # None: an optional one absent

    def float(self, key, default=MISSING, lo=None, hi=None, strict_lo=False, strict_hi=False):
        self._note(key, "number", default, range_text(lo, hi, strict_lo, strict_hi))
        if isinstance(default, int | float):
            return float(default)
        value = (lo if lo is not None else 0.0) + 1.0
        return (lo + hi) / 2 if hi is not None and value >= hi else value

    def int(self, key, default=MISSING, lo=None, hi=None):
        self._note(key, "integer", default, range_text(lo, hi))
        return default if isinstance(default, int) else (lo if lo is not None else 1)

    def bool(self, key, default=MISSING):
        self._note(key, "true or false", default)
        return default if isinstance(default, bool) else True

    def list(self, key, default=MISSING, of=builtins.str, choices=None):
        allowed = tuple(choices) if choices is not None else ()
        numbers = (builtins.int, builtins.float)
        kinds = {builtins.str: "strings", builtins.list: "lists", numbers: "numbers"}.get(of, "values")
        self._note(key, f"list of {kinds}", default, ", ".join(f'"{c}"' for c in allowed))
        if allowed:
            return list(allowed)
        given = [1.0, 1.0] if of == numbers else ["a", "b"]  # two entries, as every list the probe answers
        return [] if of is builtins.list else (list(default) if isinstance(default, list) else given)

    def section(self, key, required=False):
        self._note(key, "table", MISSING if required else {})
        return _Probe({}, f"{self.path + '.' if self.path else ''}{key}", self.file)

    def sections(self, key):
        self._note(f"{key}[]", "array of tables", [])
        return [_Probe({}, f"{self.path + '.' if self.path else ''}{key}[0]", self.file)]

    def raw(self, key, default=MISSING):
        self._note(key, "table", default)
        return {} if default is MISSING else default

    def plain_name(self, key):
        self._note(key, "string (a plain name)")
        return "probe"

    def options(self, key, known, owner):
        self._note(key, "table", {}, options=dict(known))
        return {}

    def check_unknown(self, known=None):
        return None


@contextmanager
def _probing(forced: dict[str, str]) -> Iterator[dict[str, Key]]:
    """While inside, every module of boundid.studies that reads study files with Section and
    read_toml reads the probe instead."""
    read_toml = schema.read_toml
    modules = [m for name, m in list(sys.modules.items()) if name.startswith("boundid.studies.") and m is not schema
               and (getattr(m, "Section", None) is Section or getattr(m, "read_toml", None) is read_toml)]
    saved = [(m, dict(vars(m))) for m in modules]
    _Probe.seen, _Probe.forced, _Probe.optional = {}, forced, set()
    try:
        for m in modules:
            if getattr(m, "Section", None) is Section:
                m.Section = _Probe
            if getattr(m, "read_toml", None) is read_toml:
                m.read_toml = lambda path: _AnyKey()
        yield _Probe.seen
    finally:
        for m, before in saved:
            for name in ("Section", "read_toml"):
                if name in before:
                    setattr(m, name, before[name])


def _parse_once(forced: dict[str, str]) -> dict[str, Key]:
    from boundid.errors import BoundidError
    from boundid.studies import config, scenarios

    with tempfile.TemporaryDirectory() as tmp, _probing(forced) as seen:
        path = Path(tmp) / "probe.toml"
        path.write_text("")
        try:
            cfg = config.load_study(path)
        except BoundidError:  # the probe's values may not make a runnable study; the keys were read
            cfg = None
        if cfg is not None:
            try:
                scenarios.load_campaign(cfg)
            except BoundidError:
                pass
        return dict(seen)


def study_keys() -> list[Key]:
    """Every key the parser reads, in reading order, each with the choices under which it is read."""
    base = _parse_once({})
    keys = dict(base)
    runs: dict[str, dict[str, set[str]]] = {}  # choice key -> choice -> keys read
    for path, key in base.items():
        choices = re.findall(r'"([^"]+)"', key.allowed) if key.kind == "string" else []
        if len(choices) < 2:
            continue
        runs[path] = {}
        options: dict[str, dict[str, dict]] = {}  # option table -> choice -> its options
        defaults: dict[str, set[str]] = {}  # key -> its defaults over the choices
        for choice in choices:
            seen = _parse_once({path: choice})
            runs[path][choice] = set(seen)
            for p, k in seen.items():
                keys.setdefault(p, k)
                defaults.setdefault(p, set()).add(repr(k.default))
                if k.options is not None:
                    options.setdefault(p, {})[choice] = k.options
        for p, values in defaults.items():
            if len(values) > 1 and p != path:
                keys[p].default_note = f"depends on {path.rsplit('.', 1)[-1]}"
        for p, by_choice in options.items():  # options that depend on this choice: one list per choice
            if len({repr(sorted(o.items())) for o in by_choice.values()}) > 1:
                name = path.rsplit(".", 1)[-1]
                keys[p].options_by = {f'{name} = "{c}"': o for c, o in by_choice.items()}
    for choice_key, by_choice in runs.items():
        every = set.intersection(*by_choice.values())
        for p in set.union(*by_choice.values()) - every:
            keys[p].when[choice_key] = {c for c, s in by_choice.items() if p in s}
    return list(keys.values())


def _default_text(key: Key) -> str:
    if key.required:
        return "required"
    if key.kind in ("table", "array of tables"):
        return ""
    if key.default_note:
        return key.default_note
    d = key.default
    if d is None or d == {} or d == []:
        return "" if key.kind in ("table", "array of tables") else "absent"
    if isinstance(d, bool):
        return "true" if d else "false"
    if isinstance(d, str):
        return f'"{d}"'
    return f"{d!r}".replace("(", "[").replace(")", "]") if isinstance(d, tuple) else f"{d:g}" if isinstance(
        d, float) else str(d)


def _toml_name(path: str) -> str:
    return path.replace("[]", "")


def render(keys: list[Key]) -> str:
    """The Markdown of docs/study-files.md."""
    missing = [k.path for k in keys if k.path not in DESCRIPTIONS]
    stale = sorted(set(DESCRIPTIONS) - {k.path for k in keys})
    if missing or stale:
        raise SystemExit("boundid.docs: " + (f"no description for {missing} (add it to DESCRIPTIONS) " if missing
                                             else "") + (f"descriptions of keys the parser no longer reads: {stale}"
                                                         if stale else ""))
    tables = [k for k in keys if k.kind in ("table", "array of tables")]
    lines = ["# Study files", "",
             "<!-- Generated by `python -m boundid.docs` (make docs) from the study-file parser; do not edit. -->", "",
             "A study is a TOML file (`studies/*.toml`; a measured-data example to copy is "
             "`studies/examples/measured_direct_drive.toml`). `boundid run <file>` runs it; every key is checked "
             "when the file is read (a number must be finite, not nan or inf, and within its allowed range), and "
             "an unknown or misspelt key or a bad value is refused with a message naming the file, the key and "
             "what is allowed.", "",
             "Each table below lists its keys: type, default (\"required\": no default; \"absent\": the feature "
             "is off unless given; \"built in\": the estimator's own default), allowed values, and when the key "
             "is read, if only under some choice of another key.", ""]

    def when(k: Key) -> str:
        return "; ".join(f"{_toml_name(ck).rsplit('.', 1)[-1]} = " + " or ".join(f'"{c}"' for c in sorted(v))
                         for ck, v in k.when.items())

    def table_rows(members: list[Key]) -> list[str]:
        out = ["| key | type | default | allowed | read when | description |", "|---|---|---|---|---|---|"]
        for k in members:
            name = k.path.rsplit(".", 1)[-1].replace("[]", "")
            cells = [f"`{name}`", k.kind, _default_text(k), k.allowed, when(k), DESCRIPTIONS[k.path]]
            out.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
        return out

    top = [k for k in keys if "." not in k.path.replace("[]", "") and k.kind not in ("table", "array of tables")]
    if top:
        lines += ["## Top level", "", *table_rows(top), ""]
    roots = list(dict.fromkeys(k.path.split(".")[0] for k in keys))
    for t in sorted(tables, key=lambda t: roots.index(t.path.split(".")[0])):
        members = [k for k in keys if k.path.rsplit(".", 1)[0] == t.path and "." in k.path and k not in tables]
        name = _toml_name(t.path)
        parent, _, last = t.path.rpartition(".")
        if "[]" in parent:  # a table inside each element of an array of tables
            header = f"`{last}` in each `[[{_toml_name(parent)}]]`"
        else:
            header = f"`[[{name}]]`" if t.kind == "array of tables" else f"`[{name}]`"
        lines += [f"## {header}", "", DESCRIPTIONS[t.path] + (
            f" Read when {when(t)}." if t.when else "") + (" Required." if t.required else ""), ""]
        if t.options is not None:
            for case, options in (t.options_by or {"": t.options}).items():
                lines += [f"With {case}:", ""] if case else []
                if options:
                    lines += ["| option | type | default |", "|---|---|---|"]
                    lines += [f"| `{o}` | {describe_option(d)} | {_default_text(Key(o, '', default=d))} |"
                              for o, d in options.items()]
                else:
                    lines += ["No options."]
                lines.append("")
        if members:
            lines += [*table_rows(members), ""]
    return "\n".join(lines).rstrip() + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m boundid.docs", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="docs/study-files.md", help="file to write (default: docs/study-files.md)")
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 if --out differs from the generated")
    args = ap.parse_args(argv)
    text = render(study_keys())
    out = Path(args.out)
    if args.check:
        same = out.is_file() and out.read_text(encoding="utf-8") == text
        print(f"{out}: {'up to date' if same else 'differs from the generated file: run python -m boundid.docs'}")
        return 0 if same else 1
    out.write_text(text, encoding="utf-8")
    print(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
