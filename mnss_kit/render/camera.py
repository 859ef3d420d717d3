"""Camera matrices and keyframed camera paths (the camera-path YAML format).

Matrices are numpy ``(4, 4)`` float64, row-major, acting on column vectors
(``clip = proj @ view @ world``); world space is right-handed with +y up and the
camera looks down its -z axis (OpenGL).  ``proj`` maps depth to OpenGL NDC
[-1, 1], which the default depth range turns into standard [0, 1] hardware
depth ``d = f (z - n) / (z (f - n))``.

Camera-path YAML (``mnss_kit/configs/scenes/*.yaml``)::

    version: 1
    fov: 60                 # default vertical field of view, degrees
    keyframes:              # sorted by time (seconds)
      - {time: 0.0, position: [0, 12, 20], look_at: [0, 0, 0]}
      - {time: 2.5, position: [8, 12, 14], yaw: 30, pitch: -35, fov: 50}
      - {time: 3.0, position: [-20, 2, 5], look_at: [0, 2, 0], cut: true}

A keyframe gives either ``look_at`` or ``yaw``/``pitch`` in degrees (yaw 0 looks
down -z, positive yaw turns left towards -x; positive pitch looks up), and
optionally ``roll`` (degrees) and ``fov``.  Between keyframes the position,
angles and fov follow a cubic Hermite spline with finite-difference
(Catmull-Rom) tangents, so motion is smooth.  ``cut: true`` starts a new shot:
keyframes before it are not used after it, and the first frame at or after
its time is flagged ``reset`` in the dataset.  A frame is also flagged ``reset``
when the camera jumped so far since the previous frame that the point it looks at
lay outside the previous view, or that most of the image moved by more than half
of it (``view_jumped``: a whip pan or a fast pan squeezed into one frame): most of
such a frame has no history, as after a cut.  The point
looked at is ``look_at`` (its distance is interpolated as 1 / distance), or the
view axis at infinity for ``yaw``/``pitch`` keyframes.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config import from_dict, read_yaml
from ..errors import UserError


@dataclass
class KeyframeConfig:
    time: float
    position: tuple[float, float, float]
    look_at: tuple[float, float, float] | None = None
    yaw: float | None = None
    pitch: float | None = None
    roll: float = 0.0
    fov: float | None = None
    cut: bool = False


@dataclass
class CameraPathConfig:
    keyframes: list[KeyframeConfig]
    version: int = 1
    fov: float = 60.0


@dataclass(frozen=True)
class CameraState:
    position: np.ndarray  # (3,) float64
    yaw: float  # degrees
    pitch: float
    roll: float
    fov: float  # vertical, degrees
    inverse_focus: float = 0.0  # 1 / distance of the point looked at (0: the view axis at infinity)

    def view(self) -> np.ndarray:
        return view_matrix(self.position, self.yaw, self.pitch, self.roll)


def yaw_pitch_towards(position, target) -> tuple[float, float]:
    """Angles (degrees) that look from ``position`` at ``target``."""
    d = np.asarray(target, dtype=np.float64) - np.asarray(position, dtype=np.float64)
    length = float(np.linalg.norm(d))
    if length < 1e-9:
        raise UserError("camera keyframe: look_at equals position")
    yaw = math.degrees(math.atan2(-d[0], -d[2]))
    pitch = math.degrees(math.asin(max(-1.0, min(1.0, d[1] / length))))
    return yaw, pitch


def rotation(yaw: float, pitch: float, roll: float = 0.0) -> np.ndarray:
    """``(3, 3)`` camera-to-world rotation: columns are right, up, back."""
    y, p, r = (math.radians(a) for a in (yaw, pitch, roll))
    ry = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
    rx = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
    rz = np.array([[math.cos(r), -math.sin(r), 0], [math.sin(r), math.cos(r), 0], [0, 0, 1]])
    return ry @ rx @ rz


def view_matrix(position, yaw: float, pitch: float, roll: float = 0.0) -> np.ndarray:
    """World -> view ``(4, 4)``."""
    r = rotation(yaw, pitch, roll)
    v = np.eye(4)
    v[:3, :3] = r.T
    v[:3, 3] = -r.T @ np.asarray(position, dtype=np.float64)
    return v


def perspective(fov_y: float, aspect: float, near: float, far: float) -> np.ndarray:
    """OpenGL perspective ``(4, 4)``; ``fov_y`` in degrees, aspect = width / height."""
    f = 1.0 / math.tan(math.radians(fov_y) / 2.0)
    p = np.zeros((4, 4))
    p[0, 0] = f / aspect
    p[1, 1] = f
    p[2, 2] = (far + near) / (near - far)
    p[2, 3] = 2.0 * far * near / (near - far)
    p[3, 2] = -1.0
    return p


def jittered(proj: np.ndarray, jitter, size: tuple[int, int]) -> np.ndarray:
    """``proj`` shifted so pixel centres sample ``centre + jitter``.

    ``jitter`` is ``(jx, jy)`` in pixels of ``size = (width, height)``, +y down
    (``mnss_kit.ops.conventions``).  The image moves by ``-jitter``; NDC y is up,
    hence the sign flip on y.
    """
    jx, jy = float(jitter[0]), float(jitter[1])
    shift = np.eye(4)
    shift[0, 3] = -2.0 * jx / size[0]
    shift[1, 3] = 2.0 * jy / size[1]
    return shift @ proj


JUMP_GRID = 8  # an 8x8 grid of points across the image stands for its pixels in view_jumped


def view_jumped(prev: CameraState, cur: CameraState, aspect: float) -> bool:
    """The camera jumped in one frame: the point ``cur`` looks at lay outside ``prev``'s frame or
    behind it (it turned by more than half the field of view, or moved the point off the image),
    or most of the image moved by more than half its size on an axis (``data check`` refuses such
    motion).  The image is taken at the distance of the point looked at.  The motion of most pixels
    then leaves the image (no history), which is what a cut means to an upscaler."""
    view = cur.view()
    focus = np.append(cur.position * cur.inverse_focus - view[2, :3], cur.inverse_focus)  # homogeneous; w = 0 at infinity
    to_prev = perspective(prev.fov, aspect, 1.0, 2.0) @ prev.view()
    clip = to_prev @ focus
    if clip[3] <= 0.0 or max(abs(clip[0]), abs(clip[1])) > clip[3]:
        return True
    return _share_moved_over_half(to_prev, view, cur.fov, aspect, focus) > 0.5


def _share_moved_over_half(to_prev: np.ndarray, view: np.ndarray, fov: float, aspect: float, focus: np.ndarray) -> float:
    """The share of a JUMP_GRID x JUMP_GRID grid of the image points of the camera at ``view`` (at the
    depth of ``focus``) that lie behind the previous camera or more than half the image away from
    where they are now."""
    ndc = (np.arange(JUMP_GRID) + 0.5) / JUMP_GRID * 2.0 - 1.0
    x, y = (a.ravel() for a in np.meshgrid(ndc, ndc))
    half_y = math.tan(math.radians(fov) / 2.0)
    right, up = view[0, :3], view[1, :3]
    directions = focus[:3, None] + (right[:, None] * (x * half_y * aspect) + up[:, None] * (y * half_y))
    points = np.vstack([directions, np.full(x.size, focus[3])])  # at the focus distance, or at infinity
    clip = to_prev @ points
    ahead = clip[3] > 1e-9
    w = np.where(ahead, clip[3], 1.0)
    moved = (np.abs(clip[0] / w - x) > 1.0) | (np.abs(clip[1] / w - y) > 1.0) | ~ahead
    return float(moved.mean())


class CameraPath:
    """Keyframed camera; ``state(t)`` is a pure function of time."""

    def __init__(self, keyframes: list[KeyframeConfig], default_fov: float = 60.0, source: str = "camera path"):
        if not keyframes:
            raise UserError(f"{source}: needs at least one keyframe")
        times = [k.time for k in keyframes]
        if any(b <= a for a, b in zip(times, times[1:])):
            raise UserError(f"{source}: keyframe times must increase strictly")
        self.shots: list[tuple[float, np.ndarray, np.ndarray]] = []  # (start, times, values)
        shot: list[tuple[float, list[float]]] = []
        for k in keyframes:
            if k.cut and shot:
                self._close(shot)
                shot = []
            shot.append((k.time, self._values(k, default_fov, shot, source)))
        self._close(shot)
        self.cut_times = [s[0] for s in self.shots[1:]]

    @staticmethod
    def _values(k: KeyframeConfig, default_fov: float, shot, source: str) -> list[float]:
        inverse_focus = 0.0
        if k.look_at is not None:
            yaw, pitch = yaw_pitch_towards(k.position, k.look_at)
            inverse_focus = 1.0 / float(np.linalg.norm(np.subtract(k.look_at, k.position)))
        elif k.yaw is not None and k.pitch is not None:
            yaw, pitch = k.yaw, k.pitch
        else:
            raise UserError(f"{source}: keyframe at t={k.time} needs look_at or both yaw and pitch")
        if shot:  # unwrap yaw so interpolation takes the short way round
            prev_yaw = shot[-1][1][3]
            yaw = prev_yaw + (yaw - prev_yaw + 180.0) % 360.0 - 180.0
        fov = default_fov if k.fov is None else k.fov
        if not 1.0 <= fov <= 170.0:
            raise UserError(f"{source}: fov {fov} out of range (1..170 degrees)")
        return [*map(float, k.position), yaw, pitch, float(k.roll), fov, inverse_focus]

    def _close(self, shot) -> None:
        times = np.array([t for t, _ in shot])
        values = np.array([v for _, v in shot])
        self.shots.append((float(times[0]), times, values))

    def _shot(self, t: float) -> tuple[float, np.ndarray, np.ndarray]:
        """The shot playing at time ``t`` (the first one before it starts)."""
        current = self.shots[0]
        for shot in self.shots:
            if t >= shot[0]:
                current = shot
        return current

    def state(self, t: float) -> CameraState:
        _, times, values = self._shot(t)
        v = _hermite(times, values, t)
        return CameraState(v[:3], float(v[3]), float(v[4]), float(v[5]), float(v[6]), max(float(v[7]), 0.0))

    def is_cut(self, t_prev: float, t: float) -> bool:
        """A shot starts in ``(t_prev, t]``."""
        return any(t_prev < c <= t for c in self.cut_times)

    def breaks_history(self, t_prev: float, t: float, aspect: float) -> bool:
        """The frame at ``t`` is a ``reset``: a cut, or a jump out of the view of the frame at ``t_prev``."""
        return self.is_cut(t_prev, t) or view_jumped(self.state(t_prev), self.state(t), aspect)

    def held(self, t: float) -> "CameraPath":
        """This path frozen at time ``t``: a still camera over moving content (no cuts, no jumps)."""
        still = copy.copy(self)  # a shallow copy: only the shots and cuts differ
        _, times, values = self._shot(t)
        still.shots = [(0.0, np.array([0.0]), _hermite(times, values, t)[None, :])]
        still.cut_times = []
        return still

    @classmethod
    def from_config(cls, cfg: CameraPathConfig, source: str = "camera path") -> "CameraPath":
        return cls(cfg.keyframes, cfg.fov, source)

    @classmethod
    def load(cls, path: str | Path) -> "CameraPath":
        cfg = from_dict(CameraPathConfig, read_yaml(path), source=str(path))
        return cls.from_config(cfg, str(path))


def _hermite(times: np.ndarray, values: np.ndarray, t: float) -> np.ndarray:
    """Cubic Hermite through ``values`` (K, D) at ``times`` (K,); clamped outside."""
    if len(times) == 1 or t <= times[0]:
        return values[0].copy()
    if t >= times[-1]:
        return values[-1].copy()
    i = int(np.searchsorted(times, t, side="right")) - 1

    def tangent(j: int) -> np.ndarray:
        a, b = max(j - 1, 0), min(j + 1, len(times) - 1)
        return (values[b] - values[a]) / (times[b] - times[a])

    h = times[i + 1] - times[i]
    s = (t - times[i]) / h
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * values[i] + h10 * h * tangent(i) + h01 * values[i + 1] + h11 * h * tangent(i + 1)
