"""The GPU side of a bundle as data: shader entries, resources, weight blocks and the frame schedule.

The schedule spells out, step by step, what :func:`mnss_kit.gpu.schedule.before_npu` and
:func:`~mnss_kit.gpu.schedule.after_npu` do, with the resources a phone keeps allocated: which
resource each shader binding gets, every uniform (a constant, or a per-frame value from the
jitter table), the workgroup counts, and the steps skipped on a reset frame.  Bindings,
workgroup sizes and formats come from :data:`mnss_kit.gpu.passes.PASSES`, weights from
:mod:`mnss_kit.gpu.weights`; nothing here restates them.

Resource names in ``bind`` refer to ``resources``; ``weights:NAME`` to a block of the weight file.
Per-frame uniform values (``{"frame": KEY}``) are: ``offset`` / ``subpixel`` (this frame's jitter
entry), ``previous_offset`` / ``previous_subpixel`` (the previous frame's) and ``reset`` (1 on
a camera cut or the first frame, from the engine).
"""

from __future__ import annotations

import hashlib

import numpy as np

from ..gpu import passes as P
from ..model.config import aa_input_channels
from ..gpu.schedule import GpuStage
from ..gpu.weights import Conv3x3, layers_of
from ..ops.runtimes import get_runtime

WEIGHTS_FILE = "gpu_weights.bin"
WEIGHTS_PREFIX = "weights:"  # a bind target naming a block of the weight file
WEIGHT_ALIGNMENT = 256  # bytes; the largest SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT GL ES allows
NPU_CHANNELS = 3
MAX_GROUPS_X = 4096  # workgroups along x for the word grid (the shader folds y into the index)


def weight_blocks(stage: GpuStage) -> list[tuple[str, Conv3x3]]:
    """``(block name, conv)`` of every learned GPU conv, in schedule order."""
    blocks = [("inpaint", stage.weights.inpaint)] if stage.with_history else []
    return blocks + [(f"aa.{i}", conv) for i, conv in enumerate(stage.weights.aa)]


def pack_weights(stage: GpuStage) -> tuple[bytes, list[dict]]:
    """The weight file (little-endian float32, blocks aligned to :data:`WEIGHT_ALIGNMENT`) and its block entries.

    Each block is ``pack_conv3x3`` of one conv: ``(rows, 4)`` float32, the layout ``conv3x3.glsl``
    reads; ``conv`` records the unpacked shape so a reader can undo the packing.
    """
    data, entries = bytearray(), []
    for name, conv in weight_blocks(stage):
        data += b"\0" * (-len(data) % WEIGHT_ALIGNMENT)
        packed = np.ascontiguousarray(conv.packed(), dtype="<f4")
        raw = packed.tobytes()
        entries.append({
            "name": name,
            "offset": len(data),
            "bytes": len(raw),
            "shape": list(packed.shape),
            "sha256": hashlib.sha256(raw).hexdigest(),
            "conv": {"out_channels": conv.out_channels, "in_channels": conv.in_channels, "kernel": [3, 3],
                     "layout": "conv3x3.glsl (mnss_kit.gpu.weights.pack_conv3x3)"},
        })
        data += raw
    return bytes(data), entries


