"""A deployment bundle as an evaluation method: the int8 model as the phone runs it, scored by
the same loop as the fp32 model and the baselines (``eval.evaluate``)."""

from __future__ import annotations

import numpy as np
import torch

from ..emulate.frame_loop import Emulator
from ..eval.methods import Method


def bundle_method(bundle, npu_profile: str = "tflite-ref") -> Method:
    """A deployment bundle through the desktop emulator (numpy GPU passes, ``npu_profile``'s NPU
    numerics): the int8 model as the phone runs it, scored like any other method.  The state is
    the emulator's own; ``None`` starts a sequence."""
    emulator = Emulator(bundle, npu_profile)
    inputs = emulator.runner.inputs

    def run(frame: dict, state):
        if state is None:
            emulator.reset()
        arrays = {k: frame[k][0].permute(1, 2, 0).numpy() for k in inputs}
        result = emulator.run_frame({**arrays, "jitter": frame["jitter"][0].numpy(), "reset": bool(frame["reset"][0] > 0.5)})
        display = torch.from_numpy(result.display.astype(np.float32) / 255.0).permute(2, 0, 1)[None]
        return display, {}, emulator

    return run
