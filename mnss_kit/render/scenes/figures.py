"""Articulated figures: rigid limbs on a joint hierarchy, each limb its own instance.

A figure is pelvis -> torso -> head, shoulders -> upper arms -> forearms and hips -> thighs -> shins;
every limb's transform is a pure function of time (a walk or run cycle), so the renderer's motion
vectors are exact per limb and limbs crossing the background disocclude it every frame, as with
the skinned characters of games.  ``STYLES`` holds the gaits; the runner is drawn only by the
held-out ``garden`` scene, so no training config shows it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .. import shapes
from ..mesh import Material, Mesh
from .common import SceneBuilder

WalkPath = Callable[[float], tuple[np.ndarray, float]]  # t -> (feet position (3,), heading degrees)
LimbTransform = Callable[[float], np.ndarray]


@dataclass(frozen=True)
class FigureStyle:
    """Proportions (fractions of ``height``) and gait (degrees, radians per second) of one figure."""

    name: str
    height: float  # metres
    width: float  # shoulder and hip breadth scale
    cadence: float  # gait cycle, radians per second
    hip_swing: float  # thigh swing amplitude
    knee_bend: float  # extra shin flexion at its peak
    arm_swing: float  # upper arm swing amplitude
    elbow_bend: float  # constant forearm flexion plus a swing of half of it
    lean: float  # forward lean of the torso
    bob: float  # vertical bounce, fraction of height
    rounded: bool  # limbs as ellipsoids (True) or boxes


WALKER = FigureStyle("walker", 1.78, 1.0, 5.5, 25.0, 30.0, 28.0, 15.0, 2.0, 0.015, rounded=False)
RUNNER = FigureStyle("runner", 1.62, 0.8, 10.0, 45.0, 85.0, 50.0, 60.0, 12.0, 0.04, rounded=True)
STYLES = {s.name: s for s in (WALKER, RUNNER)}


@dataclass(frozen=True)
class Outfit:
    top: Material  # torso and upper arms
    bottom: Material  # pelvis and legs
    skin: Material  # head and forearms


def limbs(style: FigureStyle, path: WalkPath, outfit: Outfit) -> list[tuple[Mesh, LimbTransform]]:
    """The figure's ``(mesh in joint space, t -> object-to-world)`` pairs, one per rigid limb."""
    h, w = style.height, style.width
    thigh, shin, upper_arm, forearm = 0.25 * h, 0.25 * h, 0.18 * h, 0.17 * h
    hip_y = thigh + shin
    shoulder_y = 0.82 * h - hip_y  # above the pelvis joint

    def root(t: float) -> np.ndarray:
        p, heading = path(t)
        bounce = style.bob * h * abs(math.sin(style.cadence * t))
        return shapes.translate(p[0], p[1] + hip_y + bounce, p[2]) @ shapes.rotate_y(heading)

    def torso(t: float) -> np.ndarray:
        twist = 0.2 * style.arm_swing * math.sin(style.cadence * t)  # shoulders counter the hips
        return root(t) @ shapes.rotate_x(-style.lean) @ shapes.rotate_y(twist)

    def swing(t: float, phase: float) -> float:
        return math.sin(style.cadence * t + phase)

    def thigh_at(side: int, phase: float) -> LimbTransform:
        return lambda t: root(t) @ shapes.translate(side * 0.1 * h * w, 0, 0) @ shapes.rotate_x(-style.hip_swing * swing(t, phase))

    def shin_at(side: int, phase: float) -> LimbTransform:
        upper = thigh_at(side, phase)
        # the knee folds while the leg swings forward (cosine leads the thigh's sine)
        return lambda t: upper(t) @ shapes.translate(0, -thigh, 0) @ shapes.rotate_x(style.knee_bend * max(0.0, swing(t, phase + math.pi / 2)))

    def arm_at(side: int, phase: float) -> LimbTransform:
        return lambda t: torso(t) @ shapes.translate(side * 0.21 * h * w, shoulder_y, 0) @ shapes.rotate_x(-style.arm_swing * swing(t, phase))

    def forearm_at(side: int, phase: float) -> LimbTransform:
        upper = arm_at(side, phase)

        def bend(t: float) -> float:  # the hand lifts most as the arm swings forward
            return style.elbow_bend * (1.0 + 0.5 * swing(t, phase + math.pi / 4))

        return lambda t: upper(t) @ shapes.translate(0, -upper_arm, 0) @ shapes.rotate_x(-bend(t))

    part = _ellipsoid if style.rounded else _block
    parts = [
        (part((0.3 * h * w, 0.12 * h, 0.17 * h), outfit.bottom, 0.0), root),
        (part((0.36 * h * w, shoulder_y + 0.03 * h, 0.19 * h), outfit.top, 0.5), torso),
        (shapes.transform(_ellipsoid((0.11 * h, 0.14 * h, 0.12 * h), outfit.skin, 0.5), shapes.translate(0, shoulder_y + 0.03 * h, 0)), torso),
    ]
    for side, phase in ((-1, 0.0), (1, math.pi)):
        parts += [
            (part((0.11 * h * w, thigh, 0.12 * h), outfit.bottom, -0.5), thigh_at(side, phase)),
            (part((0.09 * h * w, shin, 0.1 * h), outfit.bottom, -0.5), shin_at(side, phase)),
            (part((0.08 * h * w, upper_arm, 0.08 * h), outfit.top, -0.5), arm_at(side, phase + math.pi)),
            (part((0.065 * h * w, forearm, 0.065 * h), outfit.skin, -0.5), forearm_at(side, phase + math.pi)),
        ]
    return parts


def add_figure(b: SceneBuilder, style: FigureStyle, path: WalkPath, outfit: Outfit) -> None:
    for mesh, transform in limbs(style, path, outfit):
        b.animate(mesh, transform)


def _block(size, material: Material, offset: float) -> Mesh:
    """Box of ``size`` whose centre sits ``offset * height`` above its joint (-0.5: hangs below it)."""
    return shapes.transform(shapes.box(size, material, 0.25), shapes.translate(0, offset * size[1], 0))


def _ellipsoid(size, material: Material, offset: float) -> Mesh:
    """Ellipsoid with the axes ``size``, placed like :func:`_block`."""
    sphere = shapes.transform(shapes.sphere(0.5, 6, 10, material), shapes.scale(*size))
    return shapes.transform(sphere, shapes.translate(0, offset * size[1], 0))
