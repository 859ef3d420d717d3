"""The MNSS family's GPU side of a bundle: shaders used, resources, weight blocks, frame schedule.

The schedule spells out, step by step, what :func:`.gpu_stage.before_npu` and
:func:`~.gpu_stage.after_npu` do, with the resources a phone keeps allocated: which resource
each shader binding gets, every uniform (a constant, or a per-frame value from the jitter
table), the workgroup counts, and the steps skipped on a reset frame.  The building blocks are
:mod:`mnss_kit.gpu.plan`'s.
"""

from __future__ import annotations

import numpy as np

from ...gpu import passes as P
from ...gpu.plan import WEIGHTS_PREFIX, const as _const, pass_entries, per_frame as _frame, quantize_uniforms
from ...gpu.plan import step, warp_step, word_count
from ...gpu.weights import Conv3x3, layers_of
from .config import MNSSConfig, aa_input_channels
from .gpu_stage import GpuStage

NPU_CHANNELS = 3  # the reconstruction net maps an RGB image to an RGB image


def bundle_gpu_plan(config: MNSSConfig, state_dict: dict, lr_size: tuple[int, int], npu: dict, profile: str) -> dict:
    """The family record's ``gpu_plan``: passes, weight blocks ``[(name, Conv3x3)]``, resources, schedule, debug views."""
    stage = GpuStage.from_model(config, state_dict)
    return {
        "passes": pass_entries(_used_passes(stage)),
        "weights": weight_blocks(stage),
        "resources": resources(stage, lr_size),
        "schedule": schedule(stage, lr_size, npu, profile),
        "debug_views": debug_views(stage),
    }


MOTION_VIEW_RANGE = 4.0  # LR pixels of motion shown at full saturation


def debug_views(stage: GpuStage) -> list[dict]:
    """The resources an app can show for this configuration, and how to colour them (the schema's ``debug_views``)."""
    views = []
    if stage.with_history:
        views += [
            {"name": "weight map", "resource": "lr_weight", "map": "scalar", "range": [0.0, 1.0], "on_reset": 1.0,
             "description": "LR inpainting weights: white takes the current frame, black keeps the warped history"},
            {"name": "history taken", "resource": "lr_weight", "map": "mask", "below": 0.5, "on_reset": 1.0,
             "description": "pixels whose rectified colour is mostly the warped history (weight below 0.5); none on a reset frame"},
        ]
    views.append({"name": "motion", "resource": "motion", "map": "vector", "range": [0.0, MOTION_VIEW_RANGE],
                  "description": f"LR motion: hue is the direction, saturation the length, full at {MOTION_VIEW_RANGE:g} LR pixels"})
    return views


def weight_blocks(stage: GpuStage) -> list[tuple[str, Conv3x3]]:
    """``(block name, conv)`` of every learned GPU conv, in schedule order."""
    blocks = [("inpaint", stage.weights.inpaint)] if stage.with_history else []
    return blocks + [(f"aa.{i}", conv) for i, conv in enumerate(stage.weights.aa)]


def _used_passes(stage: GpuStage) -> set[str]:
    used = {"inpaint_blend_pass", "avgpool_pass", "conv3x3_pass", "insert_pack_pass", "unpack_history_pass"}
    if stage.with_history:
        used |= {"warp_pass", "inpaint_weights_pass"}
    if stage.enhance_beta is not None:
        used.add("sharpen_pass")
    return used


