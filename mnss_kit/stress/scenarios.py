"""The stress scenarios: each names the failure case it tests and its sequence in ``mnss_kit/configs/data/stress.yaml``.

A scenario's ``events`` are the times (seconds) after which recovery is measured besides the
camera cuts the data flags: the end of a fast pan, where new content has entered the view.
Cases the renderer cannot express are listed in :data:`NOT_COVERED` with the reason, so every
report names them instead of leaving them out.  :data:`FAULTS` are bad input frames (NaN colour,
Inf depth) applied in memory to a clean scenario's sequence.
"""

from __future__ import annotations

from dataclasses import dataclass

DATA_CONFIG = "stress"
# the baselines every scenario runs beside the models: the toolkit's TAAU, the FSR2-class upscaler, bicubic
BASELINES = ("bicubic", "taau", "fsr2")


@dataclass(frozen=True)
class Scenario:
    name: str  # also the sequence name in the data config
    case: str  # the failure case, in DESIGN.md's words
    events: tuple[float, ...] = ()  # seconds: recovery is measured from the first frame at or after each


SCENARIOS = (
    Scenario("static_camera", "static camera: history should converge toward the reference (people walk past)"),
    Scenario("fast_pan", "fast camera pan: new content at the screen edge", events=(0.55,)),
    Scenario("camera_cut", "camera cut: history must reset cheaply"),
    Scenario("fast_objects", "disocclusion behind fast objects (ghosting): camera following a running hero"),
    Scenario("thin_geometry", "thin and alpha-tested geometry: chain-link fences, wires, posts"),
    Scenario("particles", "particles without motion vectors or depth (additive sparks)"),
    Scenario("flickering_light", "shading changes motion vectors do not explain: moving shadows, flickering sun"),
    Scenario("high_frequency_texture", "high-frequency textures: bricks, planks, stripes (moire, shimmer)"),
    Scenario("unjittered_input", "un-jittered input (jitter: center): no sub-pixel information to accumulate"),
    Scenario("figure_crossing", "characters whose limbs cross a textured background: a runner and a walker before a "
                                "brick wall, disocclusion every frame (see the disocclusion PSNR)"),
    Scenario("foliage_strafe_cut", "alpha-tested foliage and fences: a low strafe past grass cards and a picket fence, "
                                   "then a camera cut"),
)

NOT_COVERED = {
    "hud_overlay": "HUD-like overlays: the renderer draws no screen-space overlay",
    "alpha_blended_transparency": "alpha-blended transparent surfaces: the renderer skips blended surfaces "
                                  "(only additive particles are drawn)",
}


@dataclass(frozen=True)
class Fault:
    """A bad input frame the renderer cannot produce: the ``buffers`` (frame keys: ``color``,
    ``depth``, ``hr_depth``; those a method's frames hold) of frame ``frame`` of scenario ``source``'s
    sequence are set to ``value`` on ``region`` (x0, y0, x1, y1 as fractions of the frame) after loading, as a shader bug or a sky at infinite depth would write
    it.  (The loader refuses NaN / Inf in files, so the fault is applied in memory.)  Measured: the
    frames after the bad one until every method's PSNR is back within 0.5 dB of the clean run of
    ``source`` (one bad frame must cost one frame: at most 2), and no NaN output on any frame."""
    name: str
    case: str
    source: str
    buffers: tuple[str, ...]
    value: float
    frame: int
    region: tuple[float, float, float, float]


FAULTS = (
    Fault("nan_frame", "one frame of NaN pixels in the LR colour (a shader bug): it must not persist in the history",
          source="fast_objects", buffers=("color",), value=float("nan"), frame=8, region=(0.3, 0.3, 0.6, 0.6)),
    Fault("inf_depth", "one frame of +Inf depth (LR, and HR where a method reads it) on the top third (a sky at "
                       "infinite depth)",
          source="fast_objects", buffers=("depth", "hr_depth"), value=float("inf"), frame=8, region=(0.0, 0.0, 1.0, 0.34)),
)
MAX_RECOVERY_FRAMES = 2  # a bad frame costs itself and at most this many frames after it


def corrupt(frame: dict, fault: Fault) -> dict:
    """A copy of the loader's frame dict (tensors (1, C, h, w)) with ``fault`` applied."""
    out = dict(frame)
    for key in (k for k in fault.buffers if k in frame):
        image = frame[key].clone()
        h, w = image.shape[-2:]
        x0, y0, x1, y1 = fault.region
        image[..., int(y0 * h):int(y1 * h), int(x0 * w):int(x1 * w)] = fault.value
        out[key] = image
    return out


def fault_method(method, fault: Fault):
    """``method`` seeing ``fault`` on its input frame ``fault.frame`` (frames counted from its first call)."""

    def run(frame: dict, state):
        t, inner = (0, None) if state is None else state
        seen = corrupt(frame, fault) if t == fault.frame else frame
        output, aux, inner = method(seen, inner)
        return output, aux, (t + 1, inner)

    return run


def scenario(name: str) -> Scenario | None:
    return next((s for s in SCENARIOS if s.name == name), None)
