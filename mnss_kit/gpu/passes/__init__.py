"""The GPU passes of the phone runtime, one file per pass.

Each ``<name>_pass.py`` holds its pass's record (:class:`~.record.Pass`: workgroup size, grid,
bindings, uniforms) and its numpy reference ``reference(call) -> {written binding: array}``, which
binds the math of ``mnss_kit.ops``; the shader is ``shaders/runtime/<name>_pass.comp`` and the
binding-free algorithm file it includes.  The bundle manifest lists these records, the Mesa harness
binds by them, and a test reads the flattened shaders and checks every declaration against them.

:data:`PASSES` is in execution order within a frame (:data:`PASS_ORDER`): the manifest lists a
bundle's passes in it.  The NPU runs between a pack pass and the pass that reads its output.
"""

from __future__ import annotations

from . import (avgpool_pass, conv3x3_pass, demodulate_pass, fsr2_accumulate_pass, fsr2_depth_clip_pass,
               fsr2_rcas_pass, fsr2_reconstruct_pass, gbuffer_pack_pass, inpaint_blend_pass, inpaint_weights_pass,
               insert_pack_pass, remodulate_pass, sharpen_pass, taau_accumulate_pass, taau_filter_pass,
               taau_lr_accumulate_pass, taau_lr_evidence_pass, taau_lr_filter_pass, taau_lr_pack_pass,
               taau_lr_reproject_pass, taau_pack_pass, taau_reproject_pass, unpack_history_pass, warp_pass)
from .avgpool_pass import avgpool_channels
from .conv3x3_pass import EPILOGUE_CODES
from .fsr2_params import fsr2_params_from_uniforms, fsr2_uniforms
from .gbuffer_pack_pass import PACKED_GBUFFERS
from .inpaint_blend_pass import WEIGHT_UPSAMPLE_CODES
from .inpaint_weights_pass import ACTIVATION_CODES
from .record import (DISPLAY_FORMAT, HISTORY_FORMAT, INPUT_FORMATS, NPU_TENSOR, ROUNDING_CODES, Binding, Call, Pass,
                     call, dequantize_uniforms, frame_uniforms, quantize_uniforms)

PASSES: dict[str, Pass] = {
    m.PASS.name: m.PASS
    for m in (
        warp_pass, inpaint_weights_pass, inpaint_blend_pass, avgpool_pass, conv3x3_pass, insert_pack_pass,
        unpack_history_pass, sharpen_pass,
        # FuseSR: demodulation, G-buffer unshuffle + pack, remodulation (conv3x3_pass encodes, warp_pass warps)
        demodulate_pass, gbuffer_pack_pass, remodulate_pass,
        # ntaau: the TAAU history reprojected, and the steered accumulation (exp and tanh: float paths)
        taau_reproject_pass, taau_pack_pass, taau_accumulate_pass, taau_filter_pass,
        # ntaau_lr: the evidence at LR, the LR features packed, the accumulation steered from LR
        taau_lr_reproject_pass, taau_lr_evidence_pass, taau_lr_pack_pass, taau_lr_accumulate_pass, taau_lr_filter_pass,
        # fsr2: the FSR2-class baseline upscaler (ops.fsr2), GPU only; float paths (sin, sqrt)
        fsr2_reconstruct_pass, fsr2_depth_clip_pass, fsr2_accumulate_pass, fsr2_rcas_pass,
    )
}

# Execution order within a frame (the AA net runs conv3x3_pass once per layer).
PASS_ORDER = tuple(PASSES)

__all__ = ["ACTIVATION_CODES", "DISPLAY_FORMAT", "EPILOGUE_CODES", "HISTORY_FORMAT", "INPUT_FORMATS", "NPU_TENSOR",
           "PACKED_GBUFFERS", "PASSES", "PASS_ORDER", "ROUNDING_CODES", "WEIGHT_UPSAMPLE_CODES", "Binding", "Call", "Pass",
           "avgpool_channels", "call", "dequantize_uniforms", "frame_uniforms", "fsr2_params_from_uniforms", "fsr2_uniforms",
           "quantize_uniforms"]
