"""The ntaau_lr family's GPU side of a bundle: shaders used, resources, frame schedule.

Per frame: ``taau_reproject_pass`` (ntaau's: the previous blend and its weight warped to this
frame; weight 0 on a reset), ``taau_lr_evidence_pass`` (depth change, motion spread and trust at
LR, from this depth and the last), ``taau_lr_pack_pass`` (the int8 NPU input at LR, padded to an
even size), the NPU steering net, ``taau_lr_accumulate_pass`` (the steering upsampled to HR, the
blend with its fallback: the next history and the display) and, when the net steers a display
filter, ``taau_lr_filter_pass``.  At a fractional scale (a quality mode such as 1.5x) the passes
get ``u_scale`` 0 and map HR texels to LR by the ratio of their textures' sizes, the reprojection
is ``taau_lr_reproject_pass`` (the motion resized to the HR size, times each axis's ratio) and the
filter pass gets the LR size as ``u_lr_size``.  With a detail branch (``model.detail``, integer
scales) the pack pass writes its ``s * s`` input channels (``u_detail`` 1), the NPU output has its
4 patch values after the 6 steering ones (``u_detail_channels`` 4 in the passes that read it), and
the pass that writes the display (the filter pass, else the accumulation) draws the patch
(``u_detail_bound`` > 0).  At the end of the frame ``depth`` and ``prev_depth`` swap: this frame's
depth is the next one's previous depth, without a copy.  No learned weights run on the GPU.
"""

from __future__ import annotations

import numpy as np

from ...gpu import passes as P
from ...gpu.plan import const, pass_entries, per_frame, quantize_uniforms, step, texture, boundary_buffer
from ..taau import TAAUParams
from .config import DETAIL_CHANNELS, NTAAULRConfig

PASSES_USED = ("taau_reproject_pass", "taau_lr_evidence_pass", "taau_lr_pack_pass", "taau_lr_accumulate_pass")
FILTER_PASS = "taau_lr_filter_pass"
RATIO_REPROJECT = "taau_lr_reproject_pass"  # the reprojection at a fractional scale


def is_fractional(config: NTAAULRConfig) -> bool:
    return not float(config.scale).is_integer()


def hr_size_of(config: NTAAULRConfig, lr_size, hr_size=None) -> tuple[int, int]:
    """``(W, H)``: ``hr_size`` when given, else ``lr_size`` times an integer scale or ``ops.scale.hr_size_for``."""
    from ...ops.scale import hr_size_for

    if hr_size is not None:
        return int(hr_size[0]), int(hr_size[1])
    return tuple(hr_size_for(lr_size, config.scale))


def passes_used(config: NTAAULRConfig) -> set[str]:
    used = set(PASSES_USED) | ({FILTER_PASS} if config.filter_bound > 0 else set())
    return used - {"taau_reproject_pass"} | {RATIO_REPROJECT} if is_fractional(config) else used


def bundle_gpu_plan(config: NTAAULRConfig, state_dict: dict, lr_size: tuple[int, int], npu: dict, profile: str,
                    hr_size=None) -> dict:
    """The family record's ``gpu_plan``: passes, weight blocks (none), resources and schedule; ``hr_size``
    ``(W, H)`` at a fractional scale (else ``lr_size`` times the scale)."""
    if config.detail and is_fractional(config):
        from ...errors import UserError

        raise UserError(f"model.detail takes integer scales only, so a x{config.scale} detail model cannot be bundled")
    return {"passes": pass_entries(passes_used(config)), "weights": [], "resources": resources(config, lr_size, hr_size),
            "schedule": schedule(config, lr_size, npu, profile, hr_size)}


def npu_size(lr_size: tuple[int, int]) -> tuple[int, int]:
    """``[width, height]`` of the NPU tensors: the LR size rounded up to even (the net halves it once)."""
    w, h = lr_size
    return w + w % 2, h + h % 2


