"""``mnss-kit models``: the shipped checkpoints and the model config ladder, with their cost."""

from __future__ import annotations

import argparse

HELP = "list shipped checkpoints and model configs with MACs per output pixel"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--configs", action="store_true", help="also list mnss_kit/configs/models/*.yaml with the MACs of each")
    parser.add_argument("--json", action="store_true", help="print the listing as JSON instead of a table")


def run(args: argparse.Namespace) -> int:
    import json

    from .listing import checkpoint_rows, config_rows

    rows = checkpoint_rows()
    listing = {"checkpoints": rows}
    if args.configs or not rows:
        listing["configs"] = config_rows()
    if args.json:
        print(json.dumps(listing, indent=2))
        return 0
    if rows:
        print("Shipped checkpoints:")
        shown = [{**r, "default": "yes" if r["default"] else ""} for r in rows]
        print(_table(shown, ("name", "default", "family", "scale", "macs_per_pixel", "params", "path")))
    else:
        print("No checkpoint is shipped yet (mnss_kit/zoo/ is empty); train one with `mnss-kit train`.")
    if "configs" in listing:
        print("\nModel configs (mnss_kit/configs/models/):")
        print(_table(listing["configs"], ("name", "family", "scale", "macs_per_pixel", "npu_macs_per_pixel", "params")))
    return 0


def _table(rows: list[dict], columns: tuple[str, ...]) -> str:
    cells = [[str(r.get(c, "")) for c in columns] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(columns)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(columns, widths))]
    lines += ["  ".join(v.ljust(w) for v, w in zip(row, widths)) for row in cells]
    return "\n".join(lines)
