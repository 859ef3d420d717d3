"""Built-in scenes (three modelled on game genres, one industrial interior, furnished rooms from the
installed furniture catalogue in a training and an unseen variant, a held-out garden of alpha-tested
foliage and articulated figures, a training town square of such figures) and the scene-file import path."""

from __future__ import annotations

import dataclasses

from ...errors import UserError
from ..camera import CameraPath
from ..config import SCENE_CAMERAS, RenderConfig, SequenceConfig, resolve_asset
from ..scene import Scene, Sun, static_instances
from . import arena, factory, flight, garden, plaza, rooms, town

BUILDERS = {"arena": arena.build, "town": town.build, "flight": flight.build, "factory": factory.build,
            "rooms": rooms.build, "rooms_unseen": rooms.build_unseen, "garden": garden.build,
            "plaza": plaza.build}


def build_scene(seq: SequenceConfig, cfg: RenderConfig) -> Scene:
    """The scene of one sequence: a built-in one (seeded) or an imported file with its camera path."""
    camera = None if seq.camera in SCENE_CAMERAS else CameraPath.load(resolve_asset(seq.camera, cfg, "camera path"))
    duration = seq.frames / seq.fps
    if seq.is_builtin:
        scene = BUILDERS[seq.scene](seq.seed, duration, seq.start_time, camera, seq.particles, seq.animated_light)
        if seq.camera == "still":  # the scene's own camera held at the first frame: stands where it would stand
            scene = dataclasses.replace(scene, camera=scene.camera.held(seq.start_time))
        return scene
    from ..importers import load_meshes  # glTF/OBJ reader, imported only when needed

    meshes = load_meshes(resolve_asset(seq.scene, cfg, "scene file"))
    if not meshes:
        raise UserError(f"scene file '{seq.scene}' contains no meshes")
    lo = min(float(m.positions.min()) for m in meshes)
    hi = max(float(m.positions.max()) for m in meshes)
    radius = max(hi - lo, 1.0)
    return Scene(seq.scene, meshes, static_instances(meshes), camera, Sun(animated=seq.animated_light),
                 near=max(radius * 1e-4, 0.01), far=radius * 4.0, shadow_radius=radius / 2)
