"""The GPU passes of the phone runtime as data: entry file, workgroup size, bindings, formats.

This table is what the bundle manifest lists and what the Mesa harness binds by; a test reads
the flattened shaders and checks that every declaration agrees with it.  Per frame the passes
run in the order of :data:`PASS_ORDER` (``schedule.py``); the NPU runs ``model.recon`` between
``insert_pack_pass`` and ``unpack_history_pass``.

Formats are GL sized internal formats.  Image stores in GLSL ES 3.10 accept only rgba32f,
rgba16f, r32f, rgba8(_snorm) and the integer ones, so one-channel float intermediates are r32f.
Inputs the engine renders (colour, depth, motion) are read with ``texelFetch`` and could have
any float format; the formats below are the ones the harness and the emulator assume.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..ops.fsr2 import FSR2Params
from ..ops.runtimes import get_runtime

# Storage formats of the frame inputs and of the state kept between frames.
INPUT_FORMATS = {"color": "rgba16f", "depth": "r32f", "motion": "rg32f"}
HISTORY_FORMAT = "rgba16f"
DISPLAY_FORMAT = "rgba8"
NPU_TENSOR = {"layout": "NHWC", "shape": "(1, H, W, 3)", "dtype": "int8", "packing": "4 bytes per uint32, little-endian"}


@dataclass(frozen=True)
class Binding:
    """One shader resource.  ``kind``: ``sampler`` (texelFetch input), ``image`` (imageStore output)
    or ``buffer`` (std430 SSBO); ``unit`` is its binding point in that kind's namespace."""

    name: str
    kind: str
    unit: int
    format: str  # sized texture format, or the SSBO element type ("vec4[]", "uint[]")
    array: bool = False  # a 2D array texture (channels in layers of four)


@dataclass(frozen=True)
class Pass:
    name: str
    local_size: tuple[int, int, int]
    grid: str  # what one invocation covers: "hr" texel, "lr" texel, "lr_layers" (LR texel x
    #            output layer) or "words" (32-bit word of the NPU tensor)
    bindings: tuple[Binding, ...]
    uniforms: tuple[str, ...]
    # bit for bit the numpy reference on an IEEE float32 GPU; False: a float path through the
    # driver's pow() (BRDF demodulation), within one code of it
    exact: bool = True

    @property
    def entry(self) -> str:
        return f"{self.name}.comp"

    def binding(self, name: str) -> Binding:
        return next(b for b in self.bindings if b.name == name)


def _s(name, unit, fmt, array=False):
    return Binding(name, "sampler", unit, fmt, array)


def _i(name, unit, fmt, array=False):
    return Binding(name, "image", unit, fmt, array)


def _b(name, unit, element):
    return Binding(name, "buffer", unit, element)


