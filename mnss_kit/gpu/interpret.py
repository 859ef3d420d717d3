"""The one frame loop: a bundle's per-frame schedule run step by step, as the phone runs it.

The schedule (``Family.gpu_plan``, written into ``manifest.json``) is the single definition of
what runs in which order on GPU and NPU.  :class:`ScheduleRunner` keeps every resource the
schedule names (textures and buffers, as numpy arrays), fills the inputs each frame, runs each
GPU step through a passes backend (:class:`~.reference.ReferencePasses` or
:class:`~.mesa.MesaPasses`: ``run_pass(name, call)``) and each NPU step through a callable,
skips the ``skip_on_reset`` steps on a reset frame, and applies ``end_of_frame`` swaps.  At the
start of a sequence every ``state`` resource is zero, as a freshly allocated texture.

A step reaches its pass as one :class:`~.passes.Call`: the values bound to the pass's bindings,
the step's uniform values as the shader holds them, and the frame's jitter; what the pass writes
comes back by binding name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import UserError
from ..ops.jitter import subpixel_index
from . import passes as P
from .passes import Call
from .weights import Conv3x3


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
        missing = sorted({s["pass"] for s in schedule["steps"] if s["kind"] == "gpu"} - set(P.PASSES))
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
        """Run one GPU step; what its pass returns (by binding name) is written to the bound resources."""
        read, weights = {}, {}
        for binding in P.PASSES[step["pass"]].bindings:
            target = step["bind"][binding.name]
            if target.startswith("weights:"):
                weights[binding.name] = self.weights[target[len("weights:"):]]
            else:
                read[binding.name] = self.values.get(target)
        uniforms = {name: (frame[v["frame"]] if "frame" in v else v["value"]) for name, v in step["uniforms"].items()}
        produced = self.passes.run_pass(step["pass"], Call(read, uniforms, weights, offset, previous, self.profile))
        return {step["bind"][name]: value for name, value in produced.items()}

    def _npu(self, step: dict) -> dict[str, np.ndarray]:
        feeds = {tensor: self.values[resource] for tensor, resource in step["inputs"].items()}
        results = self.npu(step, feeds)
        return {resource: results[tensor] for tensor, resource in step["outputs"].items()}
