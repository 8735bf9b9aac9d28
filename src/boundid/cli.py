"""The ``boundid`` command: run studies, write reports, benchmark, certify an ellipsoid."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from boundid.errors import BoundidError

DEFAULT_STUDIES = Path("studies")
DEFAULT_REPORTS = Path("reports")


def _progress(quiet: bool):
    from boundid.studies.progress import Progress

    return Progress(enabled=not quiet)


def cmd_run(args) -> int:
    from boundid.report.study_page import write_study_report
    from boundid.studies.config import load_study
    from boundid.studies.runner import run_study

    cfg = load_study(args.study)
    if args.seed is not None:
        cfg = cfg.with_seed(args.seed)
    out = Path(args.out) / cfg.name
    with _progress(args.quiet) as progress:
        result = run_study(cfg, progress=progress)
        page = write_study_report(result, out)
    if not args.quiet:
        print(f"{cfg.name}: {page}")
    return 0


def cmd_report(args) -> int:
    from boundid.report.html import write_index
    from boundid.report.study_page import write_study_report
    from boundid.studies.config import load_study
    from boundid.studies.runner import run_study

    studies = sorted(Path(args.studies).glob("*.toml"))
    if not studies:
        raise BoundidError(f"no study files in {args.studies}/; add a *.toml study there.")
    out = Path(args.out)
    entries = []
    with _progress(args.quiet) as progress:
        for path in studies:
            cfg = load_study(path)
            result = run_study(cfg, progress=progress)
            page = write_study_report(result, out / cfg.name)
            entries.append((cfg.name, cfg.title, page.relative_to(out)))
    index = write_index(out, entries)
    if not args.quiet:
        print(f"index: {index}")
    return 0


def cmd_campaign(args) -> int:
    from boundid.report.campaign_page import write_campaign_page
    from boundid.studies.campaign import run_campaign
    from boundid.studies.config import load_study
    from boundid.studies.scenarios import load_campaign

    cfg = load_study(args.study)
    if args.seed is not None:
        cfg = cfg.with_seed(args.seed)
    spec = load_campaign(cfg)
    replicates = args.replicates if args.replicates is not None else spec.replicates
    workers = args.workers if args.workers is not None else (os.cpu_count() or 1)
    out = Path(args.out) / cfg.name / "campaign"
    with _progress(args.quiet) as progress:
        result = run_campaign(cfg, replicates, spec.select(args.scenarios), out, workers=workers,
                              scheduler=args.scheduler, progress=progress)
    page = write_campaign_page(result)
    if not args.quiet:
        print(f"{cfg.name}: {len(result.computed)} replicates computed, {len(result.skipped)} already done "
              f"({result.elapsed_s:.1f} s); {page}")
    return 0


def cmd_bench(args) -> int:
    from boundid.bench.__main__ import main as bench_main

    return bench_main(["--out", str(Path(args.out) / "benchmarks")] + (["--quick"] if args.quick else []))


def cmd_teach(args) -> int:
    from boundid.teaching import run_lessons

    for page in run_lessons(args.lessons, Path(args.out) / "teaching", fast=args.fast, only=args.only or None):
        print(page)
    return 0


def cmd_list(args) -> int:
    from boundid.studies.registry import ESTIMATORS, REGRESSIONS, ROBOTS

    print("robots:")
    for name, factory in ROBOTS.items():
        model = factory({})
        print(f"  {name:<14} {model.n_joints} joints, {model.p} parameters: {', '.join(model.param_names)}")
    print("estimators:")
    for name, doc in ESTIMATORS.items():
        print(f"  {name:<14} {doc}")
    print("regression models:")
    for name, doc in REGRESSIONS.items():
        print(f"  {name:<18} {doc}")
    return 0


def cmd_certify(args) -> int:
    from boundid.studies.certify_files import certificate_row, certify_files

    cert = certify_files(args.regression, args.ellipsoid, e_max=args.e_max, sdp=not args.no_sdp)
    if args.json:
        row = certificate_row(cert)
        row.update(width_ratio=dict(zip(cert.names, cert.width_ratio.tolist(), strict=True)))
        print(json.dumps(row, indent=2))
    else:
        print(cert.summary())
    return 0 if cert.contains_polytope else 3


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="boundid", description=__doc__)
    sub = ap.add_subparsers(dest="command", required=True)

    p = sub.add_parser("run", help="run one study and write its report")
    p.add_argument("study", help="study file, e.g. studies/h4_obe.toml")
    p.add_argument("--out", default=str(DEFAULT_REPORTS), help="reports folder (default: reports)")
    p.add_argument("--seed", type=int, help="override the study's seed")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("report", help="run every study in studies/ and write reports/ with its index")
    p.add_argument("--studies", default=str(DEFAULT_STUDIES))
    p.add_argument("--out", default=str(DEFAULT_REPORTS))
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=cmd_report)

    p = sub.add_parser(
        "campaign", help="Monte Carlo campaign: every estimator on fresh noise, per scenario (resumable)",
        description="Runs replicates 0..N-1 of each scenario of the study's [campaign] table with Dask and writes "
                    "one Parquet file per (scenario, replicate) to <out>/<study>/campaign/data/ (a re-run skips "
                    "those already there), then the summary page <out>/<study>/campaign/index.html. Campaign mode: "
                    "no SDP ellipsoids and no validation experiment.")
    p.add_argument("study", help="study file, e.g. studies/direct_drive_rls.toml")
    p.add_argument("--replicates", type=int, help="replicates per scenario (default: campaign.replicates)")
    p.add_argument("--scenarios", nargs="+", metavar="NAME", help="scenarios to run (default: all of the study's)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="K",
                       help="local Dask cluster of K single-thread worker processes (default: one per CPU; "
                            "0: in this process, no cluster)")
    where.add_argument("--scheduler", metavar="ADDRESS", help="existing Dask scheduler, e.g. tcp://host:8786")
    p.add_argument("--seed", type=int, help="override the study's seed (the root of every replicate's seed)")
    p.add_argument("--out", default=str(DEFAULT_REPORTS), help="reports folder (default: reports)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=cmd_campaign)

    p = sub.add_parser("bench", help="run the benchmarks, write reports/benchmarks/")
    p.add_argument("--out", default=str(DEFAULT_REPORTS))
    p.add_argument("--quick", action="store_true")
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("teach", help="run the lessons in studies/teaching and write reports/teaching/ handouts")
    p.add_argument("--lessons", default="studies/teaching", help="folder holding lesson*.py scripts")
    p.add_argument("--out", default=str(DEFAULT_REPORTS), help="reports folder (handouts go to <out>/teaching/)")
    p.add_argument("--only", nargs="*", help="run only lessons whose file name contains one of these")
    p.add_argument("--fast", action="store_true", help="small settings (BOUNDID_TEACH_FAST=1), for checks")
    p.set_defaults(func=cmd_teach)

    p = sub.add_parser("list", help="robots, estimators and regression models")
    p.set_defaults(func=cmd_list)

    p = sub.add_parser(
        "certify",
        help="check your own estimator's final ellipsoid against the exact optima of the same data",
        description="Exit code 0 if the ellipsoid contains the exact feasible polytope, 3 if not.",
    )
    p.add_argument("--regression", required=True,
                   help="CSV or Parquet: columns w1..wp, y and e_max (or pass --e-max)")
    p.add_argument("--ellipsoid", required=True,
                   help='JSON {"center": [...], "shape": [[...]]} (or "information" and "sigma"), or CSV '
                        "whose first row is the centre and the next p rows the shape matrix")
    p.add_argument("--e-max", type=float, help="one error bound for every row (instead of an e_max column)")
    p.add_argument("--no-sdp", action="store_true", help="skip the SDP volume comparison (LP bounds only)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=cmd_certify)
    return ap


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except BoundidError as exc:
        print(f"boundid: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("boundid: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
