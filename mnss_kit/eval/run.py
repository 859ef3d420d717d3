"""The eval stage's entry function: a checkpoint (or none) and the baselines over a dataset."""

from __future__ import annotations

from pathlib import Path


def evaluate_model(model_name: str, data_dir, methods: list[str] | None = None, max_frames: int | None = None,
                   flip: bool = False, crops_dir=None, progress: bool = True, reference: str = "box",
                   scale=None) -> dict:
    """Run ``methods`` (default: the model, its no-history ablation and the baselines) over
    ``data_dir``; ``model_name`` is a checkpoint path, a shipped name or ``none``; ``reference``
    (box, taa, 4x) the HR buffer the metrics compare against; ``scale`` (``--scale``, a number or its
    text, integer or fractional) the scale the data must have.  Returns the result of
    :func:`.loop.evaluate`."""
    from ..dataset import format as fmt
    from ..errors import UserError
    from ..ops.scale import check_data_scale_is, parse_scale
    from .baselines import BASELINES, baseline_methods
    from .methods import default_methods
    from .loop import evaluate

    if scale is not None:
        check_data_scale_is(fmt.read_meta(fmt.find_sequences(data_dir)[0]).scale, parse_scale(scale, "--scale"), data_dir)
    model, info = load_model(model_name, data_dir)
    scale = info["scale"] if info else fmt.read_meta(fmt.find_sequences(data_dir)[0]).scale
    available = default_methods(model, scale)
    wanted = methods or list(available)
    named = [m for m in wanted if m in BASELINES and m not in available]  # baselines run only when named (fsr2)
    available.update(baseline_methods(scale, named))
    missing = [m for m in wanted if m not in available]
    if missing:
        raise UserError(f"method(s) {', '.join(missing)} need a model (MODEL is 'none')")
    return evaluate({name: available[name] for name in wanted}, data_dir, scale=scale, max_frames=max_frames, flip=flip,
                    crops_dir=crops_dir, progress=progress, model_info=info, reference=reference)


def load_model(name_or_path: str, data_dir: str):
    """``(model, info)`` from a checkpoint, or ``(None, None)`` for 'none'."""
    if name_or_path.lower() == "none":
        return None, None
    import logging

    from ..dataset import format as fmt
    from ..errors import UserError
    from ..model.checkpoint import load, trained_patterns
    from ..model.family import check_data_scale
    from ..model.macs import count_macs

    model, record = load(name_or_path)
    scale = int(record.get("scale") or model.scale)
    meta = fmt.read_meta(fmt.find_sequences(data_dir)[0])
    if getattr(model, "takes_frame_scale", False):  # runs at the data's scale (frame key 'scale'; docs/architecture.md)
        scale = meta.scale
    else:
        check_data_scale(record.get("family"), scale, meta.scale, str(data_dir))
    trained = trained_patterns(record)  # by today's names (a shipped record may say mnss for grid)
    pattern = ",".join(trained) or record.get("jitter_pattern")
    if trained and meta.jitter_pattern not in trained:
        logging.getLogger(__name__).warning(
            "model trained with the '%s' jitter pattern, data uses '%s'", pattern, meta.jitter_pattern)
    macs = record.get("macs") or count_macs(model).to_dict()
    info = {
        "name": record.get("name") or Path(name_or_path).stem,
        "source": str(name_or_path),
        "family": record.get("family"),
        "scale": scale,
        "jitter_pattern": pattern,
        "parameters": sum(p.numel() for p in model.parameters()),
        "macs_per_pixel": macs["macs_per_pixel"],
        "npu_macs_per_pixel": macs.get("npu_macs_per_pixel"),
        "gpu_macs_per_pixel": macs.get("gpu_macs_per_pixel"),
        "config": record.get("config"),
        "data_fingerprint": record.get("data_fingerprint"),
        "code_version": record.get("code_version"),
    }
    return model, info