def pass_entries(stage: GpuStage) -> list[dict]:
    """Every shader the schedule uses: entry file, workgroup size, grid, bindings, uniforms."""
    names = [n for n in P.PASS_ORDER if n in _used_passes(stage)]
    out = []
    for name in names:
        spec = P.PASSES[name]
        out.append({
            "name": name,
            "file": f"shaders/{spec.entry}",
            "workgroup_size": list(spec.local_size),
            "grid": spec.grid,
            "bindings": [{"name": b.name, "kind": b.kind, "unit": b.unit, "format": b.format, "array": b.array} for b in spec.bindings],
            "uniforms": list(spec.uniforms),
        })
    return out


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
    words = -(-hr[0] * hr[1] * NPU_CHANNELS // 4)
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


def _groups(grid: str, local: tuple[int, int, int], lr_size: tuple[int, int], scale: int, depth: int = 1) -> list[int]:
    w, h = lr_size
    if grid == "words":
        words = -(-w * scale * h * scale * NPU_CHANNELS // 4)
        groups = -(-words // local[0])
        gx = min(groups, MAX_GROUPS_X)
        return [gx, -(-groups // gx), 1]
    if grid == "hr":
        w, h = w * scale, h * scale
    return [-(-w // local[0]), -(-h // local[1]), depth]


def _step(name: str, label: str, stage_name: str, bind: dict, uniforms: dict, lr_size, scale, depth: int = 1,
          skip_on_reset: bool = False) -> dict:
    spec = P.PASSES[name]
    return {
        "kind": "gpu",
        "pass": name,
        "label": label,
        "stage": stage_name,
        "bind": bind,
        "uniforms": uniforms,
        "groups": _groups(spec.grid, spec.local_size, lr_size, scale, depth),
        "skip_on_reset": skip_on_reset,
    }


def _const(value) -> dict:
    return {"value": value}


def _frame(key: str) -> dict:
    return {"frame": key}


def quantize_uniforms(scale: float, zero_point: int, profile: str) -> dict:
    """``insert_pack_pass`` quantization uniforms for the NPU input and a runtime's QUANTIZE rounding."""
    p = get_runtime(profile)
    s = np.float32(scale)
    return {
        "u_q_scale": _const(float(s)),
        "u_q_reciprocal": _const(float(np.float32(1.0) / s)),
        "u_q_use_reciprocal": _const(int(p.quantize_reciprocal)),
        "u_q_rounding": _const(P.ROUNDING_CODES[p.quantize_rounding]),
        "u_q_zero_point": _const(int(zero_point)),
    }


def schedule(stage: GpuStage, lr_size: tuple[int, int], npu: dict, profile: str) -> dict:
    """The per-frame steps.  ``npu``: ``{"model", "input", "output", "input_q", "output_q"}``
    (tensor names and ``(scale, zero_point)`` of the NPU's input and output)."""
    s = stage.scale
    a = dict(lr_size=lr_size, scale=s)
    steps = []
    if stage.with_history:
        steps.append(_step("warp_pass", "warp", "warp", {
            "history": "history", "prev_depth": "prev_depth", "motion": "motion", "warped": "warped", "warped_depth": "warped_depth",
        }, {"u_scale": _const(s), "u_subpixel": _frame("subpixel"), "u_prev_jitter": _frame("previous_offset"),
            "u_prev_subpixel": _frame("previous_subpixel")}, skip_on_reset=True, **a))
        steps.append(_step("inpaint_weights_pass", "inpaint weights", "inpaint", {
            "color": "color", "depth": "depth", "warped": "warped", "warped_depth": "warped_depth", "weights": WEIGHTS_PREFIX + "inpaint",
            "lr_weight": "lr_weight",
        }, {"u_scale": _const(s), "u_subpixel": _frame("subpixel"), "u_activation": _const(P.ACTIVATION_CODES[stage.activation])},
            skip_on_reset=True, **a))
    history_bind = {"warped": "warped", "lr_weight": "lr_weight"} if stage.with_history else {"warped": "unused", "lr_weight": "unused"}
    steps.append(_step("inpaint_blend_pass", "inpaint blend", "inpaint", {"color": "color", **history_bind, "rectified": "rectified"}, {
        "u_scale": _const(s), "u_jitter": _frame("offset"), "u_subpixel": _frame("subpixel"),
        "u_weight_upsample": _const(P.WEIGHT_UPSAMPLE_CODES[stage.weight_upsample]),
        "u_reset": _frame("reset") if stage.with_history else _const(1),
    }, **a))
    steps.append(_step("avgpool_pass", "aa input", "aa", {"rectified": "rectified", "color": "color", "aa_input": "aa_input"},
                       {"u_scale": _const(s), "u_subpixel": _frame("subpixel"),
                        "u_history_at_samples": _const(int(stage.weights.aa_history_at_samples))}, **a))
    steps += _aa_steps(stage, **a)
    steps.append(_step("insert_pack_pass", "insert + pack", "insert", {"rectified": "rectified", "aa": "aa", "npu_input": "npu_input"}, {
        "u_scale": _const(s), "u_subpixel": _frame("subpixel"),
        "u_word_count": _const(-(-lr_size[0] * s * lr_size[1] * s * NPU_CHANNELS // 4)), **quantize_uniforms(*npu["input_q"], profile),
    }, **a))
    steps.append({"kind": "npu", "label": "reconstruction", "stage": "recon", "model": npu["model"],
                  "inputs": {npu["input"]: "npu_input"}, "outputs": {npu["output"]: "npu_output"}})
    out_scale, out_zp = npu["output_q"]
    steps.append(_step("unpack_history_pass", "unpack + history", "recon", {"npu_output": "npu_output", "history": "history", "display": "display"},
                       {"u_q_scale": _const(float(np.float32(out_scale))), "u_q_zero_point": _const(int(out_zp))}, **a))
    if stage.enhance_beta is not None:
        steps.append(_step("sharpen_pass", "sharpen", "enhance", {"image": "history", "display": "display"},
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
        steps.append(_step("conv3x3_pass", f"aa conv {i}", "aa", {
            "x": source, "residual": "color" if last else "unused", "weights": f"{WEIGHTS_PREFIX}aa.{i}", "y": target,
        }, {"u_in_layers": _const(layers_of(conv.in_channels)), "u_out_layers": _const(out_layers),
            "u_epilogue": _const(P.EPILOGUE_CODES["residual_clamp" if last else "relu"])}, lr_size, scale, depth=out_layers))
        source = target
    return steps