def resources(stage: GpuStage, lr_size: tuple[int, int]) -> list[dict]:
    """Every texture and buffer a phone keeps for the schedule.  Sizes are ``[width, height]``."""
    w, h = lr_size
    hr = [w * stage.scale, h * stage.scale]
    lr = [w, h]
    words = word_count(lr_size, stage.scale, NPU_CHANNELS)
    aa_channels = aa_input_channels(stage.weights.aa_history_at_samples)
    at_samples = "I_R at the sampled sub-pixels, " if stage.weights.aa_history_at_samples else ""

    def tex(name, size, fmt, role, note, channels, layers=0):
        entry = {"name": name, "kind": "texture2d_array" if layers else "texture2d", "size": size, "format": fmt,
                 "channels": channels, "role": role, "description": note}
        if layers:
            entry["layers"] = layers
        return entry

    def buf(name, note):
        return {"name": name, "kind": "buffer", "bytes": words * 4, "words": words, "element": "uint", "role": "boundary",
                "description": note}

    out = [
        tex("color", lr, P.INPUT_FORMATS["color"], "input", "jittered LR colour, display values in [0, 1]", 3),
        tex("depth", lr, P.INPUT_FORMATS["depth"], "input", "LR depth, linear in [0, 1]; swaps with prev_depth at the end of the frame", 1),
        tex("motion", lr, P.INPUT_FORMATS["motion"], "input", "LR motion in LR pixels, pointing to the previous frame, +y down", 2),
        tex("history", hr, P.HISTORY_FORMAT, "state", "previous output I_SS; read by warp_pass, rewritten by unpack_history_pass", 3),
        tex("prev_depth", lr, "r32f", "state", "the previous frame's depth (the depth texture of the last frame)", 1),
        tex("unused", [1, 1], "r32f", "placeholder", "bound where a pass declares a texture it does not read in this configuration", 1),
        tex("rectified", hr, "rgba16f", "intermediate", "I_R, the rectified history", 3),
        tex("aa_input", lr, "rgba16f", "intermediate", f"AA net input: pooled I_R, {at_samples}the colour",
            aa_channels, layers=layers_of(aa_channels)),
    ]
    if stage.with_history:
        out += [
            tex("warped", hr, "rgba16f", "intermediate", "I_W, the warped history", 3),
            tex("warped_depth", lr, "r32f", "intermediate", "D_W at this frame's sampled sub-pixels", 1),
            tex("lr_weight", lr, "r32f", "intermediate", "LR inpainting weights in [0, 1]", 1),
        ]
    hidden = [conv.out_channels for conv in stage.weights.aa[:-1]]
    for i in range(min(len(hidden), 2)):
        out.append(tex(f"aa_hidden_{i}", lr, "rgba16f", "intermediate", "AA net hidden layer (alternating)", max(hidden),
                       layers=layers_of(max(hidden))))
    out += [
        tex("aa", lr, "rgba16f", "intermediate", "I_AA, the anti-aliased LR frame (layer 0)", 3, layers=1),
        buf("npu_input", "int8 NHWC (1, H, W, 3) NPU input, 4 bytes per word, little-endian"),
        buf("npu_output", "int8 NHWC (1, H, W, 3) NPU output, 4 bytes per word, little-endian"),
        tex("display", hr, P.DISPLAY_FORMAT, "output", "the frame to show (8-bit codes)", 3),
    ]
    return out


