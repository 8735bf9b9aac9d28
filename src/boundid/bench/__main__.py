"""Run every benchmark module and write its table to reports/benchmarks/."""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import platform
import time
from pathlib import Path

import boundid.bench as pkg


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m boundid.bench", description=__doc__)
    ap.add_argument("--out", default="reports/benchmarks", help="output folder")
    ap.add_argument("--only", nargs="*", help="topics to run (default: all)")
    ap.add_argument("--quick", action="store_true", help="smaller sizes, for a smoke run")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    topics = sorted(m.name[len("bench_"):] for m in pkgutil.iter_modules(pkg.__path__)
                    if m.name.startswith("bench_"))
    for topic in topics:
        if args.only and topic not in args.only:
            continue
        mod = importlib.import_module(f"boundid.bench.bench_{topic}")
        t0 = time.perf_counter()
        df = mod.run(quick=args.quick)
        elapsed = time.perf_counter() - t0
        df.to_csv(out / f"{topic}.csv", index=False)
        md = [f"# Benchmark: {topic}", "", mod.GOALS.strip(), "",
              f"Machine: {platform.machine()}, {platform.processor() or 'cpu'}, "
              f"Python {platform.python_version()}; whole benchmark {elapsed:.1f} s.", "",
              df.to_markdown(index=False, floatfmt=".4g"), ""]
        (out / f"{topic}.md").write_text("\n".join(md))
        print("\n".join(md))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