PASSES = {
    p.name: p
    for p in (
        Pass(
            "warp_pass", (8, 8, 1), "hr",
            (_s("history", 0, HISTORY_FORMAT), _s("prev_depth", 1, "r32f"), _s("motion", 2, "rg32f"),
             _i("warped", 0, "rgba16f"), _i("warped_depth", 1, "r32f")),
            ("u_scale", "u_subpixel", "u_prev_jitter", "u_prev_subpixel"),
        ),
        Pass(
            "inpaint_weights_pass", (8, 8, 1), "lr",
            (_s("color", 0, "rgba16f"), _s("depth", 1, "r32f"), _s("warped", 2, "rgba16f"),
             _s("warped_depth", 3, "r32f"), _b("weights", 0, "vec4[]"), _i("lr_weight", 0, "r32f")),
            ("u_scale", "u_subpixel", "u_activation"),
        ),
        Pass(
            "inpaint_blend_pass", (8, 8, 1), "hr",
            (_s("color", 0, "rgba16f"), _s("warped", 1, "rgba16f"), _s("lr_weight", 2, "r32f"),
             _i("rectified", 0, "rgba16f")),
            ("u_scale", "u_jitter", "u_subpixel", "u_weight_upsample", "u_reset"),
        ),
        Pass(
            "avgpool_pass", (8, 8, 1), "lr",
            (_s("rectified", 0, "rgba16f"), _s("color", 1, "rgba16f"), _i("aa_input", 0, "rgba16f", array=True)),
            ("u_scale", "u_subpixel", "u_history_at_samples"),
        ),
        Pass(
            "conv3x3_pass", (8, 8, 1), "lr_layers",
            (_s("x", 0, "rgba16f", array=True), _s("residual", 1, "rgba16f"), _b("weights", 0, "vec4[]"),
             _i("y", 0, "rgba16f", array=True)),
            ("u_in_layers", "u_out_layers", "u_epilogue"),
        ),
        Pass(
            "insert_pack_pass", (64, 1, 1), "words",
            (_s("rectified", 0, "rgba16f"), _s("aa", 1, "rgba16f", array=True), _b("npu_input", 0, "uint[]")),
            ("u_scale", "u_subpixel", "u_word_count", "u_q_scale", "u_q_reciprocal", "u_q_use_reciprocal",
             "u_q_rounding", "u_q_zero_point"),
        ),
        Pass(
            "unpack_history_pass", (8, 8, 1), "hr",
            (_b("npu_output", 0, "uint[]"), _i("history", 0, HISTORY_FORMAT), _i("display", 1, DISPLAY_FORMAT)),
            ("u_q_scale", "u_q_zero_point"),
        ),
        Pass(
            "sharpen_pass", (8, 8, 1), "hr",
            (_s("image", 0, HISTORY_FORMAT), _i("display", 0, DISPLAY_FORMAT)),
            ("u_beta",),
        ),
        # FuseSR: demodulation, G-buffer unshuffle + pack, remodulation (conv3x3_pass encodes, warp_pass warps)
        Pass(
            "demodulate_pass", (8, 8, 1), "lr",
            (_s("color", 0, "rgba16f"), _s("fbeta", 1, "rgba16f"), _s("emissive", 2, "rgba16f"),
             _i("l", 0, "rgba16f", array=True)),
            ("u_demodulate",),
            exact=False,
        ),
        Pass(
            "gbuffer_pack_pass", (64, 1, 1), "words",
            (_s("l", 0, "rgba16f", array=True), _s("features", 1, "rgba16f", array=True), _s("warped", 2, "rgba16f"),
             _s("fbeta", 3, "rgba16f"), _s("normal", 4, "rgba16f"), _s("depth", 5, "r32f"), _s("albedo", 6, "rgba16f"),
             _b("npu_input", 0, "uint[]")),
            ("u_scale", "u_features", "u_history", "u_reset", "u_gbuffers", "u_word_count", "u_q_scale", "u_q_reciprocal",
             "u_q_use_reciprocal", "u_q_rounding", "u_q_zero_point"),
        ),
        Pass(
            "remodulate_pass", (8, 8, 1), "hr",
            (_b("npu_output", 0, "uint[]"), _s("fbeta", 0, "rgba16f"), _s("emissive", 1, "rgba16f"),
             _s("l", 2, "rgba16f", array=True), _i("history", 0, HISTORY_FORMAT), _i("display", 1, DISPLAY_FORMAT)),
            ("u_scale", "u_q_scale", "u_q_zero_point", "u_demodulate"),
            exact=False,
        ),
        # ntaau: the TAAU history reprojected, and the steered accumulation (exp and tanh: float paths)
        Pass(
            "taau_reproject_pass", (8, 8, 1), "hr",
            (_s("history", 0, HISTORY_FORMAT), _s("motion", 1, "rg32f"), _i("reprojected", 0, "rgba16f")),
            ("u_scale", "u_reset", "u_blur_penalty"),
            exact=False,
        ),
        Pass(
            "taau_pack_pass", (64, 1, 1), "words",
            (_s("color", 0, "rgba16f"), _s("reprojected", 1, "rgba16f"), _b("npu_input", 0, "uint[]")),
            ("u_scale", "u_max_weight", "u_word_count", "u_q_scale", "u_q_reciprocal", "u_q_use_reciprocal", "u_q_rounding",
             "u_q_zero_point"),
            exact=False,
        ),
        Pass(
            "taau_accumulate_pass", (8, 8, 1), "hr",
            (_b("npu_output", 0, "uint[]"), _s("color", 0, "rgba16f"), _s("reprojected", 1, "rgba16f"),
             _s("motion", 2, "rg32f"), _i("history", 0, HISTORY_FORMAT), _i("display", 1, DISPLAY_FORMAT)),
            ("u_scale", "u_steer_channels", "u_jitter", "u_q_scale", "u_q_zero_point", "u_correction_bound", "u_box_bound",
             "u_history_gain_min", "u_still_motion_px", "u_sample_sigma", "u_prior_weight", "u_max_weight"),
            exact=False,
        ),
        Pass(
            "taau_filter_pass", (8, 8, 1), "hr",
            (_b("npu_output", 0, "uint[]"), _s("history", 0, HISTORY_FORMAT), _s("motion", 1, "rg32f"),
             _i("display", 0, DISPLAY_FORMAT)),
            ("u_scale", "u_q_scale", "u_q_zero_point", "u_correction_bound", "u_filter_bound", "u_filter_falloff"),
            exact=False,
        ),
        # ntaau_lr: the evidence at LR, the LR features packed, the accumulation steered from LR (exp, tanh: float paths)
        Pass(  # ntaau_lr at a fractional scale: taau_reproject_pass with the motion resized by the sizes' ratio
            "taau_lr_reproject_pass", (8, 8, 1), "hr",
            (_s("history", 0, HISTORY_FORMAT), _s("motion", 1, "rg32f"), _i("reprojected", 0, "rgba16f")),
            ("u_reset", "u_blur_penalty"),
            exact=False,
        ),
        Pass(
            "taau_lr_evidence_pass", (8, 8, 1), "lr",
            (_s("depth", 0, "r32f"), _s("prev_depth", 1, "r32f"), _s("motion", 2, "rg32f"), _i("evidence", 0, "rgba32f")),
            ("u_reset", "u_trust_depth", "u_trust_spread_px"),
            exact=False,
        ),
        Pass(
            "taau_lr_pack_pass", (64, 1, 1), "words",
            (_s("color", 0, "rgba16f"), _s("reprojected", 1, "rgba16f"), _s("evidence", 2, "rgba32f"),
             _b("npu_input", 0, "uint[]")),
            ("u_scale", "u_reset", "u_max_weight", "u_word_count", "u_q_scale", "u_q_reciprocal", "u_q_use_reciprocal", "u_q_rounding",
             "u_q_zero_point", "u_scale_input"),
            exact=False,
        ),
        Pass(
            "taau_lr_accumulate_pass", (8, 8, 1), "hr",
            (_b("npu_output", 0, "uint[]"), _s("color", 0, "rgba16f"), _s("reprojected", 1, "rgba16f"),
             _s("evidence", 2, "rgba32f"), _i("history", 0, HISTORY_FORMAT), _i("display", 1, DISPLAY_FORMAT)),
            ("u_scale", "u_jitter", "u_q_scale", "u_q_zero_point", "u_box_bound", "u_sample_sigma", "u_prior_weight",
             "u_max_weight"),
            exact=False,
        ),
        Pass(
            "taau_lr_filter_pass", (8, 8, 1), "hr",
            (_b("npu_output", 0, "uint[]"), _s("history", 0, HISTORY_FORMAT), _i("display", 0, DISPLAY_FORMAT)),
            ("u_scale", "u_lr_size", "u_q_scale", "u_q_zero_point", "u_filter_bound"),
            exact=False,
        ),
        # fsr2: the FSR2-class baseline upscaler (ops.fsr2), GPU only; float paths (sin, sqrt)
        Pass(
            "fsr2_reconstruct_pass", (8, 8, 1), "lr",
            (_s("depth", 0, "r32f"), _s("motion", 1, "rg32f"), _i("dilated", 0, "rgba32f"), _b("previous_depth", 0, "uint[]")),
            ("u_dilation_edge",),
        ),
        Pass(
            "fsr2_depth_clip_pass", (8, 8, 1), "lr",
            (_s("dilated", 0, "rgba32f"), _s("color", 1, "rgba16f"), _b("previous_depth", 0, "uint[]"),
             _i("analysis", 0, "rgba32f")),
            ("u_depth_tolerance", "u_slope_factor", "u_lock_contrast"),
            exact=False,
        ),
        Pass(
            "fsr2_accumulate_pass", (8, 8, 1), "hr",
            (_s("color", 0, "rgba16f"), _s("dilated", 1, "rgba32f"), _s("analysis", 2, "rgba32f"),
             _s("history", 3, HISTORY_FORMAT), _s("locks", 4, "rgba16f"), _s("reactive", 5, "r32f"),
             _i("next_history", 0, HISTORY_FORMAT), _i("next_locks", 1, "rgba16f"), _b("previous_depth", 0, "uint[]")),
            ("u_scale", "u_jitter", "u_reset", "u_use_reactive", "u_max_weight", "u_gamma", "u_resample_penalty",
             "u_kernel_width", "u_prior_weight", "u_lock_decay", "u_lock_luma_tolerance"),
            exact=False,
        ),
        Pass(
            "fsr2_rcas_pass", (8, 8, 1), "hr",
            (_s("image", 0, HISTORY_FORMAT), _i("output_image", 0, "rgba16f")),
            ("u_sharpness",),
            exact=False,
        ),
    )
}

