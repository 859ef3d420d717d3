"""The stress scenarios: each names the failure case it tests and its sequence in ``mnss_kit/configs/data/stress.yaml``.

A scenario's ``events`` are the times (seconds) after which recovery is measured besides the
camera cuts the data flags: the end of a fast pan, where new content has entered the view.
Cases the renderer cannot express are listed in :data:`NOT_COVERED` with the reason, so every
report names them instead of leaving them out.
"""

from __future__ import annotations

from dataclasses import dataclass

DATA_CONFIG = "stress"


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


def scenario(name: str) -> Scenario | None:
    return next((s for s in SCENARIOS if s.name == name), None)
