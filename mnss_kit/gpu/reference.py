"""numpy reference of every runtime GPU pass: what the shaders compute, and the emulator's GPU stage.

:class:`ReferencePasses` and :class:`mnss_kit.gpu.mesa.MesaPasses` have the same methods with
the same arguments, so ``schedule.py`` runs a frame through either and the tests compare them
pass by pass.  The math is ``mnss_kit.ops`` (bilinear warp, sub-pixel insertion, inpainting,
conv, unsharp, quantize); this module adds only what the GPU's storage does to it: values
stored in an fp16 texture are rounded to float16 (nearest-even; the shaders round explicitly
because image stores may truncate), r32f / rg32f values stay float32, rgba8 display values are
8-bit codes (:func:`encode_unorm8`).

Arrays are ``(H, W, C)`` (HR) or ``(h, w, C)`` (LR) float32; jitter is ``(2,)`` LR pixels,
taken as float32 as the shaders' uniforms are.

The 3x3 convolution (inpainting weights and the AA net) is ``ops.inpaint.conv3x3`` unless the
passes are built with another function of identical values (``mnss_kit.emulate.fast_gpu``).
"""

from __future__ import annotations

import numpy as np

from ..ops import demodulation, fsr2, inpaint, sharpen, subpixel, taau, taau_lr, warp
from ..ops.sanitize import sanitize_colour, sanitize_depth, sanitize_motion
from ..ops.int8 import quantize as quant
from ..ops.resample import avgpool
from .passes import PACKED_GBUFFERS
from .weights import Conv3x3

EPILOGUES = ("none", "relu", "residual_clamp")


def to_half(x: np.ndarray) -> np.ndarray:
    """float32 array of the float16 values nearest to ``x`` (ties to even): an fp16 texture's contents."""
    return np.asarray(x, dtype=np.float32).astype(np.float16).astype(np.float32)


def encode_unorm8(v: np.ndarray) -> np.ndarray:
    """Display values -> 8-bit codes ``rint(clamp(v, 0, 1) * 255)`` (float32 product, ties to even); uint8."""
    clamped = np.clip(np.asarray(v, dtype=np.float32), np.float32(0), np.float32(1))
    return np.rint(clamped * np.float32(255)).astype(np.uint8)


def as_jitter(jitter) -> np.ndarray:
    """``(2,)`` float32 jitter, as a ``vec2`` uniform holds it."""
    return np.asarray(jitter, dtype=np.float32).reshape(2)


