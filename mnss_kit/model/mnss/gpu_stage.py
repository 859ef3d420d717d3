"""One frame through the GPU passes: the part before the NPU and the part after it.

    before_npu   warp_pass, inpaint_weights_pass (both skipped on a reset), inpaint_blend_pass,
                 avgpool_pass, conv3x3_pass per AA layer, insert_pack_pass -> int8 NPU input
    (NPU)        model.recon on (1, H, W, 3) int8 NHWC; its graph does the space-to-depth
    after_npu    unpack_history_pass, sharpen_pass (with enhancement) -> history, display

``passes`` is a :class:`~mnss_kit.gpu.reference.ReferencePasses` (the emulator) or a
:class:`~mnss_kit.gpu.mesa.MesaPasses` (the shader files on Mesa), each pass run through its
``run_pass``.  Frames and states are numpy:

    frame  color (h,w,3), depth (h,w,1), motion (h,w,2) LR pixels, jitter (2,), reset bool
    state  history (H,W,3), depth (h,w,1), jitter (2,) of the previous frame; None = reset
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import UserError
from .config import MNSSConfig, aa_input_channels
from ...gpu.passes import ACTIVATION_CODES, WEIGHT_UPSAMPLE_CODES, call, dequantize_uniforms, quantize_uniforms
from ...gpu.passes.conv3x3_pass import layer_uniforms
from ...gpu.plan import NpuBoundary
from ...gpu.weights import Conv3x3


@dataclass(frozen=True)
class GpuStage:
    """What the GPU passes need from a model: its config knobs and its learned GPU weights."""

    scale: int
    with_history: bool  # warp + inpaint against the previous output; False: I_R = I_U
    activation: str
    weight_upsample: str
    enhance_beta: float | None  # None: no enhancement
    weights: GpuWeights

    @classmethod
    def from_model(cls, config: MNSSConfig, state_dict: dict[str, np.ndarray]) -> "GpuStage":
        """From an MNSS config and its state dict (numpy values)."""
        if config.history == "lr_frame":
            raise UserError("the phone runtime keeps the model's output as history; history 'lr_frame' is not supported")
        weights = GpuWeights.from_state_dict(state_dict)
        with_history = config.history == "output"
        if with_history and weights.inpaint is None:
            raise UserError("model weights lack the inpainting conv (inpaint.conv.*)")
        return cls(
            scale=config.scale,
            with_history=with_history,
            activation=config.inpaint_activation,
            weight_upsample=config.weight_upsample,
            enhance_beta=config.enhance_beta if config.enhance else None,
            weights=weights,
        )


def before_npu(passes, stage: GpuStage, frame: dict, state: dict | None, boundary: NpuBoundary) -> dict:
    """The passes up to the NPU.  Returns the int8 NPU input ``npu_input`` (1,H,W,3) and the
    intermediates: ``warped`` (H,W,3) and ``lr_weight`` (h,w,1) (None on a reset),
    ``rectified`` (H,W,3), ``aa`` (h,w,3)."""
    s = stage.scale
    color, jitter = frame["color"], frame["jitter"]
    reset = state is None or bool(frame.get("reset", False)) or not stage.with_history
    previous = None if state is None else state["jitter"]

    def run(name: str, read: dict, uniforms: dict) -> dict:
        return passes.run_pass(name, call(read, uniforms, jitter, previous, s, boundary.profile))

    warped = lr_weight = None
    if not reset:
        out = run("warp_pass", {"history": state["history"], "prev_depth": state["depth"], "motion": frame["motion"]}, {"u_scale": s})
        warped = out["warped"]
        lr_weight = run("inpaint_weights_pass", {"color": color, "depth": frame["depth"], "warped": warped,
                                                 "warped_depth": out["warped_depth"], "weights": stage.weights.inpaint},
                        {"u_scale": s, "u_activation": ACTIVATION_CODES[stage.activation]})["lr_weight"]
    rectified = run("inpaint_blend_pass", {"color": color, "warped": warped, "lr_weight": lr_weight},
                    {"u_scale": s, "u_weight_upsample": WEIGHT_UPSAMPLE_CODES[stage.weight_upsample], "u_reset": int(reset)})["rectified"]
    x = run("avgpool_pass", {"rectified": rectified, "color": color},
            {"u_scale": s, "u_history_at_samples": int(stage.weights.aa_history_at_samples)})["aa_input"]
    layers = stage.weights.aa
    for i, conv in enumerate(layers):
        last = i == len(layers) - 1
        x = run("conv3x3_pass", {"x": x, "residual": color if last else None, "weights": conv},
                layer_uniforms(conv.in_channels, conv.out_channels, "residual_clamp" if last else "relu"))["y"]
    hh, hw = rectified.shape[:2]
    npu_input = run("insert_pack_pass", {"rectified": rectified, "aa": x},
                    {"u_scale": s, "u_word_count": -(-hh * hw * 3 // 4),
                     **quantize_uniforms(boundary.input_scale, boundary.input_zero_point, boundary.profile)})["npu_input"]
    return {"npu_input": npu_input, "warped": warped, "lr_weight": lr_weight, "rectified": rectified, "aa": x}


def after_npu(passes, stage: GpuStage, npu_output: np.ndarray, boundary: NpuBoundary) -> tuple[np.ndarray, np.ndarray]:
    """The passes after the NPU: int8 (1,H,W,3) -> (history (H,W,3) fp16 values, display (H,W,3) uint8)."""
    out = passes.run_pass("unpack_history_pass", call({"npu_output": npu_output},
                                                      dequantize_uniforms(boundary.output_scale, boundary.output_zero_point)))
    history, display = out["history"], out["display"]
    if stage.enhance_beta is not None:
        display = passes.run_pass("sharpen_pass", call({"image": history}, {"u_beta": float(np.float32(stage.enhance_beta))}))["display"]
    return history, display


def next_state(frame: dict, history: np.ndarray) -> dict:
    """The state the next frame reads: this frame's output as history, its LR depth and jitter."""
    return {"history": history, "depth": frame["depth"], "jitter": np.asarray(frame["jitter"], np.float32)}


