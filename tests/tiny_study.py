"""The head of a small simulated direct-drive study file, shared by the tests that need a real study
run in a few seconds: 2 s of the open-loop experiment at h = 2.5 ms, uniform torque noise of
0.5 N m, a 16-bit encoder and a zero-centred prior box of +-100. A test appends its own
[[estimators]], [exact] and [campaign] tables. :func:`run_study_text` runs such a study and
:func:`measured_twin` turns it into the same study on its own recording."""

from __future__ import annotations

from pathlib import Path

from boundid.experiments.recording import Recording, write_recording
from boundid.studies.config import load_study
from boundid.studies.runner import run_study


def tiny_study(name: str, seed: int, regressions: tuple[str, ...] = ("filtered_dynamic",), extra: str = "") -> str:
    """TOML text from ``regressions`` to ``[prior]``; ``extra`` (e.g. a [preprocessing] table) goes
    before ``[prior]``."""
    regs = ", ".join(f'"{r}"' for r in regressions)
    return f"""
regressions = [{regs}]

[study]
name = "{name}"
title = "Direct-drive arm, 2 s"
seed = {seed}

[robot]
model = "direct_drive"

[experiment]
source = "simulate"
duration_s = 2.0
sample_period_s = 0.0025

[experiment.noise]
encoder_counts_per_rev = 65536
torque = {{ kind = "uniform", level = 0.5 }}
{extra}
[prior]
center = "zero"
absolute_range = 100.0
"""


def run_study_text(folder: Path, name: str, text: str):
    """Write study ``text`` as ``folder/name.toml``, read and run it: (config, StudyResult)."""
    path = Path(folder) / f"{name}.toml"
    path.write_text(text)
    cfg = load_study(path)
    return cfg, run_study(cfg)


def measured_twin(text: str, result, folder: Path) -> str:
    """The study ``text`` (a :func:`tiny_study` head) turned into one on a measured recording: the
    simulated run's encoder angles and torques of ``result`` written to ``folder/arm.csv``."""
    rec = result.data.recording
    csv = write_recording(Recording(rec.t, rec.q, rec.tau), Path(folder) / "arm.csv")
    text = text.replace('source = "simulate"\nduration_s = 2.0\nsample_period_s = 0.0025',
                        f'source = "measured"\n[experiment.measured]\nfile = "{csv.name}"\n'
                        '[experiment.measured.columns]\ntime = "t"\nq = ["q1", "q2"]\ntau = ["tau1", "tau2"]')
    return text.replace("[experiment.noise]\nencoder_counts_per_rev = 65536\n"
                        'torque = { kind = "uniform", level = 0.5 }\n', "")