# HR G-buffers gbuffer_pack_pass reads, in its channel order; bit i of u_gbuffers selects entry i
PACKED_GBUFFERS = ("fbeta", "normal", "depth", "albedo")


def avgpool_channels(history_at_samples: bool) -> int:
    """Channels ``avgpool_pass`` writes, in order (each RGB): avgpool(I_R), then I_R at this
    frame's sampled sub-pixels when ``history_at_samples``, then the LR colour."""
    return 9 if history_at_samples else 6


# Execution order within a frame (the AA net runs conv3x3_pass once per layer).
PASS_ORDER = tuple(PASSES)

# Values of the integer mode uniforms, as the shaders' constants define them.
ACTIVATION_CODES = {"sigmoid": 0, "tanh": 1}
WEIGHT_UPSAMPLE_CODES = {"bilinear": 0, "nearest": 1}
EPILOGUE_CODES = {"none": 0, "relu": 1, "residual_clamp": 2}
ROUNDING_CODES = {"away_from_zero": 0, "half_even": 1, "half_up": 2}


def quantize_uniforms(scale: float, zero_point: int, profile) -> dict:
    """The ``u_q_*`` uniforms of quant.glsl's int8 quantize for ``ops.int8.quantize.quantize`` under
    ``profile`` (a runtime name or an ``ops.runtimes.Runtime``): the float32 scale, its float32
    reciprocal (computed here, as the runtime computes it), which of the two the runtime uses,
    the tie rule and the zero point."""
    p = get_runtime(profile)
    s = np.float32(scale)
    return {
        "u_q_scale": float(s),
        "u_q_reciprocal": float(np.float32(1.0) / s),
        "u_q_use_reciprocal": int(p.quantize_reciprocal),
        "u_q_rounding": ROUNDING_CODES[p.quantize_rounding],
        "u_q_zero_point": int(zero_point),
    }


