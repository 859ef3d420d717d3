"""A second model family, defined only here: the pipeline takes it without any code knowing it.

``toy`` is deliberately unlike MNSS: a single-frame net (no history, no state) that reads an HR
G-buffer.  Its GPU side is one pass, ``insert_pack_pass``, which writes this frame's LR samples
into the HR albedo at their sampled sub-pixels and quantizes the result for the NPU; its NPU side
is a small residual conv stack at LR (pixel-unshuffled); ``unpack_history_pass`` turns the NPU's
int8 output into the displayed frame.  Registered for a test with
``monkeypatch.setitem(FAMILIES, "toy", TOY_FAMILY)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import torch
import torch.nn.functional as F
from torch import nn

from mnss_kit.gpu.plan import const, pass_entries, per_frame, quantize_uniforms, step, word_count
from mnss_kit.model.family import Family
from mnss_kit.model.layers import insert_samples

CHANNELS = 3  # the NPU maps an RGB image to an RGB image


@dataclass
class ToyConfig:
    family: Literal["toy"] = "toy"
    scale: int = 2
    width: int = 8
    layers: int = 2


class Pack(nn.Module):
    """This frame's LR colour written into the HR albedo at the sampled sub-pixels."""

    placement = "gpu"

    def __init__(self, scale: int):
        super().__init__()
        self.scale = scale

    def forward(self, albedo, color, jitter):
        return insert_samples(albedo, color, jitter, self.scale)


class Net(nn.Module):
    """Residual conv stack at LR on the pixel-unshuffled image, clamped to [0, 1]."""

    placement = "npu"

    def __init__(self, scale: int, width: int, layers: int):
        super().__init__()
        c = CHANNELS * scale * scale
        widths = [c] + [width] * (layers - 1) + [c]
        mods: list[nn.Module] = [nn.PixelUnshuffle(scale)]
        for i in range(layers):
            mods.append(nn.Conv2d(widths[i], widths[i + 1], 3, padding=1))
            if i < layers - 1:
                mods.append(nn.ReLU())
        mods.append(nn.PixelShuffle(scale))
        self.body = nn.Sequential(*mods)

    def forward(self, image):
        return torch.clamp(image + self.body(image), 0.0, 1.0)


class Toy(nn.Module):
    def __init__(self, config: ToyConfig):
        super().__init__()
        self.config, self.scale = config, config.scale
        self.pack = Pack(config.scale)
        self.net = Net(config.scale, config.width, config.layers)

    def stages(self):
        return [("pack", self.pack, "gpu"), ("net", self.net, "npu")]

    def initial_state(self, frame):
        return {}

    def forward(self, frame, state=None):
        packed = self.pack(frame["hr_albedo"], frame["color"], frame["jitter"])
        output = self.net(packed)
        return output, {"packed": packed}, {}


class ToyLoss(nn.Module):
    terms = ("total", "l1")

    def __init__(self, scale: int):
        super().__init__()
        self.scale, self.flicker_weight = scale, 0.0

    def forward(self, output, aux, frame, reference, valid=None, flicker=None):
        l1 = F.l1_loss(output, reference)
        return {"total": l1, "l1": l1}


def toy_gpu_plan(config: ToyConfig, state_dict: dict, lr_size, npu: dict, profile: str) -> dict:
    s, (w, h) = config.scale, lr_size
    hr, words = [w * s, h * s], word_count(lr_size, s, CHANNELS)
    a = dict(lr_size=lr_size, scale=s)

    def tex(name, size, fmt, role, layers=0):
        entry = {"name": name, "kind": "texture2d_array" if layers else "texture2d", "size": size, "format": fmt,
                 "channels": 3, "role": role, "description": name}
        return {**entry, "layers": layers} if layers else entry

    def buf(name):
        return {"name": name, "kind": "buffer", "bytes": words * 4, "words": words, "element": "uint", "role": "boundary",
                "description": f"int8 NHWC {name}"}

    resources = [tex("color", [w, h], "rgba16f", "input", layers=1), tex("hr_albedo", hr, "rgba16f", "input"),
                 buf("npu_input"), buf("npu_output"), tex("image", hr, "rgba16f", "intermediate"),
                 tex("display", hr, "rgba8", "output")]
    steps = [
        step("insert_pack_pass", "pack", "pack", {"rectified": "hr_albedo", "aa": "color", "npu_input": "npu_input"},
             {"u_scale": const(s), "u_subpixel": per_frame("subpixel"), "u_word_count": const(words),
              **quantize_uniforms(*npu["input_q"], profile)}, words=words, **a),
        {"kind": "npu", "label": "net", "stage": "net", "model": npu["model"],
         "inputs": {npu["input"]: "npu_input"}, "outputs": {npu["output"]: "npu_output"}},
        step("unpack_history_pass", "unpack", "net", {"npu_output": "npu_output", "history": "image", "display": "display"},
             {"u_q_scale": const(float(npu["output_q"][0])), "u_q_zero_point": const(int(npu["output_q"][1]))}, **a),
    ]
    schedule = {"steps": steps, "end_of_frame": [], "reset": "no history: every frame stands alone",
                "barriers": "glMemoryBarrier between GPU steps; fence around the NPU step"}
    return {"passes": pass_entries({"insert_pack_pass", "unpack_history_pass"}), "weights": [],
            "resources": resources, "schedule": schedule}


TOY_FAMILY = Family(
    name="toy",
    config=ToyConfig,
    build=Toy,
    loss=lambda config, train: ToyLoss(config.scale),
    lr_inputs=("color",),
    hr_inputs=("albedo",),
    npu_stages=("net",),
    gpu_plan=toy_gpu_plan,
    fixed_macs=lambda config: {"pack": 0.0, "net": 3.0},
    learned_prefixes=("net",),
)
