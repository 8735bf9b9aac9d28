"""The head of a small simulated direct-drive study file, shared by the tests that need a real study
run in a few seconds: 2 s of the open-loop experiment at h = 2.5 ms, uniform torque noise of
0.5 N m, a 16-bit encoder and a zero-centred prior box of +-100. A test appends its own
[[estimators]], [exact] and [campaign] tables."""

from __future__ import annotations


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
