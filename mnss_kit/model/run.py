"""The model stage's entry (``mnss-kit models``): what it lists, the shipped checkpoints and the model
config ladder, with their cost."""

from __future__ import annotations


def checkpoint_rows() -> list[dict]:
    from ..zoo import DEFAULT_MODEL
    from .checkpoint import read_record, resolve, shipped_names

    rows = []
    for name in shipped_names():
        record, _ = read_record(name)
        rows.append(
            {
                "name": name,
                "default": name == DEFAULT_MODEL,
                "family": record.get("family"),
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
