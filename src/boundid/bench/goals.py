"""Benchmark goals, judged from the CSV a benchmark module wrote, and the machine it ran on.

Each ``bench_<topic>.py`` states its goals twice: in words (``GOALS``, for readers) and as
:class:`Goal` records (``GOAL_CHECKS``), which :func:`judge` applies to the rows of
``<topic>.csv``. A goal selects one row (``where``: column -> regular expression matched against
the cell's text), reads one measured column, compares it with its target and says "met",
"missed", "met on CPU time only" (a rate measured on wall-clock time missed the goal, the same
rate on process CPU time met it: the machine's cores were shared) or "not measured", with the
reason (no such row, no such column, an empty cell).

:func:`machine` describes the machine (CPU model, cores, load average, library versions); the
benchmark runner stores it as ``<topic>.json`` beside each CSV.
"""

from __future__ import annotations

import importlib.metadata
import math
import os
import platform
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

import pandas as pd

from boundid.errors import InputError

LIBRARIES = ("numpy", "numba", "highspy", "clarabel", "scipy", "cvxpy")
LOAD_COLUMNS = ("load_avg", "load_avg_1min")  # the 1-minute load average a benchmark row recorded


@dataclass(frozen=True)
class Goal:
    """One goal of a benchmark.

    name : what is measured, e.g. "exact LP bounds: time"
    where : {column: regular expression} selecting the row (full match on the cell's text)
    column : the measured column;  scale : factor applied to it (e.g. 1e-6 for M/s)
    op, target, unit : the goal "value op target" and the unit of value and target
    size : the case's size, a format string over the row (e.g. "p = {p}, N = {N:,}")
    cpu_column : the same measure on process CPU time, if the benchmark records it
    """

    name: str
    where: Mapping[str, str]
    column: str
    op: Literal["<=", ">="]
    target: float
    unit: str = ""
    size: str = ""
    scale: float = 1.0
    cpu_column: str | None = None

    def __post_init__(self):
        if self.op not in ("<=", ">="):
            raise InputError(f"Goal {self.name!r}: op must be '<=' or '>=', got {self.op!r}.")

    def holds(self, value: float) -> bool:
        return value <= self.target if self.op == "<=" else value >= self.target


@dataclass
class Verdict:
    """A goal judged on one CSV: status, the measured value (None if not measured) and why."""

    goal: Goal
    status: Literal["met", "met on CPU time only", "missed", "not measured"]
    value: float | None = None
    cpu_value: float | None = None
    size: str = ""
    load: float | None = None
    reason: str = ""
    row: dict = field(default_factory=dict)


def _number(x) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def select(df: pd.DataFrame, where: Mapping[str, str]) -> pd.DataFrame:
    """Rows of ``df`` whose cells fully match every ``where`` pattern (cells compared as text)."""
    mask = pd.Series(True, index=df.index)
    for col, pattern in where.items():
        if col not in df.columns:
            return df.iloc[0:0]
        rx = re.compile(pattern)
        mask &= df[col].map(lambda v, rx=rx: bool(rx.fullmatch(str(v))))
    return df[mask]


def judge(goal: Goal, df: pd.DataFrame, topic: str, load: float | None = None) -> Verdict:
    """The verdict of ``goal`` on the rows ``df`` of ``<topic>.csv``; ``load``: the load average to
    show when the row did not record its own (e.g. the machine's at the start of the benchmark)."""
    rows = select(df, goal.where)
    which = ", ".join(f"{c} = {p}" for c, p in goal.where.items())
    if rows.empty:
        return Verdict(goal, "not measured", reason=f"{topic}.csv has no row with {which} (the case did not run)")
    row = rows.iloc[0].to_dict()
    load = next((_number(row[c]) for c in LOAD_COLUMNS if c in row and _number(row[c]) is not None), load)
    try:
        size = goal.size.format(**row)
    except (KeyError, ValueError):
        size = ""
    if goal.column not in row:
        return Verdict(goal, "not measured", size=size, load=load, row=row,
                       reason=f"{topic}.csv has no column {goal.column!r} (written by an older benchmark)")
    value = _number(row[goal.column])
    if value is None:
        return Verdict(goal, "not measured", size=size, load=load, row=row,
                       reason=f"the benchmark wrote no value in {goal.column!r} for this case")
    value *= goal.scale
    cpu = _number(row.get(goal.cpu_column)) if goal.cpu_column else None
    cpu = None if cpu is None else cpu * goal.scale
    if goal.holds(value):
        status = "met"
    elif cpu is not None and goal.holds(cpu):
        status = "met on CPU time only"
    else:
        status = "missed"
    return Verdict(goal, status, value, cpu, size, load, row=row)


def cpu_model() -> str:
    """The CPU's model name (Linux: /proc/cpuinfo), else what the platform module knows."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def machine() -> dict:
    """CPU model, cores, 1/5/15-minute load averages, OS, Python and library versions, now."""
    versions = {"python": platform.python_version()}
    for lib in LIBRARIES:
        try:
            versions[lib] = importlib.metadata.version(lib)
        except importlib.metadata.PackageNotFoundError:
            versions[lib] = "not installed"
    return {"cpu": cpu_model(), "cores": os.cpu_count(), "load_avg": list(os.getloadavg()),
            "system": f"{platform.system()} {platform.release()} ({platform.machine()})", "versions": versions}
