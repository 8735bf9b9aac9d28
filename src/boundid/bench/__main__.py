"""Run the benchmark modules, write each one's table to reports/benchmarks/, then the page.

For each topic: ``<topic>.csv`` (the rows), ``<topic>.json`` (the machine, its load and library
versions, when and how long), ``<topic>.md`` (description, machine, goal verdicts, table); then
``index.html`` judging every goal from the CSVs (:mod:`boundid.bench.page`). ``--page-only``
rebuilds the page from the files without measuring anything.
"""

from __future__ import annotations

import argparse
import importlib
import json
import pkgutil
import time
from datetime import UTC, datetime
from pathlib import Path

import boundid.bench as pkg
from boundid.bench.goals import judge, machine
from boundid.bench.page import verdicts_markdown, write_page


def topics() -> list[str]:
    """The benchmark topics: the modules ``boundid.bench.bench_<topic>``."""
    return sorted(m.name[len("bench_"):] for m in pkgutil.iter_modules(pkg.__path__) if m.name.startswith("bench_"))


def run_topic(topic: str, out: Path, quick: bool) -> str:
    """Run one benchmark module and write its CSV, machine record and Markdown; returns the Markdown."""
    mod = importlib.import_module(f"boundid.bench.bench_{topic}")
    meta = {"started": datetime.now(UTC).astimezone().isoformat(timespec="seconds"), "quick": quick,
            **machine()}
    t0 = time.perf_counter()
    df = mod.run(quick=quick)
    meta["elapsed_s"] = time.perf_counter() - t0
    meta["load_avg_end"] = machine()["load_avg"]
    df.to_csv(out / f"{topic}.csv", index=False)
    (out / f"{topic}.json").write_text(json.dumps(meta, indent=2), encoding="utf-8")
    v = meta["versions"]
    verdicts = [judge(g, df, topic, meta["load_avg"][0]) for g in getattr(mod, "GOAL_CHECKS", ())]
    md = [f"# Benchmark: {topic}", "", mod.GOALS.strip(), "",
          f"Machine: {meta['cpu']}, {meta['cores']} cores, load average {meta['load_avg'][0]:.2f} at the start; "
          f"Python {v['python']}, numpy {v['numpy']}, numba {v['numba']}, highspy {v['highspy']}, clarabel "
          f"{v['clarabel']}; whole benchmark {meta['elapsed_s']:.1f} s" + (" (--quick)." if quick else "."), "",
          "## Goals", "", verdicts_markdown(verdicts) if verdicts else "No goals stated.", "",
          "## Measurements", "", df.to_markdown(index=False, floatfmt=".4g"), ""]
    text = "\n".join(md)
    (out / f"{topic}.md").write_text(text, encoding="utf-8")
    return text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m boundid.bench", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="reports/benchmarks", help="output folder")
    ap.add_argument("--only", nargs="*", help=f"topics to run (default: all of {', '.join(topics())})")
    ap.add_argument("--quick", action="store_true", help="smaller sizes, for a smoke run")
    ap.add_argument("--page-only", action="store_true",
                    help="measure nothing: rebuild index.html from the CSV and JSON files in --out")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if not args.page_only:
        unknown = sorted(set(args.only or ()) - set(topics()))
        if unknown:
            ap.error(f"unknown topic(s) {unknown}; the topics are {topics()}")
        for topic in topics():
            if not args.only or topic in args.only:
                print(run_topic(topic, out, args.quick))
    print(write_page(out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
