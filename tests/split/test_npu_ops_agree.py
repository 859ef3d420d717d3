"""split and quantize agree on what the int8 NPU graph can hold (one op table, ops.npu_ops).

split maps ATen ops to TFLite builtins and asks ``ops.npu_ops``; quantize traces torch.fx nodes
into the graph it writes.  A stage split calls NPU-eligible (on a device accepting every op of
the table) must trace, and a module with an op the table lacks must be refused by both.
"""

from __future__ import annotations

import pytest
import torch
import torch.nn.functional as F
from torch import nn

from mnss_kit.errors import UserError
from mnss_kit.model.mnss.config import MNSSConfig
from mnss_kit.model.families import build_model
from mnss_kit.model.macs import MacReport
from mnss_kit.quantize.trace import trace
from mnss_kit.split import dataflow
from mnss_kit.split.dataflow import npu_graph_refusal, trace_model

LR_HW = (8, 12)


def quantize_traces(module: nn.Module, inputs: list[torch.Tensor]) -> bool:
    try:
        trace(module, inputs)
    except UserError:
        return False
    return True


def frame() -> dict:
    g = torch.Generator().manual_seed(0)
    h, w = LR_HW
    return {"color": torch.rand(1, 3, h, w, generator=g), "depth": torch.rand(1, 1, h, w, generator=g),
            "motion": torch.randn(1, 2, h, w, generator=g), "jitter": torch.rand(1, 2, generator=g) - 0.5,
            "reset": torch.zeros(1)}


def stage_inputs(model) -> dict[str, list[torch.Tensor]]:
    """Each stage's positional tensor inputs on one frame."""
    seen, hooks = {}, []

    def keep(name):
        def hook(module, args):
            seen.setdefault(name, list(args))

        return hook

    for name, module, _ in model.stages():
        hooks.append(module.register_forward_pre_hook(keep(name)))
    f = frame()
    try:
        with torch.no_grad():
            model(f, model.initial_state(f))
    finally:
        for hook in hooks:
            hook.remove()
    return seen


@pytest.mark.parametrize("history_at_samples", [False, True])
def test_every_stage_split_calls_npu_eligible_is_traced_by_quantize(history_at_samples):
    torch.manual_seed(0)
    config = MNSSConfig(recon_width=4, recon_layers=2, aa_width=4, aa_layers=2, aa_history_at_samples=history_at_samples)
    model = build_model(config).eval()
    flow = trace_model(model, LR_HW)
    inputs = stage_inputs(model)
    modules = {name: module for name, module, _ in model.stages()}
    eligible = [s.name for s in flow.stages if not npu_graph_refusal(s)]
    assert "recon" in eligible
    for name in eligible:
        assert quantize_traces(modules[name], inputs[name]), f"split calls {name} NPU-eligible, quantize refuses it"
    aa = flow.stage("aa")  # takes the jitter, a per-frame vector: no NPU graph input
    assert "jitter" in npu_graph_refusal(aa) or "GATHER_ND" in npu_graph_refusal(aa)


class OneStage(nn.Module):
    """A one-stage model in the shape split traces (``stages``, ``initial_state``, ``scale``); its
    frame has the MNSS family's inputs."""

    scale = 1
    config = MNSSConfig()

    def __init__(self, net: nn.Module, inputs):
        super().__init__()
        self.net, self.inputs = net, inputs

    def stages(self):
        return [("net", self.net, "npu")]

    def initial_state(self, frame):
        return {}

    def forward(self, frame, state):
        return self.net(*self.inputs(frame)), {}, {}


class Net(nn.Module):
    """Two convolutions of the image, then the op under test: ``fn(conv_a(x), conv_b(x))``."""

    def __init__(self, fn):
        super().__init__()
        self.conv_a = nn.Conv2d(3, 4, 3, padding=1)
        self.conv_b = nn.Conv2d(3, 4, 3, padding=1)
        self.fn = fn

    def forward(self, x):
        return self.fn(self.conv_a(x), self.conv_b(x))


class VectorNet(Net):
    """As :class:`Net` with a second, per-frame vector input: ``fn(conv_a(x), conv_b(x), v)``."""

    def forward(self, x, v):
        return self.fn(self.conv_a(x), self.conv_b(x), v)


def image(frame):
    return [frame["color"]]


def image_and_vector(frame):
    return [frame["color"], frame["jitter"]]


CASES = {  # name: (op under test, inputs, whether the int8 NPU graph can hold it)
    "conv_relu": (lambda a, b: F.relu(a), image, True),
    "concat_sigmoid": (lambda a, b: torch.sigmoid(torch.cat([a, b], dim=1)), image, True),
    "add_mul": (lambda a, b: a * b + a, image, True),
    "pixel_shuffle": (lambda a, b: F.pixel_shuffle(a, 2), image, True),
    "average_pool": (lambda a, b: F.avg_pool2d(a, 2), image, True),
    "sub": (lambda a, b: a - b, image, False),
    "abs": (lambda a, b: torch.abs(a), image, False),
    "max_pool": (lambda a, b: F.max_pool2d(a, 2), image, False),
    "exp": (lambda a, b: torch.exp(a), image, False),
    "vector_input": (lambda a, b, v: a * v[:, :1, None, None], image_and_vector, False),
}


@pytest.mark.parametrize("case", list(CASES))
def test_split_and_quantize_agree_on_small_modules(case, monkeypatch):
    fn, inputs, expected = CASES[case]
    torch.manual_seed(0)
    net = (VectorNet if inputs is image_and_vector else Net)(fn).eval()
    # model.macs counts MNSS stages only; the op verdict does not need MACs
    monkeypatch.setattr(dataflow, "count_macs", lambda model, lr_size: MacReport(stages={}, params=0))
    flow = trace_model(OneStage(net, inputs), LR_HW)
    split_says = not npu_graph_refusal(flow.stage("net"))
    assert split_says == expected, (case, npu_graph_refusal(flow.stage("net")))
    assert quantize_traces(net, inputs(frame())) == expected, case
