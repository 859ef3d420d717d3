#!/usr/bin/env python
"""How far the FSR2-class upscaler and TAAU converge on a rendered static camera, against the
16-sample box reference: the whole frame, and the pixels that never move (the camera is still,
people and particles pass), beside the native TAA frame of the same pixels.  Prints the table
that docs/fsr2.md quotes.

    python scripts/studies/fsr2_static.py --work W     # renders W/town_static_{halton,grid} once

The scene is test_x2's town_static (town, seed 104) rendered with Halton (2, 3) jitter, FSR2's own,
and with the grid pattern, whose samples sit at HR pixel centres.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

FRAMES = 48
SHOWN_FRAMES = (15, 31, 47)
MOVING_MARGIN_PX = 3  # filters reach this far across the edge of anything that moves
CONFIG = """version: 1
defaults: {{lr_size: [320, 180], scale: 2, hr_samples: 16, extra_references: [taa], fps: 30, frames: {frames}}}
sequences:
  - {{name: town_static_halton, scene: town, seed: 104, camera: town_static.yaml, particles: true, jitter: halton}}
  - {{name: town_static_grid, scene: town, seed: 104, camera: town_static.yaml, particles: true, jitter: grid}}
"""


def render(work: Path) -> Path:
    from mnss_kit.render.config import load_render_config
    from mnss_kit.render.run import render_dataset

    config = work / "static_study.yaml"  # not town_static.yaml: cameras are looked up beside the config
    config.parent.mkdir(parents=True, exist_ok=True)
    config.write_text(CONFIG.format(frames=FRAMES))
    data = work / "data"
    render_dataset(load_render_config(str(config), []), data, progress=True)
    return data


def still_mask(frames) -> np.ndarray:
    """Pixels that no frame's HR motion moves, shrunk by MOVING_MARGIN_PX."""
    from scipy.ndimage import binary_dilation

    moving = np.zeros(frames[0].reference.shape[:2], bool)
    for frame in frames:
        moving |= np.abs(frame.hr_motion).max(-1) > 1e-4
    return ~binary_dilation(moving, iterations=MOVING_MARGIN_PX)


def psnr(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None) -> float:
    """``metrics.psnr`` of the clipped frames, over the ``mask`` pixels when given."""
    from mnss_kit.metrics.psnr import psnr as image_psnr

    a, b = np.clip(a, 0, 1), np.clip(b, 0, 1)
    return image_psnr(a, b) if mask is None else image_psnr(a[mask], b[mask])


def outputs(method, frames) -> list[np.ndarray]:
    state, result = None, []
    with torch.no_grad():
        for frame in frames:
            y, _, state = method(frame.inputs, state)
            result.append(y[0].permute(1, 2, 0).numpy())
    return result


def study(seq: Path) -> list[str]:
    from mnss_kit.dataset import format as fmt
    from mnss_kit.eval.baselines import baseline_methods
    from mnss_kit.eval.frames import iter_frames

    meta = fmt.read_meta(seq)
    frames = list(iter_frames(seq, meta))
    taa = [f.reference for f in iter_frames(seq, meta, reference="taa")]
    still = still_mask(frames)
    rows = []
    for name, method in baseline_methods(2, ["taau", "fsr2"]).items():
        out = outputs(method, frames)
        rows.append((name, out))
    rows.append(("native TAA (HR)", taa))
    lines = [f"{seq.name}: {still.mean():.0%} of pixels never move"]
    for name, out in rows:
        whole = " / ".join(f"{psnr(out[t], frames[t].reference):.2f}" for t in SHOWN_FRAMES)
        static = " / ".join(f"{psnr(out[t], frames[t].reference, still):.2f}" for t in SHOWN_FRAMES)
        lines.append(f"| {seq.name} | {name} | {whole} | {static} |")
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, required=True, help="where the render goes (kept for reruns)")
    args = parser.parse_args()
    data = render(args.work)
    frames = ", ".join(str(t) for t in SHOWN_FRAMES)
    print(f"| sequence | method | PSNR at frames {frames}, whole frame | the same, pixels that never move |")
    print("|---|---|---|---|")
    for name in ("town_static_halton", "town_static_grid"):
        lines = study(data / name)
        print("\n".join(lines[1:]))
        print(lines[0], file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
