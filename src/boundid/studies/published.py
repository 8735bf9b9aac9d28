"""Published parameter values held against the data: inside the exact interval, and from which bound.

A published table ([[published]] in a study file) lists values of named quantities: a friction
coefficient ``fv1``, or a base parameter written as its definition in standard parameters,
``Izz1 + 1.0*Ia1 + 0.05185*m3`` (the first column of [FIGAROH]'s tables). Each quantity is a linear
combination a^T x of the model's standard parameters x (``names`` maps a name of the source to an
expression in the model's names where the two models differ, e.g. a source's ``fv5`` that includes
the coupled motor's friction: ``fv5 + fvm6``). It can be compared with the data only if it is a
combination of the base parameters beta = K x, i.e. a = K^T c; then its value is c^T beta, and

* its exact interval over the feasible polytope P is [-h_P(-c), h_P(c)] (two LPs, h_P the support
  function), the interval of every parameter vector the data allow under the bound;
* the physically consistent one is read from the physical stage's bounds when c picks one parameter;
* the smallest bound factor s at which the value is consistent with the data is one LP, gamma* of
  {beta in the prior box : |y - W beta| <= s e, c^T beta = v}: s <= 1 means inside the exact interval,
  and a published value contradicts the data at the chosen bound exactly when s > 1. Alone, one value
  leaves every other parameter free; the same LP with all of a table's values at once (C beta = v)
  says whether the table as a whole is consistent with the data, and from which bound.
"""

from __future__ import annotations

import csv
import difflib
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from boundid.errors import RUN_FAILURES, InputError, StudyError
from boundid.sets import Polytope
from boundid.studies.schema import Section

#: relative residual of K^T c = a below which a published quantity is a combination of the base
#: parameters (published definitions round their coefficients to 4-6 significant digits)
COMBINATION_RTOL = 1e-3

_TERM = re.compile(r"\s*([+-])?\s*(?:(\d+(?:\.\d*)?(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?)\s*\*?\s*)?"
                   r"([A-Za-z_]\w*)\s*")


@dataclass(frozen=True)
class PublishedTable:
    """label: the table's name on the page; source: where its values come from (a citation);
    entries: (name in the source, value) in the source's order; names: a source name -> the
    expression of the same quantity in the model's parameter names (where they differ)."""

    label: str
    source: str
    entries: tuple[tuple[str, float], ...]
    names: dict[str, str]


def parse_linear(text: str) -> dict[str, float]:
    """{name: coefficient} of a linear expression such as ``Izz1 + 1.0*Ia1 - 0.225 mz3``; InputError
    when the text is not one."""
    out: dict[str, float] = {}
    pos, first = 0, True
    text = text.strip()
    while pos < len(text):
        m = _TERM.match(text, pos)
        if m is None or m.end() == pos or (m.group(1) is None and not first):
            raise InputError(f"{text!r} is not a linear expression of parameter names (e.g. 'fv5 + fvm6' or "
                             f"'Izz1 + 0.05*m3'): cannot read it from character {pos + 1}.")
        sign = -1.0 if m.group(1) == "-" else 1.0
        out[m.group(3)] = out.get(m.group(3), 0.0) + sign * float(m.group(2) or 1.0)
        pos, first = m.end(), False
    if not out:
        raise InputError("an empty expression names no parameter.")
    return out


