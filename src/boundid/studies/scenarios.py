"""Monte Carlo scenarios: named overrides of a study's simulated experiment.

A study file lists them in a ``[campaign]`` table (read here with ``tomllib`` from ``cfg.file``;
``boundid.studies.config`` only has to accept the ``campaign`` key)::

    [campaign]
    replicates = 100                      # default of --replicates

    [[campaign.scenarios]]
    name = "gaussian_low"                 # a plain name: letters, digits, '_' and '-' (it names the result files)
    description = "Gaussian torque noise, sigma = 0.5 N m"
    torque = { kind = "gaussian", level = 0.5 }   # kind, level [N m], outlier_rate, outlier_size [N m]
    encoder_counts_per_rev = 4096         # coarser encoder (optional)
    structural_error = 1.5                # experiment.structural_error (closed loop only; H4: 1 = physical, < 1.74)

A key left out keeps the study's value; ``torque`` replaces the study's torque noise as a whole
(its own keys default to TorqueNoise's). Without a ``[campaign]`` table, the campaign runs one
scenario, ``study``: the experiment as the study file describes it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from boundid.errors import StudyError
from boundid.experiments.measurement import TorqueNoise
from boundid.studies.schema import Section, read_toml

NOISE_KINDS = ("none", "gaussian", "uniform", "bounded_outliers")


@dataclass(frozen=True)
class Scenario:
    """One scenario: None keeps the study's value."""

    name: str
    description: str = ""
    torque_noise: TorqueNoise | None = None
    encoder_counts_per_rev: int | None = None
    structural_error: float | None = None

    def apply(self, cfg):
        """The study ``cfg`` (a :class:`~boundid.studies.config.StudyConfig`, which imports this module to
        read its [campaign] table) with this scenario's experiment (``dataclasses.replace``; nothing else changes)."""
        if cfg.experiment.source != "simulate":
            raise StudyError(f"{cfg.file}: a Monte Carlo campaign re-draws the noise of a simulated experiment; "
                             "this study reads measured data (experiment.source = 'measured').")
        if self.structural_error and cfg.experiment.control == "open_loop":
            raise StudyError(f"{cfg.file}: scenario {self.name!r} sets structural_error, but the open-loop experiment "
                             "simulates the identification model itself (no structural error to add); use it with "
                             "experiment.control = 'closed_loop' (the H4 robot).")
        changes = {k: v for k, v in (("torque_noise", self.torque_noise),
                                     ("encoder_counts_per_rev", self.encoder_counts_per_rev),
                                     ("structural_error", self.structural_error)) if v is not None}
        return replace(cfg, experiment=replace(cfg.experiment, **changes))


@dataclass(frozen=True)
class CampaignSpec:
    """The ``[campaign]`` table: default replicate count, the scenarios in file order, and the labels of
    the estimators a replicate runs (empty: every estimator of the study)."""

    replicates: int
    scenarios: tuple[Scenario, ...]
    estimators: tuple[str, ...] = ()

    def select(self, names: list[str] | None) -> tuple[Scenario, ...]:
        """The named scenarios (all when ``names`` is None or empty); StudyError for an unknown name."""
        if not names:
            return self.scenarios
        known = {s.name: s for s in self.scenarios}
        for n in names:
            if n not in known:
                raise StudyError(f"no scenario {n!r} in the study's [campaign]; it has {', '.join(known)}.")
        return tuple(known[n] for n in dict.fromkeys(names))


def read_torque_noise(sec: Section) -> TorqueNoise:
    """A torque-noise table (``experiment.noise.torque``, a scenario's ``torque``): kind, level [N m],
    outlier_rate (share of the samples), outlier_size [N m]; a key left out takes TorqueNoise's default."""
    noise = TorqueNoise(kind=sec.str("kind", "none", choices=NOISE_KINDS), level=sec.float("level", 0.0, lo=0.0),
                        outlier_rate=sec.float("outlier_rate", 0.0, lo=0.0, hi=0.5),
                        outlier_size=sec.float("outlier_size", 0.0, lo=0.0))
    sec.check_unknown()
    return noise


def _scenario(sec: Section) -> Scenario:
    name = sec.plain_name("name")
    torque = sec.section("torque")  # read when absent too: check_unknown lists it among the keys
    noise = read_torque_noise(torque) if sec.has("torque") else None
    sc = Scenario(name=name, description=sec.str("description", ""), torque_noise=noise,
                  encoder_counts_per_rev=sec.int("encoder_counts_per_rev", None, lo=2),
                  structural_error=sec.float("structural_error", None, lo=0.0))
    sec.check_unknown()
    return sc


def read_campaign(sec: Section, labels: list[str]) -> CampaignSpec:
    """The ``[campaign]`` table ``sec`` of a study whose estimators are labelled ``labels``; StudyError
    naming file and key on bad input. :func:`boundid.studies.config.load_study` reads it too, so
    ``boundid run`` refuses what ``boundid campaign`` would."""
    replicates = sec.int("replicates", 10, lo=1)
    estimators = tuple(dict.fromkeys(sec.list("estimators", [])))
    if any(lab not in labels for lab in estimators):
        raise sec.error("estimators", f"entries must be labels of the study's estimators ({labels}); got "
                                      f"{[lab for lab in estimators if lab not in labels]}.")
    scenarios = tuple(_scenario(s) for s in sec.sections("scenarios"))
    if not scenarios:
        raise sec.error("scenarios", "no [[campaign.scenarios]] table: name at least one scenario.")
    names = [s.name for s in scenarios]
    if len(set(names)) != len(names):
        raise sec.error("scenarios", f"names must be unique, got {names}.")
    sec.check_unknown()
    return CampaignSpec(replicates, scenarios, estimators)


def load_campaign(cfg) -> CampaignSpec:
    """Parse the ``[campaign]`` table of ``cfg.file`` (``cfg`` a StudyConfig); StudyError naming file and key on
    bad input."""
    path = Path(cfg.file)
    data = read_toml(path)
    if "campaign" not in data:
        return CampaignSpec(replicates=10, scenarios=(Scenario("study", "the experiment of the study file"),))
    return read_campaign(Section(data, "", path).section("campaign"), [ec.label for ec in cfg.estimators])