def schedule(stage: GpuStage, lr_size: tuple[int, int], npu: dict, profile: str) -> dict:
    """The per-frame steps.  ``npu``: ``{"model", "input", "output", "input_q", "output_q"}``
    (tensor names and ``(scale, zero_point)`` of the NPU's input and output)."""
    s = stage.scale
    a = dict(lr_size=lr_size, scale=s)
    steps = []
    if stage.with_history:
        steps.append(warp_step("warp", "warp", **a))
        steps.append(step("inpaint_weights_pass", "inpaint weights", "inpaint", {
            "color": "color", "depth": "depth", "warped": "warped", "warped_depth": "warped_depth", "weights": WEIGHTS_PREFIX + "inpaint",
            "lr_weight": "lr_weight",
        }, {"u_scale": _const(s), "u_subpixel": _frame("subpixel"), "u_activation": _const(P.ACTIVATION_CODES[stage.activation])},
            skip_on_reset=True, **a))
    history_bind = {"warped": "warped", "lr_weight": "lr_weight"} if stage.with_history else {"warped": "unused", "lr_weight": "unused"}
    steps.append(step("inpaint_blend_pass", "inpaint blend", "inpaint", {"color": "color", **history_bind, "rectified": "rectified"}, {
        "u_scale": _const(s), "u_jitter": _frame("offset"), "u_subpixel": _frame("subpixel"),
        "u_weight_upsample": _const(P.WEIGHT_UPSAMPLE_CODES[stage.weight_upsample]),
        "u_reset": _frame("reset") if stage.with_history else _const(1),
    }, **a))
    steps.append(step("avgpool_pass", "aa input", "aa", {"rectified": "rectified", "color": "color", "aa_input": "aa_input"},
                       {"u_scale": _const(s), "u_subpixel": _frame("subpixel"),
                        "u_history_at_samples": _const(int(stage.weights.aa_history_at_samples))}, **a))
    steps += _aa_steps(stage, **a)
    steps.append(step("insert_pack_pass", "insert + pack", "insert", {"rectified": "rectified", "aa": "aa", "npu_input": "npu_input"}, {
        "u_scale": _const(s), "u_subpixel": _frame("subpixel"),
        "u_word_count": _const(word_count(lr_size, s, NPU_CHANNELS)), **quantize_uniforms(*npu["input_q"], profile),
    }, words=word_count(lr_size, s, NPU_CHANNELS), **a))
    steps.append({"kind": "npu", "label": "reconstruction", "stage": "recon", "model": npu["model"],
                  "inputs": {npu["input"]: "npu_input"}, "outputs": {npu["output"]: "npu_output"}})
    out_scale, out_zp = npu["output_q"]
    steps.append(step("unpack_history_pass", "unpack + history", "recon", {"npu_output": "npu_output", "history": "history", "display": "display"},
                       {"u_q_scale": _const(float(np.float32(out_scale))), "u_q_zero_point": _const(int(out_zp))}, **a))
    if stage.enhance_beta is not None:
        steps.append(step("sharpen_pass", "sharpen", "enhance", {"image": "history", "display": "display"},
                           {"u_beta": _const(float(np.float32(stage.enhance_beta)))}, **a))
    return {
        "steps": steps,
        "end_of_frame": [{"swap": ["depth", "prev_depth"]}],
        "reset": "on a reset frame (camera cut, first frame) the steps marked skip_on_reset do not run and "
                 "inpaint_blend_pass gets u_reset = 1: the history and prev_depth are ignored",
        "barriers": "every step reads what earlier steps wrote: glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT | "
                    "GL_TEXTURE_FETCH_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT) between GPU steps; around the NPU step "
                    "the GPU's writes to npu_input must be complete and visible to the NPU, and the NPU's npu_output "
                    "to the GPU (fence, and cache maintenance where the memory is not coherent)",
    }


def _aa_steps(stage: GpuStage, lr_size, scale) -> list[dict]:
    """conv3x3_pass per AA layer: aa_input -> aa_hidden_0 -> aa_hidden_1 -> aa_hidden_0 ... -> aa."""
    layers = stage.weights.aa
    steps, source = [], "aa_input"
    for i, conv in enumerate(layers):
        last = i == len(layers) - 1
        target = "aa" if last else f"aa_hidden_{i % 2}"
        out_layers = layers_of(conv.out_channels)
        steps.append(step("conv3x3_pass", f"aa conv {i}", "aa", {
            "x": source, "residual": "color" if last else "unused", "weights": f"{WEIGHTS_PREFIX}aa.{i}", "y": target,
        }, {"u_in_layers": _const(layers_of(conv.in_channels)), "u_out_layers": _const(out_layers),
            "u_epilogue": _const(P.EPILOGUE_CODES["residual_clamp" if last else "relu"])}, lr_size, scale, depth=out_layers))
        source = target
    return steps
