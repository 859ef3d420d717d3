"""The ntaau family's GPU side of a bundle: shaders used, resources, frame schedule.

Per frame: ``taau_reproject_pass`` (the previous uncorrected blend and its weight warped to this frame;
weight 0 on a reset), ``taau_pack_pass`` (the int8 NPU input at LR), the NPU steering net,
``taau_accumulate_pass`` (the steered TAAU blend: display and the next history) and, when the net
steers a display filter, ``taau_filter_pass`` (the display again: the blend filtered, plus the
correction).  No learned weights run on the GPU.  The building blocks are :mod:`mnss_kit.gpu.plan`'s.
"""

from __future__ import annotations

import numpy as np

from ...gpu import passes as P
from ...gpu.plan import const, pass_entries, per_frame, quantize_uniforms, step, word_count, texture, boundary_buffer
from ..taau import TAAUParams
from .config import NTAAUConfig

PASSES_USED = ("taau_reproject_pass", "taau_pack_pass", "taau_accumulate_pass")
FILTER_PASS = "taau_filter_pass"


def passes_used(config: NTAAUConfig) -> set[str]:
    return set(PASSES_USED) | ({FILTER_PASS} if config.filter_bound > 0 else set())


def bundle_gpu_plan(config: NTAAUConfig, state_dict: dict, lr_size: tuple[int, int], npu: dict, profile: str) -> dict:
    """The family record's ``gpu_plan``: passes, weight blocks (none), resources and schedule."""
    return {"passes": pass_entries(passes_used(config)), "weights": [], "resources": resources(config, lr_size),
            "schedule": schedule(config, lr_size, npu, profile)}


def input_words(config: NTAAUConfig, lr_size: tuple[int, int]) -> int:
    """32-bit words of the int8 NHWC (1, h, w, 3 + 5 s^2) NPU input."""
    return -(-lr_size[0] * lr_size[1] * config.npu_input_channels() // 4)



def resources(config: NTAAUConfig, lr_size: tuple[int, int]) -> list[dict]:
    """Every texture and buffer a phone keeps for the schedule.  Sizes are ``[width, height]``."""
    w, h = lr_size
    hr, lr = [w * config.scale, h * config.scale], [w, h]
    return [
        texture("color", lr, P.INPUT_FORMATS["color"], "input", "jittered LR colour, display values in [0, 1]", 3),
        texture("motion", lr, P.INPUT_FORMATS["motion"], "input", "LR motion in LR pixels, pointing to the previous frame", 2),
        texture("history", hr, P.HISTORY_FORMAT, "state", "the previous blend before the correction (rgb) and its accumulated weight (a)", 4),
        texture("reprojected", hr, "rgba16f", "intermediate", "the history warped to this frame (YCoCg) and its weight", 4),
        boundary_buffer("npu_input", input_words(config, lr_size), "int8 NHWC (1, h, w, 3 + 5 s^2) NPU input at LR, 4 bytes per word, "
             "little-endian"),
        boundary_buffer("npu_output", word_count(lr_size, config.scale, config.steer_channels()),
             f"int8 NHWC (1, H, W, {config.steer_channels()}) raw steering from the NPU, 4 bytes per word, little-endian"),
        texture("display", hr, P.DISPLAY_FORMAT, "output", "the frame to show (8-bit codes)", 3),
    ]


def schedule(config: NTAAUConfig, lr_size: tuple[int, int], npu: dict, profile: str) -> dict:
    """The per-frame steps.  ``npu``: ``{"model", "input", "output", "input_q", "output_q"}``."""
    s = config.scale
    params = TAAUParams(alpha=config.alpha)
    a = dict(lr_size=lr_size, scale=s)
    words = input_words(config, lr_size)
    out_scale, out_zp = npu["output_q"]
    dequantize = {"u_q_scale": const(float(np.float32(out_scale))), "u_q_zero_point": const(int(out_zp))}
    steps = [
        step("taau_reproject_pass", "reproject history", "taau_gather",
             {"history": "history", "motion": "motion", "reprojected": "reprojected"},
             {"u_scale": const(s), "u_reset": per_frame("reset"), "u_blur_penalty": const(params.blur_penalty)}, **a),
        step("taau_pack_pass", "steering features + pack", "taau_gather",
             {"color": "color", "reprojected": "reprojected", "npu_input": "npu_input"},
             {"u_scale": const(s), "u_max_weight": const(params.max_weight), "u_word_count": const(words),
              **quantize_uniforms(*npu["input_q"], profile)}, words=words, **a),
        {"kind": "npu", "label": "steering net", "stage": "steer", "model": npu["model"],
         "inputs": {npu["input"]: "npu_input"}, "outputs": {npu["output"]: "npu_output"}},
        step("taau_accumulate_pass", "steered accumulation", "taau_accumulate",
             {"npu_output": "npu_output", "color": "color", "reprojected": "reprojected", "motion": "motion",
              "history": "history", "display": "display"},
             {"u_scale": const(s), "u_steer_channels": const(config.steer_channels()), "u_jitter": per_frame("offset"),
              **dequantize, "u_correction_bound": const(config.correction_bound), "u_box_bound": const(config.box_bound),
              "u_history_gain_min": const(config.history_gain_min), "u_still_motion_px": const(config.still_motion_px),
              "u_sample_sigma": const(params.sample_sigma), "u_prior_weight": const(params.prior_weight),
              "u_max_weight": const(params.max_weight)}, **a),
    ]
    if config.filter_bound > 0:
        steps.append(step(FILTER_PASS, "display filter", "taau_accumulate",
                          {"npu_output": "npu_output", "history": "history", "motion": "motion", "display": "display"},
                          {"u_scale": const(s), **dequantize, "u_correction_bound": const(config.correction_bound),
                           "u_filter_bound": const(config.filter_bound), "u_filter_falloff": const(config.filter_falloff)},
                          **a))
    return {
        "steps": steps,
        "end_of_frame": [],
        "reset": "on a reset frame taau_reproject_pass gets u_reset = 1: the history keeps zero weight",
        "barriers": "glMemoryBarrier between GPU steps; around the NPU step the GPU's writes to npu_input must be visible "
                    "to the NPU, and the NPU's npu_output to the GPU (fence)",
    }