@dataclass(frozen=True)
class GpuWeights:
    """``inpaint``: the inpainting conv, None without history; ``aa``: the AA net's convs in order."""

    inpaint: Conv3x3 | None
    aa: tuple[Conv3x3, ...]

    @property
    def aa_history_at_samples(self) -> bool:
        """The AA net reads I_R at the sampled sub-pixels too (``model.config.aa_input_channels``)."""
        return self.aa[0].in_channels == aa_input_channels(True)

    @classmethod
    def from_state_dict(cls, state: dict[str, np.ndarray]) -> "GpuWeights":
        """From an MNSS state dict (numpy values), keys ``inpaint.conv.*`` and ``aa.net.<i>.*``."""

        def conv(prefix: str) -> Conv3x3:
            try:
                weight, bias = state[prefix + ".weight"], state[prefix + ".bias"]
            except KeyError as e:
                raise UserError(f"model weights lack {e.args[0]}") from None
            return Conv3x3(np.asarray(weight, np.float32), np.asarray(bias, np.float32))

        inpaint = conv("inpaint.conv") if "inpaint.conv.weight" in state else None
        indices = sorted({int(k.split(".")[2]) for k in state if k.startswith("aa.net.") and k.endswith(".weight")})
        if not indices:
            raise UserError("model weights lack the anti-aliasing net (aa.net.*)")
        aa = tuple(conv(f"aa.net.{i}") for i in indices)
        for first, second in zip(aa, aa[1:]):
            if first.out_channels != second.in_channels:
                raise UserError("anti-aliasing net layers do not chain (channel counts differ)")
        paper, with_samples = aa_input_channels(False), aa_input_channels(True)
        if aa[0].in_channels not in (paper, with_samples) or aa[-1].out_channels != 3:
            raise UserError(f"anti-aliasing net must map {paper} channels (pooled history, colour) or {with_samples} "
                            "(pooled history, history at the samples, colour) to 3")
        return cls(inpaint, aa)
