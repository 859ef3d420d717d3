"""Regenerate the generated blocks of docs/bundle.md from a real export.

Exports a small bundle (the mnss_x2_tiny config with random weights, golden frames from an
analytic synthetic sequence at 64x48) and rewrites every block between
``<!-- BEGIN GENERATED: NAME -->`` and ``<!-- END GENERATED: NAME -->`` in docs/bundle.md:
the file list, the schedule, the boundary tensors, the jitter table, an abridged manifest, and
the resources of the default mnss_x2 config at 1280x720 with their memory.

    python scripts/make_bundle_doc.py
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
from pathlib import Path

import torch

from doc_blocks import replace_block

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "bundle.md"
TEXEL_BYTES = {"rgba16f": 8, "r32f": 4, "rg32f": 8, "rgba8": 4, "rgba32f": 16}
LIST_KEEP = 2


def export_example(root: Path) -> Path:
    from mnss_kit.dataset.synthetic import write_synthetic_sequence
    from mnss_kit.export.run import ExportRequest, export
    from mnss_kit.model import checkpoint
    from mnss_kit.model.config import load_model_config
    from mnss_kit.model.families import build_model, randomise_convs

    torch.manual_seed(0)
    model = randomise_convs(build_model(load_model_config("mnss_x2_tiny")).eval())
    ckpt = checkpoint.save(root / "mnss_x2_tiny.pt", model, {"jitter_pattern": "grid"})
    write_synthetic_sequence(root / "data" / "pan", lr_size=(32, 24), frames=8, name="pan")
    os.chdir(root)  # relative paths, so the manifest example names no temporary directory
    export(ExportRequest(model="mnss_x2_tiny.pt", out=Path("bundle"), resolution="64x48", device="snapdragon_8_gen_1",
                         data=Path("data"), progress=False))
    return root / "bundle"


def table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def files_block(m: dict) -> str:
    rows = [[f"`{name}`", entry["bytes"]] for name, entry in m["files"].items()]
    return table(["file", "bytes"], rows)


def schedule_block(m: dict) -> str:
    rows = []
    for i, step in enumerate(m["schedule"]["steps"]):
        if step["kind"] == "npu":
            io = ", ".join(f"{t} <- {r}" for t, r in step["inputs"].items()) + "; " + ", ".join(f"{t} -> {r}" for t, r in step["outputs"].items())
            rows.append([i, step["label"], f"NPU `{step['model']}`", io, "", ""])
            continue
        binds = ", ".join(f"{k}={v}" for k, v in step["bind"].items())
        frame = ", ".join(k for k, v in step["uniforms"].items() if "frame" in v)
        rows.append([i, step["label"], f"`{step['pass']}`", binds, "x".join(map(str, step["groups"])) + (f" (per-frame: {frame})" if frame else ""),
                     "yes" if step["skip_on_reset"] else ""])
    swaps = "; ".join(" <-> ".join(s["swap"]) for s in m["schedule"]["end_of_frame"])
    return table(["#", "step", "runs", "bindings (shader name = resource)", "workgroups", "skip on reset"], rows) + f"\n\nEnd of frame: swap {swaps}."


def boundary_block(m: dict) -> str:
    rows = []
    for b in m["boundary"]:
        sn, un = b["texture_remap"]["snorm8"], b["texture_remap"]["unorm8"]["pieces"]
        rows.append([
            b["role"], f"`{b['tensor']}`", b["direction"], b["shape"], b["scale"], b["zero_point"],
            f"r = {sn['real_from_texel']['multiply']:.6g} v + {sn['real_from_texel']['add']:.6g}",
            f"r = {un[0]['real_from_texel']['multiply']:.6g} v + {un[0]['real_from_texel']['add']:.6g} (byte <= 127), "
            f"r = {un[1]['real_from_texel']['multiply']:.6g} v + {un[1]['real_from_texel']['add']:.6g} (byte >= 128)",
        ])
    return table(["role", "tensor", "direction", "shape (NHWC)", "scale", "zero point", "SNORM8 read", "UNORM8 read"], rows)


def jitter_block(m: dict) -> str:
    rows = [[e["index"], f"({e['offset'][0]:+.4f}, {e['offset'][1]:+.4f})", tuple(e["subpixel"])] for e in m["jitter"]["sequence"]]
    return f"Pattern `{m['jitter']['pattern']}`, x{m['scale']}, period {m['jitter']['period']}:\n\n" + table(["frame", "offset (LR px)", "subpixel (dx, dy)"], rows)


def abridge(value, depth: int = 0):
    """The manifest with long lists and tables cut to their first entries (marked)."""
    if isinstance(value, list) and len(value) > LIST_KEEP and not all(isinstance(v, (int, float)) for v in value):
        return [abridge(v, depth + 1) for v in value[:LIST_KEEP]] + [f"... {len(value) - LIST_KEEP} more"]
    if isinstance(value, list) and len(value) > 8:
        return value[:4] + [f"... {len(value) - 4} more"]
    if isinstance(value, dict):
        items = list(value.items())
        if depth >= 1 and len(items) > 12:
            kept = dict((k, abridge(v, depth + 1)) for k, v in items[:LIST_KEEP])
            kept["..."] = f"{len(items) - LIST_KEEP} more"
            return kept
        return {k: abridge(v, depth + 1) for k, v in items}
    return value


def compact_json(value, indent: int = 0, width: int = 110, prefix: int = 0) -> str:
    """JSON with every list or object that fits on its line (after ``prefix`` characters of key) written on one line."""
    flat = json.dumps(value)
    if indent + prefix + len(flat) <= width or not isinstance(value, (dict, list)) or not value:
        return flat
    pad, inner = " " * indent, " " * (indent + 2)
    if isinstance(value, list):
        items = [inner + compact_json(v, indent + 2, width) for v in value]
        return "[\n" + ",\n".join(items) + "\n" + pad + "]"
    items = [f"{inner}{json.dumps(k)}: {compact_json(v, indent + 2, width, len(json.dumps(k)) + 2)}" for k, v in value.items()]
    return "{\n" + ",\n".join(items) + "\n" + pad + "}"


def manifest_block(m: dict) -> str:
    m = dict(m)
    m["placement"] = {k: m["placement"][k] for k in ("device", "mode", "resolution", "estimated_frame_ms")} | {"...": "stages, boundary, handoffs, notes"}
    return "```json\n" + compact_json(abridge(m)) + "\n```"


def resources_block() -> str:
    from mnss_kit.model.mnss.gpu_plan import resources
    from mnss_kit.model.mnss.gpu_stage import GpuStage
    from mnss_kit.model.config import load_model_config
    from mnss_kit.model.families import build_model

    config = load_model_config("mnss_x2")
    state = {k: v.numpy() for k, v in build_model(config).state_dict().items()}
    rows, total = [], 0
    for r in resources(GpuStage.from_model(config, state), (640, 360)):
        if r["kind"] == "buffer":
            nbytes, what = r["bytes"], f"buffer, {r['words']} uint words"
        else:
            nbytes = r["size"][0] * r["size"][1] * TEXEL_BYTES[r["format"]] * r.get("layers", 1)
            what = f"{r['kind']} {r['size'][0]}x{r['size'][1]}" + (f"x{r['layers']}" if "layers" in r else "") + f" {r['format']}"
        total += nbytes
        rows.append([f"`{r['name']}`", r["role"], what, f"{nbytes / 2**20:.2f}", r["description"]])
    return (table(["resource", "role", "allocation", "MiB", "what"], rows)
            + f"\n\nTotal {total / 2**20:.1f} MiB (mnss_x2 config, 1280x720 output; the engine's own colour, depth and motion included).")


def main() -> int:
    from mnss_kit.fileio import atomic_write_text

    with tempfile.TemporaryDirectory(prefix="bundle-doc-") as tmp:
        bundle = export_example(Path(tmp))
        manifest = json.loads((bundle / "manifest.json").read_text())
    text = DOC.read_text()
    blocks = {
        "files": files_block(manifest),
        "schedule": schedule_block(manifest),
        "boundary": boundary_block(manifest),
        "jitter": jitter_block(manifest),
        "resources": resources_block(),
        "manifest": manifest_block(manifest),
    }
    for name, body in blocks.items():
        text = replace_block(text, name, body, DOC)
    atomic_write_text(DOC, text)
    print(f"updated {DOC.relative_to(ROOT)} ({', '.join(blocks)})", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
