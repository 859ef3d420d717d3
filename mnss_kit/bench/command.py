"""``mnss-kit bench``: speed against accuracy for every model, in fp32 and int8, with charts."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "bench every shipped and trained model (fp32 and int8) and the baselines: quality vs cost JSON and charts"
DEFAULT_OUT = Path("runs/bench")
DEFAULT_WORK = Path("runs/work")  # shared with ``mnss-kit stress``: data rendered once serves both
BENCH_FILE = "bench.json"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, metavar="DIR",
                        help=f"directory for {BENCH_FILE} and charts/; a path ending in .json names the bench file "
                             "itself, its charts beside it (default: %(default)s, under the working directory)")
    parser.add_argument("--charts", type=Path, help="directory for the PNG charts (default: charts/ beside the bench file)")
    parser.add_argument("--work", type=Path, default=DEFAULT_WORK,
                        help="rendered data sets and bundles, reused between runs (default: %(default)s)")
    parser.add_argument("--models", nargs="+", metavar="MODEL",
                        help="checkpoints or shipped names (default: every shipped checkpoint and runs/*/model.pt)")
    parser.add_argument("--data", type=Path, help="held-out data set (default: render test_x2, or tiny_test with --quick)")
    parser.add_argument("--scale", metavar="S", help="bench only this upscaling factor (2, 3, 4 or a quality mode such as "
                        "1.5, in [1.25, 4]): its models on a held-out set at it "
                        "(default: the --data set's, or every scale that has a model; built-in sets: test_x2, test_x4, "
                        "tiny_test at any)")
    parser.add_argument("--devices", nargs="+", metavar="NAME", help="device profiles (default: every shipped one)")
    parser.add_argument("--quick", action="store_true", help="a shortened run on small sequences (its charts say so)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def bench_file(out: Path) -> Path:
    """The bench JSON ``--out`` names: ``out`` itself when it ends in ``.json``, else ``bench.json`` in it."""
    return out if out.suffix.lower() == ".json" else out / BENCH_FILE


def run(args: argparse.Namespace) -> int:
    from ..fileio import check_output
    from ..ops.scale import parse_scale

    if args.scale is not None:
        args.scale = parse_scale(args.scale, "--scale")  # 0.5, 1.0, nan, 9: one line

    out = bench_file(args.out)
    charts = args.charts or out.parent / "charts"
    for path, kind in ((out, "file"), (charts, "into"), (args.work, "into")):
        check_output(path, kind)

    from .charts import write_charts
    from .run import BenchRequest, run_bench, sections

    doc = run_bench(BenchRequest(out=out, work=args.work, models=args.models, data=args.data, quick=args.quick,
                                 scale=args.scale, devices=args.devices, progress=not args.no_progress))
    written = write_charts(doc, charts)
    for section_name, section in sections(doc):
        for key, r in section["records"].items():
            cpu = (r.get("cpu_ms") or {}).get("xnnpack")
            print(f"{section_name:3s} {key:28s} PSNR {r['psnr']:6.2f}  SSIM {r['ssim']:.4f}  IF-SSIM {r['if_ssim']:.4f}  "
                  f"MACs/px {r['macs_per_pixel']:8.0f}  " + (f"CPU {cpu:7.2f} ms" if cpu is not None else ""))
    print(f"wrote {out} and {len(written)} charts in {charts}")
    return 0
