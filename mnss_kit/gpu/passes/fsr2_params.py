"""The float uniforms the fsr2 passes share, and the ``ops.fsr2.FSR2Params`` they stand for."""

from __future__ import annotations

import numpy as np

from ...ops.fsr2 import FSR2Params

# uniform -> FSR2Params field (u_lock_decay holds 1 / lock_frames)
FIELDS = {"u_dilation_edge": "dilation_edge", "u_depth_tolerance": "depth_tolerance", "u_slope_factor": "slope_factor",
          "u_lock_contrast": "lock_contrast", "u_max_weight": "max_weight", "u_gamma": "gamma",
          "u_resample_penalty": "resample_penalty", "u_kernel_width": "kernel_width", "u_prior_weight": "prior_weight",
          "u_lock_luma_tolerance": "lock_luma_tolerance", "u_sharpness": "sharpness"}


def fsr2_uniforms(params: FSR2Params, scale: int = 2) -> dict:
    """The float uniforms of the fsr2 passes for ``params`` at ``scale`` (float32 values, as the
    shaders hold them; the kernel's width follows the scale unless ``params`` sets it)."""
    values = {u: float(np.float32(getattr(params, field))) for u, field in FIELDS.items() if field != "kernel_width"}
    values["u_kernel_width"] = float(np.float32(params.kernel_width_at(scale)))
    values["u_lock_decay"] = float(np.float32(np.float32(1.0 / params.lock_frames)))
    return values


def fsr2_params_from_uniforms(uniforms: dict) -> FSR2Params:
    """The ``FSR2Params`` behind fsr2 uniform values (those a pass does not take keep their defaults)."""
    values = {field: uniforms[u] for u, field in FIELDS.items() if u in uniforms}
    if "u_lock_decay" in uniforms:
        values["lock_frames"] = int(round(1.0 / uniforms["u_lock_decay"]))
    return FSR2Params(**values)
