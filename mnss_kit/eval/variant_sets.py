"""Held-out sets in the input variants engines send: rendered with another jitter pattern and/or
rewritten by ``mnss-kit data variant``, once, into a work directory.

``VARIANTS`` maps a name to ``(jitter pattern rendered, data variants applied, what it stands for)``.
``RENAMED_VARIANTS`` maps earlier names to today's, for results files written before a rename.
"""

from __future__ import annotations

from pathlib import Path

from ..dataset.variants import ENGINE
from ..ops.jitter import RENAMED_PATTERNS

VARIANTS = {
    "grid": ("grid", [], "the toolkit's own inputs: grid jitter, float colour, depth and motion"),
    "halton": ("halton", [], "Halton (2, 3) jitter, as TAA in most engines"),
    "no_jitter": ("center", [], "no sub-pixel jitter (TAA off, or a capture that drops it)"),
    "no_jitter_ldr8_depth8": ("center", ["ldr8", "depth8"], "no jitter, 8-bit LDR colour, 8-bit depth: a typical game capture"),
    "ldr8": ("grid", ["ldr8"], "8-bit LDR colour"),
    "depth8": ("grid", ["depth8"], "8-bit reversed depth"),
    "motion_noise": ("grid", ["motion_noise"], "motion vectors with 0.25 px Gaussian error"),
    "camera_motion": ("grid", ["camera_motion"], "camera motion only (no per-object motion vectors)"),
    "engine": ("center", list(ENGINE), "as an engine sends it: no jitter, 8-bit LDR colour, 8-bit reversed depth with a "
               "guessed near plane, motion packed in 8-bit pairs, dilated, rigid on skinned objects, absent on some"),
    "engine_halton": ("halton", list(ENGINE), "the engine variant with Halton (2, 3) jitter"),
}
# Earlier variant name -> today's: a variant named after its jitter pattern took the pattern's rename.
RENAMED_VARIANTS = {old: new for old, new in RENAMED_PATTERNS.items() if new in VARIANTS}


def current_variant_names(entries: dict) -> dict:
    """``entries`` (a results file's ``{variant: ...}``) with earlier variant names read as today's,
    in their order; an entry under both names keeps today's."""
    out = {}
    for name, value in entries.items():
        new = RENAMED_VARIANTS.get(name, name)
        if new == name or new not in entries:
            out[new] = value
    return out


def variant_set(name: str, config: str, work: Path, frames: int, base: Path | None = None, progress: bool = False) -> Path:
    """The render config ``config`` in variant ``name``, its first ``frames`` frames per sequence,
    under ``work/<config>/``.  ``base``: the set already rendered with the grid jitter (default:
    render it too).  Renders resume; a rewritten variant is written atomically, and again when
    its source has since gained sequences or frames."""
    from ..render.config import load_render_config
    from ..render.run import render_dataset

    pattern, applied, _ = VARIANTS[name]
    root = work / config
    source = base if pattern == "grid" and base is not None else _render_dir(root, pattern)
    if source != base:
        render_dataset(load_render_config(config, [f"jitter={pattern}", f"frames={frames}"]), source, progress=progress)
    if not applied:
        return source
    return rewritten(source, root / name, applied)


def rewritten(source: Path, out: Path, applied: list[str]) -> Path:
    """``out``: ``source`` rewritten with the data variants ``applied``, written atomically, and again
    when ``source`` has since gained sequences or frames."""
    from ..dataset.variants import write_variant_dataset

    if not out.is_dir() or _contents(out) != _contents(source):
        write_variant_dataset(source, out, applied, overwrite=True)
    return out


def _render_dir(root: Path, pattern: str) -> Path:
    """``root/render_<pattern>``; a work directory rendered before the pattern was renamed
    (``render_mnss`` for grid) is used as it is, since its frames are the same."""
    path = root / f"render_{pattern}"
    earlier = [root / f"render_{old}" for old, new in RENAMED_PATTERNS.items() if new == pattern]
    return next((d for d in earlier if d.is_dir() and not path.exists()), path)


def _contents(data: Path) -> list[tuple[str, int]]:
    from ..dataset import format as fmt

    return [(seq.name, fmt.read_meta(seq).frame_count) for seq in fmt.find_sequences(data)]
