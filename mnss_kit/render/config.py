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

Scale: ``scale`` is an integer (2, 3, 4) or a quality mode in [1.25, 4] (1.5, 1.7; ``ops.scale``).
A sequence gives its size as ``lr_size`` (the render size; HR is ``lr_size * scale``, rounded half
up per axis at a fractional scale) or as ``hr_size`` (the display size, FSR2's convention: LR is
``round_half_up(hr_size / scale)`` per axis, so ``hr_size: [1280, 720], scale: 1.7`` renders at
753x424).  A sequence or ``--set`` naming one of the two drops the other one inherited from
``defaults``; given both, they must agree.  At an integer scale ``hr_size`` must be divisible.

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
from ..dataset.format import current_pattern  # the on-disk contract: the one reader of renamed patterns
from ..ops import jitter as jitter_ops
from ..ops import scale as scales

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
    lr_size: tuple[int, int] | None = None  # (640, 360) unless hr_size is given
    scale: int | float | str = 2  # an int when integral (2.0 -> 2); a quality mode such as 1.5 otherwise (text: refused clearly)
    jitter: str = "grid"  # ops.jitter.PATTERNS; an earlier spelling (mnss) is read as today's name
    hr_samples: int = 16
    camera: str = "auto"  # "auto": the scene's own path; "still": that path held at start_time; or a camera-path YAML
    particles: bool = False
    animated_light: bool = False
    exposure: float = 1.0
    # native-AA references beside the box one: "taa" (hr/reference_taa), "4x" (hr/reference_4x)
    extra_references: tuple[str, ...] = ()
    # the display size, FSR2's convention (lr_size derived); None: lr_size given (or its default)
    hr_size: tuple[int, int] | None = None

    def __post_init__(self):
        if not re.fullmatch(r"[A-Za-z0-9_.-]+", self.name):
            raise ValueError(f"sequence name '{self.name}' must use letters, digits, '_', '-', '.' only")
        if self.frames < 1 or self.fps <= 0:
            raise ValueError(f"sequence '{self.name}': frames must be >= 1 and fps > 0")
        try:
            self.scale = scales.parse_scale(self.scale)
        except UserError as e:
            raise ValueError(f"sequence '{self.name}': {e}") from None
        self._resolve_sizes()
        root = math.isqrt(self.hr_samples) if self.hr_samples > 0 else 0
        if self.hr_samples < 1 or root * root != self.hr_samples:
            raise ValueError(f"sequence '{self.name}': hr_samples must be a square (1, 4, 9, 16, 25, ...), got {self.hr_samples}")
        if self.exposure <= 0:
            raise ValueError(f"sequence '{self.name}': exposure must be > 0")
        self.jitter = current_pattern(self.jitter)
        try:
            jitter_ops.period(self.jitter, self.scale)  # a UserError for a bad pattern or scale
        except UserError as e:
            raise ValueError(f"sequence '{self.name}': {e}") from None
        unknown = [r for r in self.extra_references if r not in EXTRA_REFERENCES]
        if unknown or len(set(self.extra_references)) != len(self.extra_references):
            raise ValueError(f"sequence '{self.name}': extra_references takes each of {', '.join(EXTRA_REFERENCES)} "
                             f"at most once, got {list(self.extra_references)}")

    def _resolve_sizes(self) -> None:
        """Fill in the size not given: ``lr_size`` from ``hr_size`` (FSR2's convention) or the other way."""
        if self.hr_size is None:
            self.lr_size = tuple(self.lr_size) if self.lr_size is not None else (640, 360)
            self._check_lr_size()
            self.hr_size = scales.hr_size_for(self.lr_size, self.scale)
            return
        hr = tuple(self.hr_size)
        if min(hr) < 10 or max(hr) > 32768:
            raise ValueError(f"sequence '{self.name}': hr_size {list(hr)} out of range (10..32768)")
        if isinstance(self.scale, int) and (hr[0] % self.scale or hr[1] % self.scale):
            raise ValueError(f"sequence '{self.name}': hr_size {list(hr)} is not divisible by the integer scale {self.scale}")
        derived = scales.lr_size_for(hr, self.scale)
        if self.lr_size is not None and tuple(self.lr_size) != derived:
            raise ValueError(f"sequence '{self.name}': lr_size {list(self.lr_size)} and hr_size {list(hr)} disagree at "
                             f"scale {self.scale} (round(hr_size / scale) is {list(derived)}): give one of them")
        self.lr_size, self.hr_size = derived, hr
        self._check_lr_size()

    def _check_lr_size(self) -> None:
        if min(self.lr_size) < 8 or max(self.lr_size) > 8192:
            raise ValueError(f"sequence '{self.name}': lr_size {list(self.lr_size)} out of range (8..8192)")

    @property
    def is_builtin(self) -> bool:
        return self.scene in BUILTIN_SCENES


SEQUENCE_KEYS = frozenset(f.name for f in fields(SequenceConfig))
SIZE_KEYS = frozenset({"lr_size", "hr_size"})


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
        merged.append(_without_other_size({**defaults, **seq}, seq))
    names = [s.get("name") for s in merged]
    for item in overrides or []:
        key = item.split("=", 1)[0]
        head, _, field_name = key.rpartition(".")
        if field_name not in SEQUENCE_KEYS:
            raise UserError(f"{source}: --set {key}: '{field_name}' is not a sequence key (allowed: {', '.join(sorted(SEQUENCE_KEYS))})")
        if head and head not in names:
            raise UserError(f"{source}: --set {key}: no sequence '{head}' (sequences: {', '.join(map(str, names))})")
        sizes_set = {k.rpartition(".")[2] for k in (o.split("=", 1)[0] for o in overrides or [])
                     if k.rpartition(".")[0] in ("", head)} & SIZE_KEYS
        if head:
            i = names.index(head)
            merged[i] = _without_other_size(apply_overrides(merged[i], [item[len(head) + 1:]]), sizes_set)
        else:
            merged = [_without_other_size(apply_overrides(s, [item]), sizes_set) for s in merged]
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


def _without_other_size(merged: dict, named) -> dict:
    """``merged`` less the size key ``named`` does not name, when ``named`` names only one of them:
    a sequence (or ``--set``) giving ``hr_size`` drops an ``lr_size`` from ``defaults``, and the other way."""
    given = SIZE_KEYS & set(named)
    if len(given) == 1:
        (other,) = SIZE_KEYS - given
        merged = {k: v for k, v in merged.items() if k != other}
    return merged


def resolve_asset(name: str, cfg: RenderConfig, what: str) -> Path:
    """A scene or camera file: as given, relative to the config, or under ``mnss_kit/configs/scenes/``."""
    for candidate in (Path(name), Path(cfg.source_dir) / name, CONFIG_DIR / "scenes" / name, CONFIG_DIR / "scenes" / f"{name}.yaml"):
        if candidate.is_file():
            return candidate
    raise UserError(f"{what} '{name}' not found (looked relative to the working directory, {cfg.source_dir} and {CONFIG_DIR / 'scenes'})")
