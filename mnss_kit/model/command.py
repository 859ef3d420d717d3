"""``mnss-kit models``: the shipped checkpoints and the model config ladder, with their cost."""

from __future__ import annotations

import argparse

HELP = "list shipped checkpoints and model configs with MACs per output pixel"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--configs", action="store_true", help="also list configs/models/*.yaml with the MACs of each")
    parser.add_argument("--json", action="store_true", help="print the listing as JSON instead of a table")


def run(args: argparse.Namespace) -> int:
    import json

    rows = checkpoint_rows()
    listing = {"checkpoints": rows}
    if args.configs or not rows:
        listing["configs"] = config_rows()
    if args.json:
        print(json.dumps(listing, indent=2))
        return 0
    if rows:
        print("Shipped checkpoints:")
        print(_table(rows, ("name", "scale", "macs_per_pixel", "params", "path")))
    else:
        print("No checkpoint is shipped yet (mnss_kit/zoo/ is empty); train one with `mnss-kit train`.")
    if "configs" in listing:
        print("\nModel configs (configs/models/):")
        print(_table(listing["configs"], ("name", "family", "scale", "macs_per_pixel", "npu_macs_per_pixel", "params")))
    return 0


def checkpoint_rows() -> list[dict]:
    from .checkpoint import read_record, resolve, shipped_names

    rows = []
    for name in shipped_names():
        record, _ = read_record(name)
        rows.append(
            {
                "name": name,
                "scale": record.get("scale"),
                "macs_per_pixel": round(record.get("macs_per_pixel") or 0),
                "params": record.get("params"),
                "path": str(resolve(name)),
            }
        )
    return rows


def config_rows() -> list[dict]:
    from .config import config_names, load_model_config
    from .families import build_model
    from .macs import count_macs

    rows = []
    for name in config_names():
        config = load_model_config(name)
        report = count_macs(build_model(config))
        rows.append(
            {
                "name": name,
                "family": config.family,
                "scale": config.scale,
                "macs_per_pixel": round(report.total),
                "npu_macs_per_pixel": round(report.by_placement("npu")),
                "params": report.params,
            }
        )
    return sorted(rows, key=lambda r: (r["scale"], r["macs_per_pixel"]))


def _table(rows: list[dict], columns: tuple[str, ...]) -> str:
    cells = [[str(r.get(c, "")) for c in columns] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(columns)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(columns, widths))]
    lines += ["  ".join(v.ljust(w) for v, w in zip(row, widths)) for row in cells]
    return "\n".join(lines)
