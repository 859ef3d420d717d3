"""The GPU passes of the phone runtime, one file per pass.

Each ``<name>_pass.py`` holds its pass's record (:class:`~.record.Pass`: workgroup size, grid,
bindings, uniforms), its numpy reference ``reference(call) -> {written binding: array}``, which
binds the math of ``mnss_kit.ops``, and its ``ORDER``; the shader is ``shaders/runtime/<name>_pass.comp``
and the binding-free algorithm file it includes.  The bundle manifest lists these records, the Mesa
harness binds by them, and a test reads the flattened shaders and checks every declaration against them.

The pass modules are found here, not listed: every ``*_pass`` module of this package is imported and
must define ``PASS`` (named as its module) and an integer ``ORDER``, unique among the passes.
:data:`PASSES` is in ``ORDER`` (:data:`PASS_ORDER`), the execution order within a frame: the manifest
lists a bundle's passes in it.  The NPU runs between a pack pass and the pass that reads its output.
``ORDER`` goes by family, in steps of 10 so a pass fits between two others (each file's ``ORDER``
comment says where in the frame it runs; a new pass takes a free number and leaves this file alone):

=====  ========  ==================================================================================
ORDER  family    notes
=====  ========  ==================================================================================
1xx    MNSS      warp to sharpen; the AA net runs conv3x3_pass once per layer
2xx    FuseSR    demodulation, G-buffer unshuffle + pack, remodulation (conv3x3_pass encodes, between
                 demodulate_pass and gbuffer_pack_pass; warp_pass warps)
3xx    ntaau     the TAAU history reprojected, the steered accumulation (exp and tanh: float paths)
4xx    ntaau_lr  the evidence at LR, the LR features packed, the accumulation steered from LR
5xx    fsr2      the FSR2-class baseline upscaler (ops.fsr2), GPU only; float paths (sin, sqrt)
=====  ========  ==================================================================================
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Iterable
from types import ModuleType

from .avgpool_pass import avgpool_channels
from .conv3x3_pass import EPILOGUE_CODES
from .fsr2_params import fsr2_params_from_uniforms, fsr2_uniforms
from .gbuffer_pack_pass import PACKED_GBUFFERS
from .inpaint_blend_pass import WEIGHT_UPSAMPLE_CODES
from .inpaint_weights_pass import ACTIVATION_CODES
from .record import (DISPLAY_FORMAT, HISTORY_FORMAT, INPUT_FORMATS, NPU_TENSOR, ROUNDING_CODES, Binding, Call, Pass,
                     call, dequantize_uniforms, frame_uniforms, quantize_uniforms)


def discover_pass_modules() -> list[ModuleType]:
    """Every ``*_pass`` module of this package, imported, by name."""
    names = sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.ispkg and m.name.endswith("_pass"))
    return [importlib.import_module(f"{__name__}.{name}") for name in names]


def order_passes(modules: Iterable) -> dict[str, Pass]:
    """``{name: PASS}`` in ``ORDER`` from pass modules (anything with ``__name__``, ``PASS`` and ``ORDER``).

    Refuses a module without ``PASS`` or an integer ``ORDER``, a ``PASS`` not named as its module, and
    two passes with the same ``ORDER``: the frame order would then be up to the file names."""
    by_order: dict[int, str] = {}
    entries = []
    for m in modules:
        name = m.__name__.rpartition(".")[2]
        missing = [attr for attr in ("PASS", "ORDER") if not hasattr(m, attr)]
        if missing:
            raise ValueError(f"gpu pass module {name} defines no {' and no '.join(missing)}: every *_pass module in "
                              "mnss_kit/gpu/passes needs PASS = Pass(...) and ORDER = <int> (its place in the frame)")
        order = m.ORDER
        if not isinstance(order, int) or isinstance(order, bool):
            raise ValueError(f"gpu pass module {name}: ORDER must be an int, not {order!r}")
        if m.PASS.name != name:
            raise ValueError(f"gpu pass module {name} declares PASS named '{m.PASS.name}': name it '{name}'")
        if order in by_order:
            raise ValueError(f"gpu pass modules {by_order[order]} and {name} both have ORDER = {order}: "
                              "give each pass its own ORDER (see the table in mnss_kit/gpu/passes/__init__.py)")
        by_order[order] = name
        entries.append((order, m.PASS))
    return {p.name: p for _, p in sorted(entries, key=lambda e: e[0])}


PASSES: dict[str, Pass] = order_passes(discover_pass_modules())

# Execution order within a frame (the AA net runs conv3x3_pass once per layer).
PASS_ORDER = tuple(PASSES)

__all__ = ["ACTIVATION_CODES", "DISPLAY_FORMAT", "EPILOGUE_CODES", "HISTORY_FORMAT", "INPUT_FORMATS", "NPU_TENSOR",
           "PACKED_GBUFFERS", "PASSES", "PASS_ORDER", "ROUNDING_CODES", "WEIGHT_UPSAMPLE_CODES", "Binding", "Call", "Pass",
           "avgpool_channels", "call", "dequantize_uniforms", "frame_uniforms", "fsr2_params_from_uniforms", "fsr2_uniforms",
           "quantize_uniforms"]
