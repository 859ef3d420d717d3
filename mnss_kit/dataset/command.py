"""``mnss-kit data``: check a dataset, describe it, build its decoded cache, or import a capture into it."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "check, describe, cache or import a dataset (data check | info | cache DIR, data import FORMAT SRC)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from .variants import PRESETS, VARIANTS

    sub = parser.add_subparsers(dest="data_command", metavar="ACTION", required=True)
    p = sub.add_parser(
        "check",
        help="report missing or corrupt files, size/scale mismatches, NaN/Inf and convention mistakes",
        description="Check a dataset (or one sequence) against docs/dataset.md.  Exit 0: no errors "
        "(warnings allowed); 1: errors found; 2: not a dataset.",
    )
    p.add_argument("dir", type=Path, help="dataset directory or one sequence directory")
    p.add_argument("--quick", action="store_true", help="check only meta.json, file presence, EXR headers and sizes")
    p.add_argument("--max-lines", type=int, default=40, metavar="N", help="print at most N problems (default 40)")
    p.add_argument("--family", action="append", default=[], choices=family_names(), metavar="NAME",
                   help=f"a model family the data must serve ({', '.join(family_names())}): a buffer it reads that a "
                   "sequence lacks is an error (repeatable)")
    p.add_argument("--scale", metavar="S", help="the scale every sequence must have: 2, 3, 4 or a quality mode in "
                   "[1.25, 4] such as 1.5 or 1.7 (another scale is an error)")
    p = sub.add_parser("info", help="print sizes, frames, scale and buffers of each sequence")
    p.add_argument("dir", type=Path, help="dataset directory or one sequence directory")
    p = sub.add_parser("cache", help="decode every buffer once into the training cache")
    p.add_argument("dir", type=Path, help="dataset directory or one sequence directory")
    p.add_argument("--cache-dir", type=Path, default=None, help="where to put the cache (default: DIR/.cache)")
    p = sub.add_parser(
        "import",
        help="convert a capture (nss: Arm NSS capture; images: PNG/EXR/NPY files and a mapping) into the dataset format",
        description="Import a capture into the dataset format (docs/dataset.md, Importing captures), recording its "
        "conventions in meta.json, and check the result as data check does; nothing is written to --out on failure.",
    )
    p.add_argument("format", choices=IMPORT_FORMATS, help="nss: an Arm Neural Super Sampling capture; images: "
                   "per-buffer image files described by --mapping")
    p.add_argument("src", type=Path, help="the capture directory")
    p.add_argument("--out", type=Path, required=True, help="output dataset directory (must be empty or absent)")
    p.add_argument("--mapping", default=None, help="images: a mapping YAML, or a name under mnss_kit/configs/import/ (e.g. packed8)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    p = sub.add_parser(
        "variant",
        help="rewrite a dataset's LR inputs as engines send them (8-bit colour and depth, packed, dilated or wrong motion)",
        description="Write a copy of a dataset with input variants applied (mnss_kit/dataset/variants.py says what each "
        "does); the HR buffers are kept.  Un-jittered or Halton input: mnss-kit render CONFIG --set jitter=center.",
    )
    p.add_argument("src", type=Path, help="dataset directory or one sequence directory")
    p.add_argument("--out", type=Path, required=True, help="output dataset directory (must be empty or absent)")
    p.add_argument("--apply", nargs="+", required=True, metavar="VARIANT", help=f"one or more of: {', '.join(VARIANTS)}; or a preset: {', '.join(PRESETS)}")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --out")


IMPORT_FORMATS = ("nss", "images")


def family_names() -> tuple[str, ...]:
    from ..model.families import FAMILIES

    return tuple(FAMILIES)


def run(args: argparse.Namespace) -> int:
    return {"check": run_check, "info": run_info, "cache": run_cache, "import": run_import,
            "variant": run_variant}[args.data_command](args)


def run_variant(args: argparse.Namespace) -> int:
    from ..fileio import check_output
    from .variants import check_variants, write_variant_dataset

    names = check_variants(args.apply)
    check_output(args.out, "directory")
    written = write_variant_dataset(args.src, args.out, names, overwrite=args.overwrite)
    print(f"wrote {len(written)} sequence(s) with {', '.join(names)} into {args.out}")
    return 0


def run_check(args: argparse.Namespace) -> int:
    from .check import check_dataset

    report = check_dataset(args.dir, quick=args.quick, families=tuple(args.family), scale=args.scale)
    ordered = report.errors + report.warnings
    for problem in ordered[: max(args.max_lines, 0)]:
        print(problem.line())
    hidden = len(ordered) - max(args.max_lines, 0)
    if hidden > 0:
        print(f"... and {hidden} more problem(s) (--max-lines to show more)")
    for family, count in report.lacking.items():
        if family not in args.family and not report.errors:  # which models the sound data can train
            print(f"note: {count} sequence(s) lack buffers the {family} family reads (--family {family} lists them)")
    mode = "quick check" if args.quick else "check"
    verdict = "FAILED" if report.errors else "OK"
    print(f"data {mode} {verdict}: {report.summary()}")
    return 1 if report.errors else 0


def run_info(args: argparse.Namespace) -> int:
    from .cache import dataset_fingerprint, frame_files
    from .format import find_sequences, read_meta

    rows = [("sequence", "frames", "lr", "hr", "scale", "jitter", "resets", "colour", "depth", "buffers", "MB")]
    total_frames = total_bytes = 0
    seqs = find_sequences(args.dir)
    for seq in seqs:
        m = read_meta(seq)
        size = sum(st.st_size for _, st in frame_files(seq))
        total_frames += m.frame_count
        total_bytes += size
        depth = m.depth_encoding + (", reverse-Z" if m.reverse_z and m.depth_encoding == "hardware" else "")
        buffers = "; ".join(f"{res}: {' '.join(names)}" for res, names in m.buffers.items())
        rows.append((
            seq.name, str(m.frame_count), "x".join(map(str, m.lr_size)), "x".join(map(str, m.hr_size)), str(m.scale),
            m.jitter_pattern, str(sum(f.reset for f in m.frames)), m.color_space, depth, buffers, f"{size / 1e6:.1f}",
        ))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())
    print(f"total: {len(seqs)} sequence(s), {total_frames} frames, {total_bytes / 1e6:.1f} MB")
    print(f"fingerprint: {dataset_fingerprint(args.dir)}")
    return 0


def run_cache(args: argparse.Namespace) -> int:
    from ..fileio import check_output
    from .cache import default_cache_dir, prepare_caches
    from .format import BUFFERS, find_sequences, read_meta

    seqs = find_sequences(args.dir)
    cache_root = args.cache_dir or default_cache_dir(args.dir)
    check_output(cache_root, "into")
    total = 0
    for seq in seqs:
        meta = read_meta(seq)
        buffers = [(r, b) for r, names in meta.buffers.items() if r in BUFFERS for b in names if b in BUFFERS[r]]
        (cache,) = prepare_caches([seq], buffers, cache_root, metas=[meta])
        total += sum(cache.path(r, b).stat().st_size for r, b in buffers)
    print(f"cache ready: {cache_root} ({len(seqs)} sequence(s), {total / 1e6:.1f} MB)")
    return 0


def run_import(args: argparse.Namespace) -> int:
    from ..errors import UserError
    from ..fileio import check_output

    check_output(args.out, "directory")
    if args.format == "nss":
        from .importers.nss import import_nss

        if args.mapping:
            raise UserError("--mapping is for the images format; an NSS capture describes itself")
        result = import_nss(args.src, args.out, overwrite=args.overwrite)
    else:
        from .importers.images import import_images

        if not args.mapping:
            raise UserError("the images format needs --mapping (a YAML path, or a name under mnss_kit/configs/import/)")
        result = import_images(args.src, args.mapping, args.out, overwrite=args.overwrite)
    for line in result.warnings + result.notes:  # diagnostics on stderr: stdout is the result line
        print(line, file=sys.stderr)
    print(f"imported {result.sequences} sequence(s), {result.frames} frames -> {', '.join(result.datasets)}")
    return 0
