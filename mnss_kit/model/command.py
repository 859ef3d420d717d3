"""``mnss-kit models``: the shipped checkpoints and the model config ladder, with their cost."""

from __future__ import annotations

import argparse

HELP = "list shipped checkpoints and model configs with MACs per output pixel"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--configs", action="store_true", help="also list mnss_kit/configs/models/*.yaml with the MACs of each")
    parser.add_argument("--json", action="store_true", help="print the listing as JSON instead of a table")


def run(args: argparse.Namespace) -> int:
    import json

    from .run import checkpoint_rows, config_rows

    rows = checkpoint_rows()
    listing = {"checkpoints": rows, "families": family_rows()}
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
    print("\nFamilies and the scales they take (quality modes such as 1.5x are fractional scales):")
    print(_table([{**r, "fractional": "yes" if r["fractional"] else "no"} for r in listing["families"]],
                 ("family", "fractional", "scales")))
    return 0


def family_rows() -> list[dict]:
    """Per family: whether it takes fractional scales (``ops.scale.INTEGER_SCALE_ONLY`` says why not)."""
    from ..ops.scale import INTEGER_SCALE_ONLY, INTEGER_SCALES, MAX_SCALE, MIN_SCALE
    from .families import FAMILIES

    rows = []
    for name in FAMILIES:
        why = INTEGER_SCALE_ONLY.get(name)
        scales = (f"{', '.join(map(str, INTEGER_SCALES))} only: {why}" if why
                  else f"any in [{MIN_SCALE}, {MAX_SCALE}] (e.g. 1.5, 1.7, 2)")
        rows.append({"family": name, "fractional": why is None, "scales": scales})
    return rows


def _table(rows: list[dict], columns: tuple[str, ...]) -> str:
    cells = [[str(r.get(c, "")) for c in columns] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(columns)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(columns, widths))]
    lines += ["  ".join(v.ljust(w) for v, w in zip(row, widths)) for row in cells]
    return "\n".join(lines)