def functional(expression: str, model) -> np.ndarray | None:
    """c (r,) with c^T beta the quantity ``expression`` (model names: standard parameters, or base
    symbols such as ``Izz1R`` read as their definitions), or None when it is not a combination of the
    base parameters (relative residual of K^T c = a above :data:`COMBINATION_RTOL`). InputError for a
    name the model does not have."""
    base = getattr(model, "base", None)
    std = tuple(model.robot.param_names) if base is not None else tuple(model.param_names)
    K = base.K if base is not None else np.eye(len(std))
    symbols = tuple(model.param_names)
    a = np.zeros(len(std))
    for name, coef in parse_linear(expression).items():
        if name in std:
            a[std.index(name)] += coef
        elif name in symbols:
            a += coef * K[symbols.index(name)]
        else:
            known = list(dict.fromkeys([*symbols, *std]))
            near = difflib.get_close_matches(name, known, n=3)
            where = "" if expression.strip() == name else f" in {expression!r}"
            raise InputError(f"{name!r}{where} is not a parameter of the {model.name} model"
                             + (f" (did you mean {' or '.join(map(repr, near))}?)" if near else "")
                             + (f"; its parameters: {', '.join(known)}." if len(known) <= 30 else
                                f"; `boundid list` shows its {len(known)} parameter names."))
    c, *_ = np.linalg.lstsq(K.T, a, rcond=None)
    return c if np.linalg.norm(K.T @ c - a) <= COMBINATION_RTOL * np.linalg.norm(a) else None


def _read_file(sec: Section, path: Path, header: bool, name_col: int, value_col: int) -> list[tuple[str, float]]:
    if not path.is_file():
        raise sec.error("file", f"{path} not found.")
    with path.open(newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))[1 if header else 0:]
    out = []
    for k, row in enumerate(rows, start=2 if header else 1):
        if not row:
            continue
        if max(name_col, value_col) >= len(row):
            raise sec.error("value_column", f"line {k} of {path.name} has {len(row)} columns; name_column and "
                                            "value_column count from 0.")
        try:
            value = float(row[value_col])
        except ValueError:
            raise sec.error("value_column", f"line {k} of {path.name}: {row[value_col]!r} is not a number (a "
                                            "header line? set header = true).") from None
        out.append((row[name_col].strip(), value))
    return out


def read_published(top: Section, base: Path) -> tuple[PublishedTable, ...]:
    """The study file's [[published]] tables (``base``: the study file's folder)."""
    tables = []
    for sec in top.sections("published"):
        label, source = sec.str("label"), sec.str("source", "")
        file = sec.str("file", None)
        values = sec.raw("values") if sec.has("values") else None
        header = sec.bool("header", False)
        name_col, value_col = sec.int("name_column", 0, lo=0), sec.int("value_column", 1, lo=0)
        names = sec.raw("names", {})
        sec.check_unknown()
        if (file is None) == (values is None):
            raise sec.error("file", "or values: give exactly one (a CSV file of names and values, or a table "
                                    "{name = value}).")
        if not isinstance(names, dict) or not all(isinstance(v, str) for v in names.values()):
            raise sec.error("names", "must be a table {source name = \"expression in the model's names\"}.")
        if values is not None:
            if not isinstance(values, dict) or not all(isinstance(v, int | float) and not isinstance(v, bool)
                                                       for v in values.values()):
                raise sec.error("values", "must be a table {name = number}.")
            entries = [(k, float(v)) for k, v in values.items()]
        else:
            entries = _read_file(sec, (base / file).resolve(), header, name_col, value_col)
        bad = [k for k, v in entries if not np.isfinite(v)]
        if bad:
            raise sec.error("values", f"{bad[0]!r} is not finite; give a number or leave it out.")
        tables.append(PublishedTable(label, source, tuple(entries), dict(names)))
    return tuple(tables)


def check_published(tables: tuple[PublishedTable, ...], model, file) -> None:
    """StudyError naming the table and entry whose expression cannot be read or names a parameter the
    model lacks (a quantity that is no combination of base parameters is kept: the page says so)."""
    for t in tables:
        for name, _ in t.entries:
            try:
                functional(t.names.get(name, name), model)
            except InputError as exc:
                raise StudyError(f"{file}: published {t.label!r}, entry {name!r}: {exc} Where the source names a "
                                 f"quantity of this model otherwise, map it: names = {{\"{name}\" = \"<expression in "
                                 "the model's names>\"}.") from None


