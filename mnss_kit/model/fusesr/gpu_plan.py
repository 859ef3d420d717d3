"""The FuseSR family's GPU side of a bundle: shaders used, resources, weight blocks, frame schedule.

Per frame: ``warp_pass`` (hybrid; skipped on a reset), ``demodulate_pass`` (L, or the colour
copied when demodulation is off), ``conv3x3_pass`` (the LR encoder), ``gbuffer_pack_pass``
(the int8 NPU input at LR), the NPU backbone, ``remodulate_pass`` (display and history).  The
building blocks are :mod:`mnss_kit.gpu.plan`'s; the passes are the library's (``gpu/passes/``, one file per pass).
"""

from __future__ import annotations

import numpy as np

from ...errors import UserError
from ...gpu import passes as P
from ...gpu.plan import WEIGHTS_PREFIX, const, pass_entries, per_frame, quantize_uniforms, step, warp_step, word_count
from ...gpu.weights import Conv3x3, layers_of
from .config import FuseSRConfig

NPU_OUTPUT_CHANNELS = 3  # the backbone returns the HR L (or colour)


def encoder_conv(state_dict: dict) -> Conv3x3:
    """The LR encoder's conv from a FuseSR state dict (numpy values)."""
    try:
        return Conv3x3(np.asarray(state_dict["encode.conv.weight"], np.float32), np.asarray(state_dict["encode.conv.bias"], np.float32))
    except KeyError as e:
        raise UserError(f"model weights lack {e.args[0]}") from None


def bundle_gpu_plan(config: FuseSRConfig, state_dict: dict, lr_size: tuple[int, int], npu: dict, profile: str) -> dict:
    """The family record's ``gpu_plan``: passes, weight blocks ``[(name, Conv3x3)]``, resources and schedule."""
    encoder = encoder_conv(state_dict)
    used = {"demodulate_pass", "conv3x3_pass", "gbuffer_pack_pass", "remodulate_pass"} | ({"warp_pass"} if config.history else set())
    return {
        "passes": pass_entries(used),
        "weights": [("encode", encoder)],
        "resources": resources(config, encoder, lr_size),
        "schedule": schedule(config, encoder, lr_size, npu, profile),
    }


