"""Training-loader throughput: windows per second reading EXR files directly vs the decoded cache.

    python benchmarks/bench_loader.py [--data DIR] [--window 4] [--crop 64 64] [--epochs 5] [--workers 0]

Without ``--data`` a synthetic dataset is generated in a temporary directory.
Each mode iterates a DataLoader over every window for several epochs (new
crops each epoch) and reports the median windows/s; both modes run in the same
process, one after the other, so their ratio is measured side by side.  The
cache build time is reported separately.  Results go to JSON (default
benchmarks/results/loader.json).
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import torch

from mnss_kit.dataset.loader import WindowDataset
from mnss_kit.dataset.synthetic import write_synthetic_sequence
from mnss_kit.fileio import atomic_write_json

DEFAULT_OUT = Path(__file__).resolve().parent / "results" / "loader.json"


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, help="dataset directory (default: a generated synthetic one)")
    p.add_argument("--window", type=int, default=4, help="frames per window")
    p.add_argument("--crop", type=int, nargs=2, default=(64, 64), metavar=("W", "H"), help="LR crop in pixels")
    p.add_argument("--batch", type=int, default=4)
    p.add_argument("--epochs", type=int, default=5, help="timed epochs per mode (median reported)")
    p.add_argument("--workers", type=int, default=0, help="DataLoader worker processes")
    p.add_argument(
        "--torch-threads", type=int, default=1,
        help="torch intra-op threads in the main process (default 1: collating small tensors with OpenMP "
        "threads on a busy machine measures thread contention, not the loader)",
    )
    p.add_argument("--synthetic-size", type=int, nargs=2, default=(160, 96), metavar=("W", "H"), help="LR size of generated data")
    p.add_argument("--synthetic-frames", type=int, default=16, help="frames per generated sequence (two sequences)")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT)
    return p.parse_args(argv)


def make_synthetic(root: Path, size: tuple[int, int], frames: int) -> Path:
    write_synthetic_sequence(root / "pan", lr_size=size, frames=frames, name="pan")
    write_synthetic_sequence(root / "pan_cut", lr_size=size, frames=frames, cut_at=frames // 2, name="pan_cut")
    return root


def time_epochs(ds: WindowDataset, args: argparse.Namespace) -> list[float]:
    """Windows per second of each epoch."""
    rates = []
    for epoch in range(args.epochs):
        ds.set_epoch(epoch)
        loader = torch.utils.data.DataLoader(
            ds, batch_size=args.batch, shuffle=True, num_workers=args.workers, generator=torch.Generator().manual_seed(epoch)
        )
        start = time.perf_counter()
        count = sum(batch["color"].shape[0] for batch in loader)
        rates.append(count / (time.perf_counter() - start))
    return rates


def run(args: argparse.Namespace, data: Path, cache_dir: Path) -> dict:
    common = dict(window=args.window, crop=tuple(args.crop), seed=0, progress=False)
    exr_ds = WindowDataset(data, cache=False, **common)
    start = time.perf_counter()
    WindowDataset(data, cache_dir=cache_dir, **common)  # builds the cache
    build_s = time.perf_counter() - start
    start = time.perf_counter()
    cached_ds = WindowDataset(data, cache_dir=cache_dir, **common)  # finds it
    open_s = time.perf_counter() - start
    uncached = time_epochs(exr_ds, args)
    cached = time_epochs(cached_ds, args)
    seq = exr_ds.sequences[0].meta
    return {
        "dataset": {
            "path": str(data) if args.data else "synthetic (generated)",
            "sequences": len(exr_ds.sequences),
            "windows": len(exr_ds),
            "lr_size": list(seq.lr_size),
            "scale": seq.scale,
            "fingerprint": exr_ds.fingerprint(),
        },
        "uncached": {"windows_per_s_median": statistics.median(uncached), "windows_per_s": uncached},
        "cached": {"windows_per_s_median": statistics.median(cached), "windows_per_s": cached},
        "cached_over_uncached": statistics.median(cached) / statistics.median(uncached),
        "cache_build_s": build_s,
        "cache_open_s": open_s,
    }


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    torch.set_num_threads(args.torch_threads)
    with tempfile.TemporaryDirectory(prefix="bench_loader.") as tmp:
        tmp = Path(tmp)
        data = args.data or make_synthetic(tmp / "data", tuple(args.synthetic_size), args.synthetic_frames)
        result = run(args, data, tmp / "cache")
    record = {
        "benchmark": "loader",
        "params": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
        "machine": {"python": platform.python_version(), "torch": torch.__version__, "cpus": os.cpu_count(), "platform": platform.platform()},
        **result,
    }
    atomic_write_json(args.out, record)
    print(
        f"uncached {result['uncached']['windows_per_s_median']:.1f} windows/s, cached {result['cached']['windows_per_s_median']:.1f} "
        f"windows/s ({result['cached_over_uncached']:.1f}x), cache build {result['cache_build_s']:.2f} s -> {args.out}",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
