"""The GPU passes called with positional arguments, as these tests were written: each method builds
one ``gpu.passes.Call`` and runs it through the wrapped backend's ``run_pass``, so the shader and
the reference always see the same bindings and uniforms.  A new pass's test may call ``run_pass``
directly instead."""

from __future__ import annotations

import numpy as np

from mnss_kit.gpu.passes import (ACTIVATION_CODES, PACKED_GBUFFERS, WEIGHT_UPSAMPLE_CODES, call, dequantize_uniforms,
                                 fsr2_uniforms, quantize_uniforms)
from mnss_kit.gpu.passes.conv3x3_pass import layer_uniforms


def _words(nbytes: int) -> int:
    return -(-nbytes // 4)


def _detail_uniforms(npu_output, detail_bound: float) -> dict:
    """ntaau_lr's detail uniforms: the NPU output's channels after the 6 steering ones, and the patch's bound (0: not drawn)."""
    return {"u_detail_channels": int(npu_output.shape[-1]) - 6, "u_detail_bound": float(detail_bound)}


class NamedPasses:
    """``backend`` (a ``ReferencePasses`` or ``MesaPasses``) with one method per pass; any other
    attribute is the backend's."""

    def __init__(self, backend):
        self.backend = backend

    def __getattr__(self, name):
        return getattr(self.backend, name)

    def _run(self, name, read, uniforms, jitter=(0.0, 0.0), previous=None, scale=0, profile="tflite-ref"):
        return self.backend.run_pass(name, call(read, uniforms, jitter, previous, scale, profile))

    def warp(self, history, prev_depth, motion, prev_jitter, jitter, scale):
        out = self._run("warp_pass", {"history": history, "prev_depth": prev_depth, "motion": motion}, {"u_scale": scale},
                        jitter, prev_jitter, scale)
        return out["warped"], out["warped_depth"]

    def inpaint_weights(self, color, depth, warped, warped_depth, jitter, scale, conv, activation):
        read = {"color": color, "depth": depth, "warped": warped, "warped_depth": warped_depth, "weights": conv}
        return self._run("inpaint_weights_pass", read, {"u_scale": scale, "u_activation": ACTIVATION_CODES[activation]},
                         jitter, None, scale)["lr_weight"]

    def inpaint_blend(self, color, warped, lr_weight, jitter, scale, weight_upsample, reset):
        uniforms = {"u_scale": scale, "u_weight_upsample": WEIGHT_UPSAMPLE_CODES[weight_upsample], "u_reset": int(reset)}
        return self._run("inpaint_blend_pass", {"color": color, "warped": warped, "lr_weight": lr_weight}, uniforms,
                         jitter, None, scale)["rectified"]

    def avgpool(self, rectified, color, jitter, scale, history_at_samples):
        return self._run("avgpool_pass", {"rectified": rectified, "color": color},
                         {"u_scale": scale, "u_history_at_samples": int(history_at_samples)}, jitter, None, scale)["aa_input"]

    def conv3x3(self, x, conv, epilogue, residual=None):
        return self._run("conv3x3_pass", {"x": x, "residual": residual, "weights": conv},
                         layer_uniforms(conv.in_channels, conv.out_channels, epilogue))["y"]

    def insert_pack(self, rectified, aa, jitter, scale, q_scale, q_zero_point, profile):
        hh, hw = rectified.shape[:2]
        uniforms = {"u_scale": scale, "u_word_count": _words(hh * hw * 3), **quantize_uniforms(q_scale, q_zero_point, profile)}
        return self._run("insert_pack_pass", {"rectified": rectified, "aa": aa}, uniforms, jitter, None, scale, profile)["npu_input"]

    def unpack_history(self, npu_output, q_scale, q_zero_point):
        out = self._run("unpack_history_pass", {"npu_output": npu_output}, dequantize_uniforms(q_scale, q_zero_point))
        return out["history"], out["display"]

    def sharpen(self, image, beta):
        return self._run("sharpen_pass", {"image": image}, {"u_beta": float(np.float32(beta))})["display"]

    def demodulate(self, color, fbeta, emissive, demodulate):
        return self._run("demodulate_pass", {"color": color, "fbeta": fbeta, "emissive": emissive},
                         {"u_demodulate": int(demodulate)})["l"]

    def gbuffer_pack(self, l, features, warped, gbuffers, scale, history, reset, q_scale, q_zero_point, profile):
        h, w = l.shape[:2]
        channels = 3 + features.shape[-1] + (3 * scale * scale if history else 0)
        channels += sum(g.shape[-1] for g in gbuffers.values()) * scale * scale
        mask = sum(1 << i for i, name in enumerate(PACKED_GBUFFERS) if name in gbuffers)
        uniforms = {"u_scale": scale, "u_features": features.shape[-1], "u_history": int(history), "u_reset": int(reset),
                    "u_gbuffers": mask, "u_word_count": _words(h * w * channels),
                    **quantize_uniforms(q_scale, q_zero_point, profile)}
        read = {"l": l, "features": features, "warped": warped, **{g: gbuffers.get(g) for g in PACKED_GBUFFERS}}
        return self._run("gbuffer_pack_pass", read, uniforms, profile=profile)["npu_input"]

    def remodulate(self, npu_output, l, fbeta, emissive, scale, q_scale, q_zero_point, demodulate):
        uniforms = {"u_scale": scale, **dequantize_uniforms(q_scale, q_zero_point), "u_demodulate": int(demodulate)}
        out = self._run("remodulate_pass", {"npu_output": npu_output, "l": l, "fbeta": fbeta, "emissive": emissive}, uniforms)
        return out["history"], out["display"]

    def taau_reproject(self, history, motion, scale, reset, blur_penalty):
        return self._run("taau_reproject_pass", {"history": history, "motion": motion},
                         {"u_scale": scale, "u_reset": int(reset), "u_blur_penalty": float(blur_penalty)})["reprojected"]

    def taau_pack(self, color, reprojected, scale, max_weight, q_scale, q_zero_point, profile):
        h, w = color.shape[:2]
        uniforms = {"u_scale": scale, "u_max_weight": float(max_weight), "u_word_count": _words(h * w * (3 + 5 * scale * scale)),
                    **quantize_uniforms(q_scale, q_zero_point, profile)}
        return self._run("taau_pack_pass", {"color": color, "reprojected": reprojected}, uniforms, profile=profile)["npu_input"]

    def taau_accumulate(self, npu_output, color, reprojected, motion, jitter, scale, q_scale, q_zero_point, correction_bound,
                        box_bound, history_gain_min, still_motion_px, sample_sigma, prior_weight, max_weight):
        uniforms = {"u_scale": scale, "u_steer_channels": int(npu_output.shape[-1]), **dequantize_uniforms(q_scale, q_zero_point),
                    "u_correction_bound": float(correction_bound), "u_box_bound": float(box_bound),
                    "u_history_gain_min": float(history_gain_min), "u_still_motion_px": float(still_motion_px),
                    "u_sample_sigma": float(sample_sigma), "u_prior_weight": float(prior_weight), "u_max_weight": float(max_weight)}
        read = {"npu_output": npu_output, "color": color, "reprojected": reprojected, "motion": motion}
        out = self._run("taau_accumulate_pass", read, uniforms, jitter, None, scale)
        return out["history"], out["display"]

    def taau_filter(self, npu_output, history, motion, scale, q_scale, q_zero_point, correction_bound, filter_bound,
                    filter_falloff):
        uniforms = {"u_scale": scale, **dequantize_uniforms(q_scale, q_zero_point), "u_correction_bound": float(correction_bound),
                    "u_filter_bound": float(filter_bound), "u_filter_falloff": float(filter_falloff)}
        return self._run("taau_filter_pass", {"npu_output": npu_output, "history": history, "motion": motion}, uniforms)["display"]

    def taau_lr_reproject(self, history, motion, reset, blur_penalty):
        return self._run("taau_lr_reproject_pass", {"history": history, "motion": motion},
                         {"u_reset": int(reset), "u_blur_penalty": float(blur_penalty)})["reprojected"]

    def taau_lr_evidence(self, depth, prev_depth, motion, reset, trust_depth, trust_spread_px):
        return self._run("taau_lr_evidence_pass", {"depth": depth, "prev_depth": prev_depth, "motion": motion},
                         {"u_reset": int(reset), "u_trust_depth": float(trust_depth),
                          "u_trust_spread_px": float(trust_spread_px)})["evidence"]

    def taau_lr_pack(self, color, reprojected, evidence, scale, reset, max_weight, q_scale, q_zero_point, profile,
                     scale_input=0.0, detail=False):
        h, w = color.shape[:2]
        words = _words((h + h % 2) * (w + w % 2) * (8 + (1 if scale_input else 0) + (scale * scale if detail else 0)))
        uniforms = {"u_scale": scale, "u_reset": int(reset), "u_max_weight": float(max_weight), "u_word_count": words,
                    "u_scale_input": float(np.float32(scale_input)), "u_detail": int(detail),
                    **quantize_uniforms(q_scale, q_zero_point, profile)}
        read = {"color": color, "reprojected": reprojected, "evidence": evidence}
        return self._run("taau_lr_pack_pass", read, uniforms, profile=profile)["npu_input"]

    def taau_lr_accumulate(self, npu_output, color, reprojected, evidence, jitter, scale, q_scale, q_zero_point, box_bound,
                           sample_sigma, prior_weight, max_weight, motion=None, history_gain_min=0.0, still_motion_px=0.0,
                           detail_bound=0.0):
        """``npu_output`` with 10 channels: a detail branch's (the patch drawn when ``detail_bound`` > 0)."""
        uniforms = {"u_scale": scale, **dequantize_uniforms(q_scale, q_zero_point), "u_box_bound": float(box_bound),
                    "u_history_gain_min": float(history_gain_min), "u_still_motion_px": float(still_motion_px),
                    "u_sample_sigma": float(sample_sigma), "u_prior_weight": float(prior_weight), "u_max_weight": float(max_weight),
                    **_detail_uniforms(npu_output, detail_bound)}
        if motion is None:  # no floor that fades with the motion: it is not read
            motion = np.zeros((*color.shape[:2], 2), np.float32)
        read = {"npu_output": npu_output, "color": color, "reprojected": reprojected, "evidence": evidence, "motion": motion}
        out = self._run("taau_lr_accumulate_pass", read, uniforms, jitter, None, scale)
        return out["history"], out["display"]

    def taau_lr_filter(self, npu_output, history, scale, q_scale, q_zero_point, filter_bound, lr_size=None, detail_bound=0.0):
        hh, hw = history.shape[:2]
        lr = tuple(int(v) for v in lr_size) if lr_size is not None else (hw // scale, hh // scale)
        uniforms = {"u_scale": scale, "u_lr_size": lr, **dequantize_uniforms(q_scale, q_zero_point),
                    "u_filter_bound": float(filter_bound), **_detail_uniforms(npu_output, detail_bound)}
        return self._run("taau_lr_filter_pass", {"npu_output": npu_output, "history": history}, uniforms)["display"]

    def fsr2_reconstruct(self, depth, motion, params):
        out = self._run("fsr2_reconstruct_pass", {"depth": depth, "motion": motion}, fsr2_uniforms(params))
        return out["dilated"], out["previous_depth"]

    def fsr2_depth_clip(self, dilated, color, previous_depth, params):
        read = {"dilated": dilated, "color": color, "previous_depth": previous_depth}
        return self._run("fsr2_depth_clip_pass", read, fsr2_uniforms(params))["analysis"]

    def fsr2_accumulate(self, color, dilated, analysis, history, locks, reactive, previous_depth, jitter, scale, reset, params):
        read = {"color": color, "dilated": dilated, "analysis": analysis, "history": history, "locks": locks, "reactive": reactive,
                "previous_depth": previous_depth}
        uniforms = {**fsr2_uniforms(params, scale), "u_scale": scale, "u_reset": int(reset), "u_use_reactive": int(reactive is not None)}
        out = self._run("fsr2_accumulate_pass", read, uniforms, jitter, None, scale)
        return out["next_history"], out["next_locks"], out["previous_depth"]

    def fsr2_rcas(self, image, sharpness):
        return self._run("fsr2_rcas_pass", {"image": image}, {"u_sharpness": float(np.float32(sharpness))})["output_image"]
