"""The one frame loop: a bundle's per-frame schedule run step by step, as the phone runs it.

The schedule (``Family.gpu_plan``, written into ``manifest.json``) is the single definition of
what runs in which order on GPU and NPU.  :class:`ScheduleRunner` keeps every resource the
schedule names (textures and buffers, as numpy arrays), fills the inputs each frame, runs each
GPU step through a passes backend (:class:`~.reference.ReferencePasses` or
:class:`~.mesa.MesaPasses`, both with the same methods) and each NPU step through a callable,
skips the ``skip_on_reset`` steps on a reset frame, and applies ``end_of_frame`` swaps.  At the
start of a sequence every ``state`` resource is zero, as a freshly allocated texture.

``PASS_CALLS`` is the one place that knows how a pass's bindings and uniforms map to the
backend's method arguments.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import UserError
from ..ops.jitter import subpixel_index
from . import passes as P
from .weights import Conv3x3


def _inverse(codes: dict[str, int]) -> dict[int, str]:
    return {v: k for k, v in codes.items()}


ACTIVATIONS, WEIGHT_UPSAMPLES, EPILOGUES = (_inverse(P.ACTIVATION_CODES), _inverse(P.WEIGHT_UPSAMPLE_CODES),
                                            _inverse(P.EPILOGUE_CODES))


@dataclass
class Call:
    """What one GPU step sees: bound resources (``read``; an output binding reads its old value), uniform
    values (a reset arrives as ``u_reset``), learned weights, frame context."""

    read: dict[str, np.ndarray | None]
    uniforms: dict
    weights: dict[str, Conv3x3]
    offset: np.ndarray  # this frame's jitter, LR pixels
    previous_offset: np.ndarray
    profile: str  # numerics profile of the NPU-input quantization

    def u(self, name: str):
        return self.uniforms[name]


def _warp(p, c: Call):
    warped, depth = p.warp(c.read["history"], c.read["prev_depth"], c.read["motion"], c.previous_offset, c.offset, c.u("u_scale"))
    return {"warped": warped, "warped_depth": depth}


def _inpaint_weights(p, c: Call):
    r = c.read
    return {"lr_weight": p.inpaint_weights(r["color"], r["depth"], r["warped"], r["warped_depth"], c.offset, c.u("u_scale"),
                                           c.weights["weights"], ACTIVATIONS[c.u("u_activation")])}


def _inpaint_blend(p, c: Call):
    reset = bool(c.u("u_reset"))
    warped, weight = (None, None) if reset else (c.read["warped"], c.read["lr_weight"])
    return {"rectified": p.inpaint_blend(c.read["color"], warped, weight, c.offset, c.u("u_scale"),
                                         WEIGHT_UPSAMPLES[c.u("u_weight_upsample")], reset)}


def _avgpool(p, c: Call):
    return {"aa_input": p.avgpool(c.read["rectified"], c.read["color"], c.offset, c.u("u_scale"), bool(c.u("u_history_at_samples")))}


def _conv3x3(p, c: Call):
    epilogue = EPILOGUES[c.u("u_epilogue")]
    residual = c.read["residual"] if epilogue == "residual_clamp" else None
    return {"y": p.conv3x3(c.read["x"], c.weights["weights"], epilogue, residual)}


def _insert_pack(p, c: Call):
    return {"npu_input": p.insert_pack(c.read["rectified"], c.read["aa"], c.offset, c.u("u_scale"), c.u("u_q_scale"),
                                       c.u("u_q_zero_point"), c.profile)}


def _unpack_history(p, c: Call):
    history, display = p.unpack_history(c.read["npu_output"], c.u("u_q_scale"), c.u("u_q_zero_point"))
    return {"history": history, "display": display}


def _sharpen(p, c: Call):
    return {"display": p.sharpen(c.read["image"], c.u("u_beta"))}


def _demodulate(p, c: Call):
    return {"l": p.demodulate(c.read["color"], c.read["fbeta"], c.read["emissive"], bool(c.u("u_demodulate")))}


def _gbuffer_pack(p, c: Call):
    mask = c.u("u_gbuffers")
    gbuffers = {name: c.read[name] for i, name in enumerate(P.PACKED_GBUFFERS) if mask & (1 << i)}
    features = c.read["features"][..., : c.u("u_features")]
    return {"npu_input": p.gbuffer_pack(c.read["l"], features, c.read["warped"], gbuffers, c.u("u_scale"),
                                        bool(c.u("u_history")), bool(c.u("u_reset")),
                                        c.u("u_q_scale"), c.u("u_q_zero_point"), c.profile)}


def _remodulate(p, c: Call):
    history, display = p.remodulate(c.read["npu_output"], c.read["l"], c.read["fbeta"], c.read["emissive"], c.u("u_scale"),
                                    c.u("u_q_scale"), c.u("u_q_zero_point"), bool(c.u("u_demodulate")))
    return {"history": history, "display": display}


def _taau_reproject(p, c: Call):
    return {"reprojected": p.taau_reproject(c.read["history"], c.read["motion"], c.u("u_scale"), bool(c.u("u_reset")),
                                            c.u("u_blur_penalty"))}


def _taau_pack(p, c: Call):
    return {"npu_input": p.taau_pack(c.read["color"], c.read["reprojected"], c.u("u_scale"), c.u("u_max_weight"),
                                     c.u("u_q_scale"), c.u("u_q_zero_point"), c.profile)}


def _taau_accumulate(p, c: Call):
    history, display = p.taau_accumulate(c.read["npu_output"], c.read["color"], c.read["reprojected"], c.read["motion"], c.offset,
                                         c.u("u_scale"), c.u("u_q_scale"), c.u("u_q_zero_point"), c.u("u_correction_bound"),
                                         c.u("u_box_bound"), c.u("u_history_gain_min"), c.u("u_still_motion_px"), c.u("u_sample_sigma"),
                                         c.u("u_prior_weight"), c.u("u_max_weight"))
    return {"history": history, "display": display}


def _taau_filter(p, c: Call):
    display = p.taau_filter(c.read["npu_output"], c.read["history"], c.read["motion"], c.u("u_scale"), c.u("u_q_scale"),
                            c.u("u_q_zero_point"), c.u("u_correction_bound"), c.u("u_filter_bound"), c.u("u_filter_falloff"))
    return {"display": display}


def _taau_lr_reproject(p, c: Call):
    return {"reprojected": p.taau_lr_reproject(c.read["history"], c.read["motion"], bool(c.u("u_reset")), c.u("u_blur_penalty"))}


def _taau_lr_evidence(p, c: Call):
    return {"evidence": p.taau_lr_evidence(c.read["depth"], c.read["prev_depth"], c.read["motion"], bool(c.u("u_reset")),
                                           c.u("u_trust_depth"), c.u("u_trust_spread_px"))}


def _taau_lr_pack(p, c: Call):
    return {"npu_input": p.taau_lr_pack(c.read["color"], c.read["reprojected"], c.read["evidence"], c.u("u_scale"),
                                        bool(c.u("u_reset")), c.u("u_max_weight"), c.u("u_q_scale"), c.u("u_q_zero_point"), c.profile,
                                        c.uniforms.get("u_scale_input", 0.0))}


def _taau_lr_accumulate(p, c: Call):
    history, display = p.taau_lr_accumulate(c.read["npu_output"], c.read["color"], c.read["reprojected"], c.read["evidence"],
                                            c.offset, c.u("u_scale"), c.u("u_q_scale"), c.u("u_q_zero_point"), c.u("u_box_bound"),
                                            c.u("u_sample_sigma"), c.u("u_prior_weight"), c.u("u_max_weight"))
    return {"history": history, "display": display}


def _taau_lr_filter(p, c: Call):
    return {"display": p.taau_lr_filter(c.read["npu_output"], c.read["history"], c.u("u_scale"), c.u("u_q_scale"),
                                        c.u("u_q_zero_point"), c.u("u_filter_bound"), c.u("u_lr_size"))}


def _fsr2_reconstruct(p, c: Call):
    dilated, previous_depth = p.fsr2_reconstruct(c.read["depth"], c.read["motion"], P.fsr2_params_from_uniforms(c.uniforms))
    return {"dilated": dilated, "previous_depth": previous_depth}


def _fsr2_depth_clip(p, c: Call):
    params = P.fsr2_params_from_uniforms(c.uniforms)
    return {"analysis": p.fsr2_depth_clip(c.read["dilated"], c.read["color"], c.read["previous_depth"], params)}


def _fsr2_accumulate(p, c: Call):
    r = c.read
    history, locks, previous_depth = p.fsr2_accumulate(
        r["color"], r["dilated"], r["analysis"], r["history"], r["locks"], r["reactive"] if c.u("u_use_reactive") else None,
        r["previous_depth"], c.offset, c.u("u_scale"), bool(c.u("u_reset")), P.fsr2_params_from_uniforms(c.uniforms))
    return {"next_history": history, "next_locks": locks, "previous_depth": previous_depth}


def _fsr2_rcas(p, c: Call):
    return {"output_image": p.fsr2_rcas(c.read["image"], c.u("u_sharpness"))}


# pass name -> (backend, call) -> {image or buffer binding written: array}
PASS_CALLS: dict[str, Callable[[object, Call], dict]] = {
    "warp_pass": _warp,
    "inpaint_weights_pass": _inpaint_weights,
    "inpaint_blend_pass": _inpaint_blend,
    "avgpool_pass": _avgpool,
    "conv3x3_pass": _conv3x3,
    "insert_pack_pass": _insert_pack,
    "unpack_history_pass": _unpack_history,
    "sharpen_pass": _sharpen,
    "demodulate_pass": _demodulate,
    "gbuffer_pack_pass": _gbuffer_pack,
    "remodulate_pass": _remodulate,
    "taau_reproject_pass": _taau_reproject,
    "taau_pack_pass": _taau_pack,
    "taau_accumulate_pass": _taau_accumulate,
    "taau_filter_pass": _taau_filter,
    "taau_lr_reproject_pass": _taau_lr_reproject,
    "taau_lr_evidence_pass": _taau_lr_evidence,
    "taau_lr_pack_pass": _taau_lr_pack,
    "taau_lr_accumulate_pass": _taau_lr_accumulate,
    "taau_lr_filter_pass": _taau_lr_filter,
    "fsr2_reconstruct_pass": _fsr2_reconstruct,
    "fsr2_depth_clip_pass": _fsr2_depth_clip,
    "fsr2_accumulate_pass": _fsr2_accumulate,
    "fsr2_rcas_pass": _fsr2_rcas,
}


@dataclass
class StepResult:
    """One step of a frame: its schedule entry and what it wrote (resource name -> array)."""

    step: dict
    written: dict[str, np.ndarray]


class ScheduleRunner:
    """Run a bundle schedule frame by frame, resources kept between frames as on the phone.

    ``resources``, ``schedule``: the manifest's; ``weights``: block name -> :class:`Conv3x3`;
    ``npu``: ``{tensor: array} -> {tensor: array}`` for an NPU step; ``profile``: the numerics
    profile of the NPU-input quantization.
    """

    def __init__(self, resources: list[dict], schedule: dict, weights: dict[str, Conv3x3], passes,
                 npu: Callable[[dict, dict], dict], profile: str, scale: int):
        missing = sorted({s["pass"] for s in schedule["steps"] if s["kind"] == "gpu"} - set(PASS_CALLS))
        if missing:
            raise UserError(f"the schedule uses GPU passes this toolkit does not run: {', '.join(missing)}")
        self.resources = {r["name"]: r for r in resources}
        self.schedule, self.weights, self.passes, self.npu = schedule, weights, passes, npu
        self.profile, self.scale = profile, scale
        self.inputs = [r["name"] for r in resources if r["role"] == "input"]
        self.state = [r for r in resources if r["role"] == "state"]
        self.values: dict[str, np.ndarray | None] = {}
        self.previous_offset: np.ndarray | None = None

    def reset(self) -> None:
        """Forget every resource: the next frame starts a sequence."""
        self.values, self.previous_offset = {}, None

    def run_frame(self, inputs: dict[str, np.ndarray], jitter, reset: bool) -> list[StepResult]:
        """One frame: ``inputs`` for every input resource; returns each step's writes in order."""
        offset = np.asarray(jitter, np.float32).reshape(2)
        if self.previous_offset is None:  # a sequence starts: state textures as freshly allocated, zero
            for r in self.state:
                self.values[r["name"]] = np.zeros((r["size"][1], r["size"][0], r["channels"]), np.float32)
        reset = bool(reset) or self.previous_offset is None
        previous = offset if self.previous_offset is None else self.previous_offset
        frame = {"offset": offset, "subpixel": subpixel_index(offset, self.scale), "previous_offset": previous,
                 "previous_subpixel": subpixel_index(previous, self.scale), "reset": int(reset)}
        for name in self.inputs:
            self.values[name] = inputs[name]
        results = []
        for step in self.schedule["steps"]:
            if step.get("skip_on_reset") and reset:
                continue
            written = self._gpu(step, frame, offset, previous) if step["kind"] == "gpu" else self._npu(step)
            self.values.update(written)
            results.append(StepResult(step, written))
        for action in self.schedule.get("end_of_frame", []):
            a, b = action["swap"]
            self.values[a], self.values[b] = self.values.get(b), self.values.get(a)
        self.previous_offset = offset
        return results

    def _gpu(self, step: dict, frame: dict, offset, previous) -> dict[str, np.ndarray]:
        """Run one GPU step; what its pass call returns (by binding name) is written to the bound resources."""
        read, weights = {}, {}
        for binding in P.PASSES[step["pass"]].bindings:
            target = step["bind"][binding.name]
            if target.startswith("weights:"):
                weights[binding.name] = self.weights[target[len("weights:"):]]
            else:
                read[binding.name] = self.values.get(target)
        uniforms = {name: (frame[v["frame"]] if "frame" in v else v["value"]) for name, v in step["uniforms"].items()}
        produced = PASS_CALLS[step["pass"]](self.passes, Call(read, uniforms, weights, offset, previous, self.profile))
        return {step["bind"][name]: value for name, value in produced.items()}

    def _npu(self, step: dict) -> dict[str, np.ndarray]:
        feeds = {tensor: self.values[resource] for tensor, resource in step["inputs"].items()}
        results = self.npu(step, feeds)
        return {resource: results[tensor] for tensor, resource in step["outputs"].items()}