def smallest_factor(P: Polytope, C: np.ndarray, values: np.ndarray) -> float:
    """gamma* of P with C beta = values added (C (m, r), values (m,)): the factor of every row's bound
    from which the data allow these values (one LP; inf when the prior box, or the values among
    themselves, exclude them). <= 1: allowed at the chosen bound."""
    C = np.atleast_2d(C)
    values = np.atleast_1d(values)
    return Polytope.from_strips(P.W, P.y, P.e_max, box=P.box,
                                halfspaces=(np.vstack([C, -C]), np.r_[values, -values])).consistency().gamma


@dataclass
class PublishedComparison:
    """values: one row per published value (:func:`compare_published`); tables: one row per table:
    its values, how many are comparable, inside their exact (and physically consistent) intervals,
    and ``together from``: the factor of the chosen bound from which the data allow all its
    comparable values at once (one LP; NaN without a polytope)."""

    values: pd.DataFrame
    tables: pd.DataFrame


def _quantity(c: np.ndarray, names: tuple[str, ...]) -> str:
    """The combination c^T beta in words: "fv5", or "fv5 + fvm6"."""
    nz = np.flatnonzero(np.abs(c) > 1e-9)
    if nz.size == 1 and abs(c[nz[0]] - 1) < 1e-9:
        return names[nz[0]]
    text = " ".join(f"{'+' if w > 0 else '-'} {'' if abs(abs(w) - 1) < 1e-9 else f'{abs(w):.4g} '}{names[j]}"
                    for j, w in zip(nz, c[nz], strict=True))
    return text[2:] if text.startswith("+ ") else text


def _factor(P: Polytope, C, values) -> float:
    try:
        return smallest_factor(P, C, values)
    except RUN_FAILURES:
        return float("nan")


def compare_published(tables: tuple[PublishedTable, ...], model, polytope: Polytope | None,
                      physical: pd.DataFrame | None, centers: dict[str, np.ndarray]) -> PublishedComparison:
    """Each published value against the data: the quantity in the model's parameters, its exact
    interval [lo, hi] over ``polytope`` (absent without one) and whether the value is inside, the
    physically consistent interval's verdict (``physical``: the physical stage's intervals table;
    only for a quantity that is one parameter), each estimate's centre's difference from the value in
    % (``centers``: label -> (r,)), and ``from bound``: the factor of the chosen bound from which the
    data allow the value (:func:`smallest_factor`); per table, the same for all its values at once."""
    rows, summary = [], []
    names = tuple(model.param_names)
    for t in tables:
        C, v, first = [], [], len(rows)
        for name, value in t.entries:
            expr = t.names.get(name, name)
            c = functional(expr, model)
            row = {"published": t.label, "name": name, "value": value}
            if c is None:
                rows.append({**row, "quantity": expr, "inside exact": "not comparable (no base parameter "
                                                                      "combination)"})
                continue
            C.append(c)
            v.append(value)
            row["quantity"] = _quantity(c, names)
            for label, center in centers.items():
                row[f"{label} - value [%]"] = 100 * (c @ center - value) / abs(value) if value else np.nan
            if polytope is not None:
                lo, hi = -polytope.support(-c), polytope.support(c)
                inside = lo - 1e-9 * max(1.0, abs(lo)) <= value <= hi + 1e-9 * max(1.0, abs(hi))
                row.update({"exact lo": lo, "exact hi": hi, "inside exact": "yes" if inside else "no",
                            "from bound": _factor(polytope, c, value)})
            if physical is not None and row["quantity"] in physical.index:
                ph = physical.loc[row["quantity"]]
                row["inside physical"] = "yes" if ph["phys_lo"] - 1e-9 <= value <= ph["phys_hi"] + 1e-9 else "no"
            rows.append(row)
        mine = rows[first:]
        summary.append({"published": t.label, "source": t.source, "values": len(t.entries), "comparable": len(C),
                        "inside exact": sum(r.get("inside exact") == "yes" for r in mine),
                        "physical checked": sum("inside physical" in r for r in mine),
                        "inside physical": sum(r.get("inside physical") == "yes" for r in mine),
                        "together from": (_factor(polytope, np.array(C), np.array(v))
                                          if polytope is not None and C else np.nan)})
    return PublishedComparison(pd.DataFrame(rows), pd.DataFrame(summary))