def fsr2_uniforms(params: FSR2Params) -> dict:
    """The float uniforms of the fsr2 passes for ``params`` (float32 values, as the shaders hold them)."""
    f = lambda v: float(np.float32(v))  # noqa: E731
    return {"u_dilation_edge": f(params.dilation_edge), "u_depth_tolerance": f(params.depth_tolerance), "u_slope_factor": f(params.slope_factor),
            "u_lock_contrast": f(params.lock_contrast), "u_max_weight": f(params.max_weight), "u_gamma": f(params.gamma),
            "u_resample_penalty": f(params.resample_penalty), "u_kernel_width": f(params.kernel_width),
            "u_prior_weight": f(params.prior_weight),
            "u_lock_decay": f(np.float32(1.0 / params.lock_frames)), "u_lock_luma_tolerance": f(params.lock_luma_tolerance),
            "u_sharpness": f(params.sharpness)}


def fsr2_params_from_uniforms(uniforms: dict) -> FSR2Params:
    """The ``FSR2Params`` behind fsr2 uniform values (those a pass does not take keep their defaults)."""
    names = {"u_dilation_edge": "dilation_edge", "u_depth_tolerance": "depth_tolerance", "u_slope_factor": "slope_factor", "u_lock_contrast": "lock_contrast",
             "u_max_weight": "max_weight", "u_gamma": "gamma", "u_resample_penalty": "resample_penalty",
             "u_kernel_width": "kernel_width", "u_prior_weight": "prior_weight", "u_lock_luma_tolerance": "lock_luma_tolerance",
             "u_sharpness": "sharpness"}
    values = {field: uniforms[u] for u, field in names.items() if u in uniforms}
    if "u_lock_decay" in uniforms:
        values["lock_frames"] = int(round(1.0 / uniforms["u_lock_decay"]))
    return FSR2Params(**values)
