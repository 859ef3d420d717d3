"""The split stage's entry, :func:`run_split` (``mnss-kit split``): a model's stages placed on the GPU
or NPU of a device, with estimates (light at import: the tracing loads torch inside)."""

from __future__ import annotations

from .inputs import DEFAULT_RESOLUTION_TEXT, load_model, parse_resolution, require_scale_multiple


def run_split(model: str, device: str, placement: str = "default", resolution: str = DEFAULT_RESOLUTION_TEXT,
              scale=None):
    """Place the stages of ``model`` (a checkpoint path or shipped name, or a model config) on the
    GPU or NPU of ``device`` (a profile name or YAML path) for the output size ``resolution``
    (``WxH``) at ``scale`` (a validated scale, ``ops.scale.parse_scale``; None: the model's own; a
    quality mode such as 1.5 for a family that takes any); returns the :class:`~.plan.Placement`."""
    from ..model.families import run_at_scale
    from ..ops.scale import is_integer
    from .device import load_device
    from .plan import split_model

    size = parse_resolution(resolution)
    profile = load_device(device)
    loaded, name = load_model(model)
    run_at_scale(loaded, scale)
    if is_integer(loaded.scale):  # a fractional scale rounds the LR size instead (ops.scale.lr_size_for)
        require_scale_multiple(size, int(loaded.scale))
    return split_model(loaded, profile, placement, size, model_name=name)
