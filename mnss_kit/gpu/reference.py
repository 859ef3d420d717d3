"""The numpy backend of the GPU passes: what the shaders compute, and the emulator's GPU stage.

:class:`ReferencePasses` and :class:`mnss_kit.gpu.mesa.MesaPasses` have one method,
``run_pass(name, call) -> {written binding: array}``, so ``interpret.py`` runs a frame through
either and the tests compare them pass by pass.  Each pass's reference is in its own file
(``gpu/passes/<name>.py``); the math is ``mnss_kit.ops`` (bilinear warp, sub-pixel insertion,
inpainting, conv, unsharp, quantize), and the pass adds only what the GPU's storage does to it
(:mod:`.storage`): values stored in an fp16 texture are rounded to float16, r32f / rg32f values
stay float32, rgba8 display values are 8-bit codes.

Arrays are ``(H, W, C)`` (HR) or ``(h, w, C)`` (LR) float32; jitter is ``(2,)`` LR pixels,
taken as float32 as the shaders' uniforms are.

The 3x3 convolution (inpainting weights and the AA net) is ``ops.inpaint.conv3x3`` unless the
passes are built with another function of identical values (``mnss_kit.emulate.fast_gpu``).
"""

from __future__ import annotations

from dataclasses import replace

from ..ops import inpaint
from .passes import PASSES, Call
from .storage import as_jitter, encode_unorm8, to_half

__all__ = ["ReferencePasses", "as_jitter", "encode_unorm8", "to_half"]


class ReferencePasses:
    """The runtime passes in numpy.  Inputs are rounded to their storage format on entry, as an
    upload to that texture format would round them.

    ``conv``: ``(h, w, Cin) float32, weight (Cout, Cin, 3, 3), bias (Cout,) -> (h, w, Cout) float32``
    with the values of ``ops.inpaint.conv3x3`` (the default)."""

    def __init__(self, conv=inpaint.conv3x3):
        self.conv = conv

    def run_pass(self, name: str, call: Call) -> dict:
        """Pass ``name``'s reference on ``call``: written binding name -> array."""
        return PASSES[name].reference(replace(call, conv=self.conv))