class ReferencePasses:
    """The runtime passes in numpy.  Inputs are rounded to their storage format on entry, as an
    upload to that texture format would round them.

    ``conv``: ``(h, w, Cin) float32, weight (Cout, Cin, 3, 3), bias (Cout,) -> (h, w, Cout) float32``
    with the values of ``ops.inpaint.conv3x3`` (the default)."""

    def __init__(self, conv=inpaint.conv3x3):
        self.conv = conv

    def warp(self, history, prev_depth, motion, prev_jitter, jitter, scale: int):
        """warp_pass.  history (H,W,3), prev_depth (h,w,1), motion (h,w,2) LR pixels ->
        (I_W (H,W,3) fp16 values, D_W at this frame's sampled sub-pixels (h,w,1) float32, ``ops.warp.OFFSCREEN_DEPTH``
        where the surface was outside the previous frame)."""
        hr_motion = warp.upsample_motion(sanitize_motion(np.asarray(motion, np.float32)), scale)
        hr_depth = subpixel.jittered_upsample(sanitize_depth(np.asarray(prev_depth, np.float32)), as_jitter(prev_jitter), scale)
        warped = warp.warp_bilinear(to_half(history), hr_motion)
        warped_depth = warp.warp_depth(hr_depth, hr_motion)
        return to_half(warped), subpixel.extract_samples(warped_depth, as_jitter(jitter), scale)

    def inpaint_weights(self, color, depth, warped, warped_depth, jitter, scale: int, conv: Conv3x3, activation: str):
        """inpaint_weights_pass -> LR weights (h,w,1) float32 in [0, 1]."""
        past = subpixel.extract_samples(to_half(warped), as_jitter(jitter), scale)
        return inpaint.lr_weights(sanitize_colour(to_half(color)), sanitize_depth(depth), past, warped_depth, conv.weight,
                                  conv.bias, activation, self.conv)

    def inpaint_blend(self, color, warped, lr_weight, jitter, scale: int, weight_upsample: str, reset: bool):
        """inpaint_blend_pass -> I_R (H,W,3) fp16 values; I_U on a reset (``warped``, ``lr_weight`` unused)."""
        upsampled = subpixel.jittered_upsample(sanitize_colour(to_half(color)), as_jitter(jitter), scale)
        if reset:
            return to_half(upsampled)
        weight = inpaint.weight_map(np.asarray(lr_weight, np.float32), as_jitter(jitter), scale, weight_upsample)
        return to_half(inpaint.rectify(upsampled, to_half(warped), weight))

    def avgpool(self, rectified, color, jitter, scale: int, history_at_samples: bool):
        """avgpool_pass -> AA net input (h,w,6 or 9) fp16 values: pooled I_R, with
        ``history_at_samples`` I_R at this frame's sampled sub-pixels, the colour
        (``model.config.aa_input_channels``)."""
        rectified = to_half(rectified)
        inputs = [avgpool(rectified, scale)]
        if history_at_samples:
            inputs.append(subpixel.extract_samples(rectified, as_jitter(jitter), scale))
        return to_half(np.concatenate([*inputs, sanitize_colour(to_half(color))], axis=-1))

    def conv3x3(self, x, conv: Conv3x3, epilogue: str, residual=None):
        """conv3x3_pass: (h,w,Cin) -> (h,w,Cout) fp16 values.  ``epilogue``: none, relu, or
        residual_clamp (``clamp(residual + conv, 0, 1)`` with ``residual`` (h,w,Cout))."""
        acc = self.conv(to_half(x), conv.weight, conv.bias)
        if epilogue == "relu":
            acc = np.maximum(acc, np.float32(0))
        elif epilogue == "residual_clamp":
            acc = np.clip(sanitize_colour(to_half(residual)) + acc, np.float32(0), np.float32(1))
        elif epilogue != "none":
            raise ValueError(f"unknown epilogue {epilogue!r} (one of {', '.join(EPILOGUES)})")
        return to_half(acc)

    def insert_pack(self, rectified, aa, jitter, scale: int, q_scale: float, q_zero_point: int, profile: str):
        """insert_pack_pass -> the int8 NPU input (1,H,W,3): I_AA inserted into I_R, quantized
        as ``ops.int8.quantize.quantize`` under ``profile``."""
        image = subpixel.insert_samples(to_half(rectified), to_half(aa), as_jitter(jitter), scale)
        return quant.quantize(image, q_scale, q_zero_point, "int8", profile)[None]

    def unpack_history(self, npu_output, q_scale: float, q_zero_point: int):
        """unpack_history_pass: int8 (1,H,W,3) -> (history (H,W,3) fp16 values, display (H,W,3) uint8)."""
        v = quant.dequantize(np.asarray(npu_output)[0], q_scale, q_zero_point)
        return to_half(v), encode_unorm8(v)

    def sharpen(self, image, beta: float):
        """sharpen_pass: (H,W,3) -> display (H,W,3) uint8 of ``ops.sharpen.unsharp``."""
        return encode_unorm8(sharpen.unsharp(to_half(image), beta))

    # -- FuseSR --------------------------------------------------------------------------------
    def demodulate(self, color, fbeta, emissive, demodulate: bool):
        """demodulate_pass -> (h,w,3) fp16 values: ``ops.demodulation.demodulate``, or the colour (sanitized)."""
        color = sanitize_colour(to_half(color))
        if not demodulate:
            return color
        return to_half(demodulation.demodulate(color, to_half(fbeta), to_half(emissive)))

    def gbuffer_pack(self, l, features, warped, gbuffers: dict, scale: int, history: bool, reset: bool, q_scale: float,
                     q_zero_point: int, profile: str):
        """gbuffer_pack_pass -> the int8 NPU input (1,h,w,C): [L, features, with ``history`` the warped
        history (zero on a reset, when ``warped`` is not read and may be None), the HR ``gbuffers`` ({name: (H,W,C)} in ``passes.PACKED_GBUFFERS``
        order, any subset)], HR images pixel-unshuffled (``ops.demodulation.pixel_unshuffle``), quantized as
        ``ops.int8.quantize.quantize`` under ``profile``.  Depth is r32f (float32), the rest fp16."""
        parts = [to_half(l)[..., :3], to_half(features)]
        if history:
            h, w = parts[0].shape[:2]
            hr = np.zeros((h * scale, w * scale, 3), np.float32) if reset else to_half(np.asarray(warped)[..., :3])
            parts.append(demodulation.pixel_unshuffle(hr, scale))
        for name in (g for g in PACKED_GBUFFERS if g in gbuffers):
            image = gbuffers[name]
            stored = sanitize_depth(np.asarray(image, np.float32)) if name == "depth" else to_half(image)
            parts.append(demodulation.pixel_unshuffle(stored, scale))
        return quant.quantize(np.concatenate(parts, axis=-1), q_scale, q_zero_point, "int8", profile)[None]

    def remodulate(self, npu_output, l, fbeta, emissive, scale: int, q_scale: float, q_zero_point: int, demodulate: bool):
        """remodulate_pass: int8 residual (1,H,W,3) and LR L (h,w,3) -> (history (H,W,3) fp16 values,
        display (H,W,3) uint8): ``ops.demodulation.add_upsampled``, then ``remodulate`` (the HR L itself
        without demodulation)."""
        v = quant.dequantize(np.asarray(npu_output)[0], q_scale, q_zero_point)
        v = demodulation.add_upsampled(v, to_half(np.asarray(l)[..., :3]), scale)
        if demodulate:
            v = demodulation.remodulate(v, to_half(fbeta), to_half(emissive))
        return to_half(v), encode_unorm8(v)

    def taau_reproject(self, history, motion, scale: int, reset: bool, blur_penalty: float):
        """taau_reproject_pass.  history (H,W,4): the previous output (rgb) and its weight (a);
        motion (h,w,2) LR pixels -> (H,W,4) fp16 values: the reprojected YCoCg history and its weight."""
        stored = to_half(history)
        colour, weight = taau.reprojected_history(stored[..., :3], stored[..., 3:], sanitize_motion(motion), reset, scale,
                                                   True, blur_penalty)
        return to_half(np.concatenate([colour, weight], axis=-1))

    def taau_pack(self, color, reprojected, scale: int, max_weight: float, q_scale: float, q_zero_point: int, profile: str):
        """taau_pack_pass -> the int8 NPU input (1,h,w,3 + 5 s^2): the LR colour, then the clamped
        history, its weight / ``max_weight`` and the clamp distance pixel-unshuffled, quantized as
        ``ops.int8.quantize.quantize`` under ``profile``."""
        r = to_half(reprojected)
        features = taau.steering_features(sanitize_colour(to_half(color)), r[..., :3], r[..., 3:], scale, max_weight)
        return quant.quantize(features, q_scale, q_zero_point, "int8", profile)[None]

    def taau_accumulate(self, npu_output, color, reprojected, motion, jitter, scale: int, q_scale: float, q_zero_point: int,
                        correction_bound: float, box_bound: float, history_gain_min: float, still_motion_px: float,
                        sample_sigma: float, prior_weight: float, max_weight: float):
        """taau_accumulate_pass.  npu_output (1,H,W,6 or 8) int8 raw steering (the first six used), color
        (h,w,3), reprojected (H,W,4), motion (h,w,2) -> (history (H,W,4) fp16 values: the uncorrected
        blend and its weight, display (H,W,3) uint8 codes of the corrected output, without the display filter)."""
        raw = quant.dequantize(np.asarray(npu_output, np.int8), q_scale, q_zero_point)[0, ..., :6]
        terms = taau.current_terms(sanitize_colour(to_half(color)), as_jitter(jitter), scale, sample_sigma)
        r = to_half(reprojected)
        floor = taau.history_floor(sanitize_motion(motion), scale, history_gain_min, still_motion_px)
        output, history, weight = taau.blend(*terms, r[..., :3], r[..., 3:], prior_weight, max_weight,
                                             taau.steer_from_raw(raw, correction_bound, floor, box_bound=box_bound))
        return to_half(np.concatenate([history, weight], axis=-1)), encode_unorm8(output)

    def taau_filter(self, npu_output, history, motion, scale: int, q_scale: float, q_zero_point: int,
                    correction_bound: float, filter_bound: float, filter_falloff: float):
        """taau_filter_pass.  npu_output (1,H,W,8) int8 raw steering, history (H,W,4) this frame's blend,
        motion (h,w,2) -> display (H,W,3) uint8 codes: the blend through the steered filter (faded by
        ``taau.filter_gain``), plus the correction."""
        raw = quant.dequantize(np.asarray(npu_output, np.int8), q_scale, q_zero_point)[0]
        gain = taau.filter_gain(sanitize_motion(motion), scale, filter_falloff)
        steer = taau.steer_from_raw(raw, correction_bound, 0.0, filter_bound, filter_scale=gain)
        return encode_unorm8(taau.display(to_half(history)[..., :3], steer))

    # -- ntaau_lr ------------------------------------------------------------------------------
    def taau_lr_reproject(self, history, motion, reset: bool, blur_penalty: float):
        """taau_lr_reproject_pass: ``taau_reproject`` at any scale, the LR motion resized to the
        history's size (``ops.taau.hr_motion_of``)."""
        return self.taau_reproject(history, motion, 0, reset, blur_penalty)

    def taau_lr_evidence(self, depth, prev_depth, motion, reset: bool, trust_depth: float, trust_spread_px: float):
        """taau_lr_evidence_pass.  depth, prev_depth (h,w,1), motion (h,w,2) -> (h,w,4) float32: the
        depth change, the motion spread, the trust, 0 (``ops.taau_lr.evidence``); on a reset this
        frame's depth stands in for the previous one (``prev_depth`` unused)."""
        depth = sanitize_depth(np.asarray(depth, np.float32))
        previous = depth if reset else sanitize_depth(np.asarray(prev_depth, np.float32))
        return taau_lr.evidence(depth, previous, sanitize_motion(np.asarray(motion, np.float32)), float(np.float32(trust_depth)),
                                float(np.float32(trust_spread_px)))

    def taau_lr_pack(self, color, reprojected, evidence, scale: int, reset: bool, max_weight: float, q_scale: float,
                     q_zero_point: int, profile: str, scale_input: float = 0.0):
        """taau_lr_pack_pass -> the int8 NPU input (1,h',w',8), h' and w' even: ``ops.taau_lr.steering_features``
        quantized as ``ops.int8.quantize.quantize`` under ``profile``.  On a reset the history is zero (colour
        and weight), as the model's state after a cut; ``reprojected`` is not read."""
        e = np.asarray(evidence, np.float32)
        hr_shape = np.asarray(reprojected).shape[:2]  # the HR size at any scale (u_scale 0: a fractional one)
        r = np.zeros((*hr_shape, 4), np.float32) if reset else to_half(reprojected)
        features = taau_lr.steering_features(sanitize_colour(to_half(color)), r[..., :3], r[..., 3:], e[..., 0:1], e[..., 1:2],
                                             scale, max_weight, float(np.float32(scale_input)))
        return quant.quantize(features, q_scale, q_zero_point, "int8", profile)[None]

    def taau_lr_accumulate(self, npu_output, color, reprojected, evidence, jitter, scale: int, q_scale: float, q_zero_point: int,
                           box_bound: float, sample_sigma: float, prior_weight: float, max_weight: float):
        """taau_lr_accumulate_pass.  npu_output (1,h',w',6) int8 raw LR steering, color (h,w,3), reprojected
        (H,W,4), evidence (h,w,4) -> (history (H,W,4) fp16 values: the blend and its weight, display (H,W,3)
        uint8 codes of the blend, without the display filter)."""
        h, w = np.asarray(color).shape[:2]
        hr_size = (np.asarray(reprojected).shape[1], np.asarray(reprojected).shape[0])  # u_scale 0: the sizes give the ratio
        raw = quant.dequantize(np.asarray(npu_output, np.int8), q_scale, q_zero_point)[0, :h, :w]
        steer = taau_lr.steer_from_lr(raw, np.asarray(evidence, np.float32)[..., 2:3], scale, box_bound, 0.0, hr_size)
        terms = taau.current_terms(sanitize_colour(to_half(color)), as_jitter(jitter), scale, sample_sigma, hr_size)
        r = to_half(reprojected)
        _, history, weight = taau.blend(*terms, r[..., :3], r[..., 3:], prior_weight, max_weight, steer)
        return to_half(np.concatenate([history, weight], axis=-1)), encode_unorm8(history)

    def taau_lr_filter(self, npu_output, history, scale: int, q_scale: float, q_zero_point: int, filter_bound: float,
                       lr_size=None):
        """taau_lr_filter_pass.  npu_output (1,h',w',6) int8 raw LR steering, history (H,W,4) this frame's
        blend -> display (H,W,3) uint8 codes: the blend through the steered filter (``ops.taau_lr.filter_weights``).
        ``scale`` 0: a fractional scale, the LR size ``lr_size`` ``(w, h)`` (``u_lr_size``)."""
        if scale:
            h, w = history.shape[0] // scale, history.shape[1] // scale
        else:
            w, h = (int(v) for v in lr_size)
        raw = quant.dequantize(np.asarray(npu_output, np.int8), q_scale, q_zero_point)[0, :h, :w]
        axis, diagonal = taau_lr.filter_weights(raw, scale, filter_bound, (history.shape[1], history.shape[0]))
        return encode_unorm8(taau.display(to_half(history)[..., :3], taau.Steer(filter_axis=axis, filter_diagonal=diagonal)))

    # -- fsr2 ----------------------------------------------------------------------------------
    def fsr2_reconstruct(self, depth, motion, params: fsr2.FSR2Params):
        """fsr2_reconstruct_pass.  depth (h,w,1), motion (h,w,2) -> (dilated (h,w,4): the nearest
        neighbour's depth and motion across an edge (``ops.fsr2.dilate``), 0; previous_depth (h*w,) uint32: the bits of
        ``ops.fsr2.reconstruct_previous_depth_encoded``, 0 where no surface landed)."""
        depth, motion = sanitize_depth(np.asarray(depth, np.float32)), sanitize_motion(np.asarray(motion, np.float32))
        dilated_depth, dilated_motion = fsr2.dilate(depth, motion, params.dilation_edge)
        encoded = fsr2.reconstruct_previous_depth_encoded(dilated_depth, dilated_motion)
        dilated = np.concatenate([dilated_depth, dilated_motion, np.zeros_like(dilated_depth)], axis=-1)
        return dilated, encoded.reshape(-1).view(np.uint32).copy()

    def fsr2_depth_clip(self, dilated, color, previous_depth, params: fsr2.FSR2Params):
        """fsr2_depth_clip_pass -> analysis (h,w,4): ``ops.fsr2.disocclusion``, ``thin_features``, 0, 0."""
        h, w = dilated.shape[:2]
        previous = fsr2.decode_depth(np.asarray(previous_depth, np.uint32).view(np.float32).reshape(h, w))[..., None]
        clip = fsr2.disocclusion(dilated[..., 0:1], dilated[..., 1:3], previous, params)
        thin = fsr2.thin_features(sanitize_colour(to_half(color))[..., :3], params.lock_contrast)
        return np.concatenate([clip, thin, np.zeros((h, w, 2), np.float32)], axis=-1)

    def fsr2_accumulate(self, color, dilated, analysis, history, locks, reactive, previous_depth, jitter, scale: int,
                        reset: bool, params: fsr2.FSR2Params):
        """fsr2_accumulate_pass -> (next_history (H,W,4) and next_locks (H,W,2) fp16 values of
        ``ops.fsr2.accumulate``, previous_depth cleared to zeros).  ``reactive`` (h,w,1) or None."""
        next_history, next_locks = fsr2.accumulate(
            sanitize_colour(to_half(color))[..., :3], dilated[..., 1:3], analysis[..., 0:2],
            to_half(history), to_half(locks)[..., :2], as_jitter(jitter), scale, reset, params,
            None if reactive is None else np.asarray(reactive, np.float32))
        return to_half(next_history), to_half(next_locks), np.zeros_like(np.asarray(previous_depth, np.uint32))

    def fsr2_rcas(self, image, sharpness: float):
        """fsr2_rcas_pass: (H,W,3) -> (H,W,3) fp16 values of ``ops.fsr2.rcas``."""
        return to_half(fsr2.rcas(to_half(image)[..., :3], float(np.float32(sharpness))))