def tensor_words(lr_size: tuple[int, int], channels: int) -> int:
    """32-bit words of an int8 NHWC (1, h', w', ``channels``) tensor at the even LR size."""
    w, h = npu_size(lr_size)
    return -(-w * h * channels // 4)



def resources(config: NTAAULRConfig, lr_size: tuple[int, int], hr_size=None) -> list[dict]:
    """Every texture and buffer a phone keeps for the schedule.  Sizes are ``[width, height]``."""
    w, h = lr_size
    hr, lr = list(hr_size_of(config, lr_size, hr_size)), [w, h]
    return [
        texture("color", lr, P.INPUT_FORMATS["color"], "input", "jittered LR colour, display values in [0, 1]", 3),
        texture("depth", lr, P.INPUT_FORMATS["depth"], "input", "LR depth, linear in [0, 1]; swaps with prev_depth at the end of "
             "the frame", 1),
        texture("motion", lr, P.INPUT_FORMATS["motion"], "input", "LR motion in LR pixels, pointing to the previous frame", 2),
        texture("prev_depth", lr, P.INPUT_FORMATS["depth"], "state", "the previous frame's depth (the depth texture of the last "
             "frame)", 1),
        texture("history", hr, P.HISTORY_FORMAT, "state", "the previous blend (rgb) and its accumulated weight (a)", 4),
        texture("reprojected", hr, "rgba16f", "intermediate", "the history warped to this frame (YCoCg) and its weight", 4),
        texture("evidence", lr, "rgba32f", "intermediate", "depth change, motion spread, trust at LR", 4),
        boundary_buffer("npu_input", tensor_words(lr_size, config.npu_input_channels()), f"int8 NHWC (1, h', w', "
             f"{config.npu_input_channels()}) NPU input at the LR size rounded "
             "up to even, 4 bytes per word, little-endian"),
        boundary_buffer("npu_output", tensor_words(lr_size, config.steer_channels()),
             f"int8 NHWC (1, h', w', {config.steer_channels()}) raw steering at LR from the NPU"
             f"{' (then the detail patch)' if config.detail else ''}, 4 bytes per word, little-endian"),
        texture("display", hr, P.DISPLAY_FORMAT, "output", "the frame to show (8-bit codes)", 3),
    ]


def schedule(config: NTAAULRConfig, lr_size: tuple[int, int], npu: dict, profile: str, hr_size=None) -> dict:
    """The per-frame steps.  ``npu``: ``{"model", "input", "output", "input_q", "output_q"}``."""
    fractional = is_fractional(config)
    s = 0 if fractional else config.scale  # u_scale 0: the passes map HR to LR by their textures' sizes
    params = TAAUParams(alpha=config.alpha)
    a = dict(lr_size=lr_size, scale=s)
    if fractional:
        a["hr_size"] = hr_size_of(config, lr_size, hr_size)
    reproject_uniforms = {"u_reset": per_frame("reset"), "u_blur_penalty": const(params.blur_penalty)}
    words = tensor_words(lr_size, config.npu_input_channels())
    out_scale, out_zp = npu["output_q"]
    dequantize = {"u_q_scale": const(float(np.float32(out_scale))), "u_q_zero_point": const(int(out_zp)),
                  "u_detail_channels": const(DETAIL_CHANNELS if config.detail else 0)}
    # the pass that writes the display draws the detail patch: the filter pass, else the accumulation
    detail_bound = float(config.detail_bound) if config.detail else 0.0
    filtered = config.filter_bound > 0
    steps = [
        step(RATIO_REPROJECT, "reproject history", "lr_gather",
             {"history": "history", "motion": "motion", "reprojected": "reprojected"}, reproject_uniforms, **a)
        if fractional else
        step("taau_reproject_pass", "reproject history", "lr_gather",
             {"history": "history", "motion": "motion", "reprojected": "reprojected"},
             {"u_scale": const(s), **reproject_uniforms}, **a),
        step("taau_lr_evidence_pass", "depth change, motion spread, trust", "lr_gather",
             {"depth": "depth", "prev_depth": "prev_depth", "motion": "motion", "evidence": "evidence"},
             {"u_reset": per_frame("reset"), "u_trust_depth": const(config.trust_depth),
              "u_trust_spread_px": const(config.trust_spread_px)}, **a),
        step("taau_lr_pack_pass", "steering features + pack", "lr_gather",
             {"color": "color", "reprojected": "reprojected", "evidence": "evidence", "npu_input": "npu_input"},
             {"u_scale": const(s), "u_reset": per_frame("reset"), "u_max_weight": const(params.max_weight),
              "u_word_count": const(words),
              # a scale input: the 9th channel's value, 1 / the bundle's scale (float32); 0: 8 channels
              "u_scale_input": const(float(np.float32(1.0 / float(config.scale))) if config.scale_input else 0.0),
              "u_detail": const(int(config.detail)),  # 1: the detail branch's s * s input channels follow
              **quantize_uniforms(*npu["input_q"], profile)}, words=words, **a),
        {"kind": "npu", "label": "steering net", "stage": "steer", "model": npu["model"],
         "inputs": {npu["input"]: "npu_input"}, "outputs": {npu["output"]: "npu_output"}},
        step("taau_lr_accumulate_pass", "steered accumulation", "lr_accumulate",
             {"npu_output": "npu_output", "color": "color", "reprojected": "reprojected", "evidence": "evidence",
              "motion": "motion", "history": "history", "display": "display"},
             {"u_scale": const(s), "u_jitter": per_frame("offset"), **dequantize, "u_box_bound": const(config.box_bound),
              "u_history_gain_min": const(config.history_gain_min), "u_still_motion_px": const(config.still_motion_px),
              "u_sample_sigma": const(params.sample_sigma), "u_prior_weight": const(params.prior_weight),
              "u_max_weight": const(params.max_weight), "u_detail_bound": const(0.0 if filtered else detail_bound)},
             **a),
    ]
    if filtered:
        steps.append(step(FILTER_PASS, "display filter", "lr_accumulate",
                          {"npu_output": "npu_output", "history": "history", "display": "display"},
                          {"u_scale": const(s), "u_lr_size": const([int(v) for v in lr_size]), **dequantize,
                           "u_filter_bound": const(config.filter_bound), "u_detail_bound": const(detail_bound)}, **a))
    return {
        "steps": steps,
        "end_of_frame": [{"swap": ["depth", "prev_depth"]}],
        "reset": "on a reset frame taau_reproject_pass gets u_reset = 1 (the history keeps zero weight) and "
                 "taau_lr_evidence_pass reads this frame's depth for the previous one; taau_lr_pack_pass takes the "
                 "history as zero (the reprojected colour is stale), as the model's state after a cut",
        "barriers": "glMemoryBarrier between GPU steps; around the NPU step the GPU's writes to npu_input must be visible "
                    "to the NPU, and the NPU's npu_output to the GPU (fence)",
    }