def input_words(config: FuseSRConfig, encoder: Conv3x3, lr_size: tuple[int, int]) -> int:
    """32-bit words of the int8 NHWC (1, h, w, C) NPU input."""
    channels = config.npu_input_channels() + encoder.out_channels
    return -(-lr_size[0] * lr_size[1] * channels // 4)


def _tex(name, size, fmt, role, note, channels, layers=0):
    entry = {"name": name, "kind": "texture2d_array" if layers else "texture2d", "size": size, "format": fmt,
             "channels": channels, "role": role, "description": note}
    return {**entry, "layers": layers} if layers else entry


def _buf(name, words, note):
    return {"name": name, "kind": "buffer", "bytes": words * 4, "words": words, "element": "uint", "role": "boundary",
            "description": note}


def hr_inputs(config: FuseSRConfig) -> tuple[str, ...]:
    """HR input textures (dataset buffers): the G-buffers, and F_beta and emissive for remodulation."""
    remodulation = ("fbeta", "emissive") if config.demodulate else ()
    return tuple(dict.fromkeys((*config.ordered_gbuffers, *remodulation)))


def resources(config: FuseSRConfig, encoder: Conv3x3, lr_size: tuple[int, int]) -> list[dict]:
    """Every texture and buffer a phone keeps for the schedule.  Sizes are ``[width, height]``."""
    w, h = lr_size
    hr, lr = [w * config.scale, h * config.scale], [w, h]
    out = [_tex("color", lr, P.INPUT_FORMATS["color"], "input", "jittered LR colour, display values in [0, 1]", 3)]
    if config.demodulate:
        out += [_tex("lr_fbeta", lr, "rgba16f", "input", "LR F_beta (linear)", 3),
                _tex("lr_emissive", lr, "rgba16f", "input", "LR emission and sky (linear)", 3)]
    if config.history:
        out += [_tex("depth", lr, P.INPUT_FORMATS["depth"], "input", "LR depth; swaps with prev_depth at the end of the frame", 1),
                _tex("motion", lr, P.INPUT_FORMATS["motion"], "input", "LR motion in LR pixels, pointing to the previous frame", 2)]
    for name in hr_inputs(config):
        fmt = P.PASSES["gbuffer_pack_pass"].binding(name).format if name in P.PACKED_GBUFFERS else "rgba16f"
        channels = 1 if fmt == "r32f" else 3
        out.append(_tex(f"hr_{name}", hr, fmt, "input", f"HR {name} G-buffer", channels))
    if config.history:
        out += [_tex("history", hr, P.HISTORY_FORMAT, "state", "the previous output; read by warp_pass, rewritten by remodulate_pass", 3),
                _tex("prev_depth", lr, "r32f", "state", "the previous frame's depth (read by warp_pass, unused after it)", 1),
                _tex("warped", hr, "rgba16f", "intermediate", "the warped history", 3),
                _tex("warped_depth", lr, "r32f", "intermediate", "warp_pass's depth output (unused by this family)", 1)]
    else:
        out.append(_tex("image", hr, P.HISTORY_FORMAT, "intermediate", "the output as fp16 (remodulate_pass)", 3))
    features = encoder.out_channels
    out += [
        _tex("unused", [1, 1], "r32f", "placeholder", "bound where a pass declares a texture it does not read in this configuration", 1),
        _tex("l", lr, "rgba16f", "intermediate", "display-encoded L (or the colour) in layer 0", 3, layers=1),
        _tex("features", lr, "rgba16f", "intermediate", "LR encoder features", features, layers=layers_of(features)),
        _buf("npu_input", input_words(config, encoder, lr_size), "int8 NHWC (1, h, w, C) NPU input at LR, 4 bytes per word, little-endian"),
        _buf("npu_output", word_count(lr_size, config.scale, NPU_OUTPUT_CHANNELS),
             "int8 NHWC (1, H, W, 3) NPU output, 4 bytes per word, little-endian"),
        _tex("display", hr, P.DISPLAY_FORMAT, "output", "the frame to show (8-bit codes)", 3),
    ]
    return out


def schedule(config: FuseSRConfig, encoder: Conv3x3, lr_size: tuple[int, int], npu: dict, profile: str) -> dict:
    """The per-frame steps.  ``npu``: ``{"model", "input", "output", "input_q", "output_q"}``."""
    s = config.scale
    a = dict(lr_size=lr_size, scale=s)
    demodulate = int(config.demodulate)
    steps = []
    if config.history:
        steps.append(warp_step("warp_history", "warp history", **a))
    steps.append(step("demodulate_pass", "demodulate", "demodulate" if demodulate else "encode", {
        "color": "color", "fbeta": "lr_fbeta" if demodulate else "unused", "emissive": "lr_emissive" if demodulate else "unused",
        "l": "l"}, {"u_demodulate": const(demodulate)}, **a))
    out_layers = layers_of(encoder.out_channels)
    steps.append(step("conv3x3_pass", "encoder", "encode", {
        "x": "l", "residual": "unused", "weights": WEIGHTS_PREFIX + "encode", "y": "features",
    }, {"u_in_layers": const(1), "u_out_layers": const(out_layers), "u_epilogue": const(P.EPILOGUE_CODES["relu"])},
        depth=out_layers, **a))
    words = input_words(config, encoder, lr_size)
    gbuffers = {g: (f"hr_{g}" if g in config.ordered_gbuffers else "unused") for g in P.PACKED_GBUFFERS}
    mask = sum(1 << i for i, g in enumerate(P.PACKED_GBUFFERS) if g in config.ordered_gbuffers)
    steps.append(step("gbuffer_pack_pass", "G-buffer unshuffle + pack", "unshuffle", {
        "l": "l", "features": "features", "warped": "warped" if config.history else "unused", **gbuffers, "npu_input": "npu_input",
    }, {"u_scale": const(s), "u_features": const(encoder.out_channels), "u_history": const(int(config.history)),
        "u_reset": per_frame("reset") if config.history else const(0), "u_gbuffers": const(mask), "u_word_count": const(words),
        **quantize_uniforms(*npu["input_q"], profile)}, words=words, **a))
    steps.append({"kind": "npu", "label": "backbone", "stage": "backbone", "model": npu["model"],
                  "inputs": {npu["input"]: "npu_input"}, "outputs": {npu["output"]: "npu_output"}})
    out_scale, out_zp = npu["output_q"]
    steps.append(step("remodulate_pass", "remodulate", "remodulate", {
        "npu_output": "npu_output", "l": "l", "fbeta": "hr_fbeta" if demodulate else "unused",
        "emissive": "hr_emissive" if demodulate else "unused", "history": "history" if config.history else "image",
        "display": "display"}, {"u_scale": const(s), "u_q_scale": const(float(np.float32(out_scale))), "u_q_zero_point": const(int(out_zp)),
                                "u_demodulate": const(demodulate)}, **a))
    return {
        "steps": steps,
        "end_of_frame": [{"swap": ["depth", "prev_depth"]}] if config.history else [],
        "reset": "on a reset frame warp_pass does not run and gbuffer_pack_pass gets u_reset = 1: the history is packed as 0"
                 if config.history else "no history: every frame stands alone",
        "barriers": "glMemoryBarrier between GPU steps; around the NPU step the GPU's writes to npu_input must be visible "
                    "to the NPU, and the NPU's npu_output to the GPU (fence)",
    }
