"""Data config (``mnss_kit/configs/data/*.yaml``): the sequences ``mnss-kit render`` writes.

    version: 1
    defaults:              # merged into every sequence (a sequence's own keys win)
      lr_size: [320, 180]
      scale: 2
    sequences:
      - name: arena_a      # output sub-directory
        scene: arena       # built-in (arena, town, flight, factory) or a .gltf/.glb/.obj file
        seed: 1
        frames: 90
        camera: auto       # 'auto' (generated from the seed) or a camera-path YAML
        particles: true
        extra_references: [taa, 4x]   # also hr/reference_taa, hr/reference_4x (held-out data)

Paths (scene files, camera paths) are taken as given, then relative to the
config file, then under ``mnss_kit/configs/scenes/``.  ``--set key=value`` overrides a
sequence key in every sequence; ``--set NAME.key=value`` in sequence NAME only.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, fields
from pathlib import Path

from ..config import CONFIG_DIR, apply_overrides, from_dict, read_yaml, resolve_config_path
from ..errors import UserError
from ..ops import jitter as jitter_ops

BUILTIN_SCENES = ("arena", "town", "flight", "factory", "rooms", "rooms_unseen", "garden", "plaza")
SCENE_SUFFIXES = (".gltf", ".glb", ".obj")
EXTRA_REFERENCES = ("taa", "4x")  # the renderer's optional native-AA references
SCENE_CAMERAS = ("auto", "still")  # a built-in scene's own path, moving or held; an imported scene has none


@dataclass
class SequenceConfig:
    name: str
    scene: str
    seed: int = 0
    frames: int = 120
    fps: float = 30.0
    start_time: float = 0.0
    lr_size: tuple[int, int] = (640, 360)
    scale: int = 2
    jitter: str = "mnss"
    hr_samples: int = 16
    camera: str = "auto"  # "auto": the scene's own path; "still": that path held at start_time; or a camera-path YAML
    particles: bool = False
    animated_light: bool = False
    exposure: float = 1.0
    # native-AA references beside the box one: "taa" (hr/reference_taa), "4x" (hr/reference_4x)
    extra_references: tuple[str, ...] = ()

    def __post_init__(self):
        if not re.fullmatch(r"[A-Za-z0-9_.-]+", self.name):
            raise ValueError(f"sequence name '{self.name}' must use letters, digits, '_', '-', '.' only")
        if self.frames < 1 or self.fps <= 0:
            raise ValueError(f"sequence '{self.name}': frames must be >= 1 and fps > 0")
        if min(self.lr_size) < 8 or max(self.lr_size) > 8192:
            raise ValueError(f"sequence '{self.name}': lr_size {list(self.lr_size)} out of range (8..8192)")
        root = math.isqrt(self.hr_samples) if self.hr_samples > 0 else 0
        if self.hr_samples < 1 or root * root != self.hr_samples:
            raise ValueError(f"sequence '{self.name}': hr_samples must be a square (1, 4, 9, 16, 25, ...), got {self.hr_samples}")
        if self.exposure <= 0:
            raise ValueError(f"sequence '{self.name}': exposure must be > 0")
        jitter_ops.period(self.jitter, self.scale)  # raises UserError for a bad pattern or scale
        unknown = [r for r in self.extra_references if r not in EXTRA_REFERENCES]
        if unknown or len(set(self.extra_references)) != len(self.extra_references):
            raise ValueError(f"sequence '{self.name}': extra_references takes each of {', '.join(EXTRA_REFERENCES)} "
                             f"at most once, got {list(self.extra_references)}")

    @property
    def hr_size(self) -> tuple[int, int]:
        return (self.lr_size[0] * self.scale, self.lr_size[1] * self.scale)

    @property
    def is_builtin(self) -> bool:
        return self.scene in BUILTIN_SCENES


SEQUENCE_KEYS = frozenset(f.name for f in fields(SequenceConfig))


@dataclass
class RenderConfig:
    sequences: list[SequenceConfig]
    version: int = 1
    source_dir: str = "."  # directory of the config file, for relative paths (set by the loader)


def load_render_config(name_or_path: str, overrides: list[str] | None = None) -> RenderConfig:
    """Read a data config by path or name (``mnss_kit/configs/data/NAME.yaml``), apply ``--set`` overrides."""
    path = resolve_config_path(name_or_path, "data")
    data = read_yaml(path)
    source = str(path)
    unknown = sorted(set(data) - {"version", "defaults", "sequences"})
    if unknown:
        raise UserError(f"{source}: unknown key '{unknown[0]}' (allowed: defaults, sequences, version)")
    defaults = data.get("defaults") or {}
    sequences = data.get("sequences")
    if not isinstance(defaults, dict):
        raise UserError(f"{source}: 'defaults' must be a mapping")
    if not isinstance(sequences, list) or not sequences:
        raise UserError(f"{source}: 'sequences' must be a non-empty list")
    merged = []
    for i, seq in enumerate(sequences):
        if not isinstance(seq, dict):
            raise UserError(f"{source}: 'sequences[{i}]' must be a mapping")
        merged.append({**defaults, **seq})
    names = [s.get("name") for s in merged]
    for item in overrides or []:
        key = item.split("=", 1)[0]
        head, _, field_name = key.rpartition(".")
        if field_name not in SEQUENCE_KEYS:
            raise UserError(f"{source}: --set {key}: '{field_name}' is not a sequence key (allowed: {', '.join(sorted(SEQUENCE_KEYS))})")
        if head and head not in names:
            raise UserError(f"{source}: --set {key}: no sequence '{head}' (sequences: {', '.join(map(str, names))})")
        if head:
            i = names.index(head)
            merged[i] = apply_overrides(merged[i], [item[len(head) + 1:]])
        else:
            merged = [apply_overrides(s, [item]) for s in merged]
    cfg = from_dict(RenderConfig, {"version": data.get("version", 1), "sequences": merged}, source=source)
    if cfg.version != 1:
        raise UserError(f"{source}: unsupported data config version {cfg.version} (expected 1)")
    dupes = {n for n in names if names.count(n) > 1}
    if dupes:
        raise UserError(f"{source}: duplicate sequence name '{sorted(dupes)[0]}'")
    for seq in cfg.sequences:
        if not seq.is_builtin and Path(seq.scene).suffix.lower() not in SCENE_SUFFIXES:
            raise UserError(f"{source}: sequence '{seq.name}': scene '{seq.scene}' is neither built-in "
                            f"({', '.join(BUILTIN_SCENES)}) nor a {'/'.join(SCENE_SUFFIXES)} file")
        if not seq.is_builtin and seq.camera in SCENE_CAMERAS:
            raise UserError(f"{source}: sequence '{seq.name}': an imported scene needs a camera-path YAML (camera: PATH)")
    cfg.source_dir = str(path.resolve().parent)
    return cfg


def resolve_asset(name: str, cfg: RenderConfig, what: str) -> Path:
    """A scene or camera file: as given, relative to the config, or under ``mnss_kit/configs/scenes/``."""
    for candidate in (Path(name), Path(cfg.source_dir) / name, CONFIG_DIR / "scenes" / name, CONFIG_DIR / "scenes" / f"{name}.yaml"):
        if candidate.is_file():
            return candidate
    raise UserError(f"{what} '{name}' not found (looked relative to the working directory, {cfg.source_dir} and {CONFIG_DIR / 'scenes'})")
