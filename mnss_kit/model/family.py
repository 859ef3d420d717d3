"""What a model family is, as data: the one record every stage after ``model/`` asks.

A family lives in its own folder under ``model/`` (``model/mnss/``) and is listed in
``model.families.FAMILIES``.  Nothing outside that folder names one of its stages; the stages
of the pipeline read what they need from the :class:`Family` record:

    train     ``config``, ``build``, ``loss``, ``lr_inputs``/``hr_inputs`` (the dataset buffers
              a frame carries), ``history_state`` and ``floor_output``
    quantize  ``npu_stages``: the submodules traced into the int8 graph
    split     ``npu_stages`` and ``placements`` (named placement modes of the family)
    export    ``gpu_plan``: the GPU passes, resources, weights and per-frame schedule of a bundle
    models    ``fixed_macs``: fixed-function GPU arithmetic per HR output pixel

A model built by ``build`` follows the interface of docs/architecture.md:
``model(frame, state) -> (output, aux, state)``, ``model.initial_state(frame)``,
``model.stages()`` and ``model.scale``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from ..dataset.format import BUFFERS, REQUIRED_BUFFERS
from ..ops.scale import INTEGER_SCALE_ONLY  # why each family takes integer scales only (check_data_scale)


@dataclass(frozen=True)
class Family:
    name: str
    config: type  # dataclass of the ``model:`` section (its ``family`` field names the family)
    build: Callable[[Any], Any]  # config -> a freshly initialised torch model (imports torch when called)
    loss: Callable[[Any, Any], Any]  # (model config, train config) -> loss module with ``terms``
    lr_inputs: tuple[str, ...]  # LR buffers a frame carries (``color``, ``depth``, ``motion``; others as ``lr_<name>``)
    npu_stages: tuple[str, ...]  # stage names (``model.stages()``) traced into the int8 NPU graph
    gpu_plan: Callable[..., dict]  # (config, numpy state dict, lr_size, npu, profile) -> bundle GPU plan
    fixed_macs: Callable[[Any], dict[str, float]]  # config -> fixed-function MACs per HR pixel by stage
    hr_inputs: tuple[str, ...] = ()  # HR G-buffers a frame carries as ``hr_<name>`` (e.g. ``fbeta``)
    placements: dict[str, tuple[str, ...]] = field(default_factory=dict)  # mode -> GPU stages it moves to the NPU
    history_state: str | None = None  # state key of the previous HR output (ground-truth history, crop masks)
    floor_output: str | None = None  # aux key of the image the model must beat (validation), e.g. I_U
    learned_prefixes: tuple[str, ...] = ()  # submodules whose convs ``randomise_convs`` fills
    # the NPU stage writes the LR size rounded up to even (not the HR image): a quantized graph's
    # output times the scale is the HR size it runs at
    npu_output_at_lr: bool = False

    def frame_channels(self) -> dict[str, int]:
        """Channels of every per-frame image input: the LR buffers (``lr_<name>`` beyond the
        loader's base ones), then ``hr_<name>``."""
        out = {self.lr_key(name): len(BUFFERS["lr"][name].channels) for name in self.lr_inputs}
        out.update({f"hr_{name}": len(BUFFERS["hr"][name].channels) for name in self.hr_inputs})
        return out

    @staticmethod
    def lr_key(name: str) -> str:
        """The frame key of LR buffer ``name``: ``color`` for the base buffers, ``lr_fbeta`` for the others."""
        return name if name in REQUIRED_BUFFERS["lr"] else f"lr_{name}"

    @property
    def lr_buffers(self) -> tuple[str, ...]:
        """The optional LR G-buffers the loader must read for this family (beyond colour, depth, motion)."""
        return tuple(name for name in self.lr_inputs if name not in REQUIRED_BUFFERS["lr"])

    def dataset_buffers(self) -> dict[str, tuple[str, ...]]:
        """The dataset buffers training and evaluation read, per resolution."""
        return {"lr": tuple(dict.fromkeys((*REQUIRED_BUFFERS["lr"], *self.lr_inputs))), "hr": ("reference", *self.hr_inputs)}


def example_frame(family: Family, h: int, w: int, scale, generator=None, still: bool = False) -> dict:
    """One random batched frame of ``family``'s inputs at LR size ``h x w`` (torch; tracing and MAC counts).

    Images are uniform in [0, 1), motion normal, jitter uniform in [-0.5, 0.5); ``still``: zero
    motion and jitter (drawn from no generator).  ``generator`` None draws from torch's global one."""
    import torch

    from .taau import hr_dims

    frame = {}
    for name, channels in family.frame_channels().items():
        size = hr_dims((h, w), scale) if name.startswith("hr_") else (h, w)
        if name.endswith("motion"):
            frame[name] = torch.zeros(1, channels, *size) if still else torch.randn(1, channels, *size, generator=generator)
        else:
            frame[name] = torch.rand(1, channels, *size, generator=generator)
    frame["jitter"] = torch.zeros(1, 2) if still else torch.rand(1, 2, generator=generator) - 0.5
    frame["reset"] = torch.zeros(1)
    return frame


def check_frame(frame: dict, keys: dict[str, int], scale: int, family: str) -> None:
    """A UserError naming the first missing or misshapen input of a ``family`` model: ``keys`` maps
    each frame key to its channels (``hr_*`` at HR, the rest at LR); a missing dataset buffer is
    named as the dataset names it."""
    from ..errors import UserError

    for key in (*keys, "jitter"):
        if key not in frame:
            if key.startswith(("hr_", "lr_")):
                res, buffer = key.split("_", 1)
                raise UserError(f"a {family} model needs the dataset buffer {res}/{buffer} (frame key '{key}'), which the data lacks")
            raise UserError(f"model input lacks '{key}'")
    n, _, h, w = frame["color"].shape
    for key, channels in keys.items():
        size = (h * scale, w * scale) if key.startswith("hr_") else (h, w)
        if tuple(frame[key].shape) != (n, channels, *size):
            raise UserError(f"model input '{key}' has shape {tuple(frame[key].shape)}, expected {(n, channels, *size)}")
    if tuple(frame["jitter"].shape) != (n, 2):
        raise UserError(f"model input 'jitter' has shape {tuple(frame['jitter'].shape)}, expected {(n, 2)}")


def check_data_scale(family: str | None, model_scale, data_scale, where: str = "", what: str = "data") -> None:
    """The one-line refusal of data at a scale the model cannot run: a fractional scale for a family
    of integer scales only (``INTEGER_SCALE_ONLY``, naming why), else any other scale than the model's.
    ``what`` names where the scale came from (``data``, or an option such as ``--scale``)."""
    from ..errors import UserError

    prefix = f"{where}: " if where else ""
    if not float(data_scale).is_integer() and (family in INTEGER_SCALE_ONLY or family is None):
        reason = INTEGER_SCALE_ONLY.get(family, "its layers are built for an integer scale")
        raise UserError(f"{prefix}{what} is x{float(data_scale):g}, a fractional scale, and the {family or 'model'} family "
                        f"takes integer scales only ({reason}); the model is x{model_scale}")
    if data_scale != model_scale:
        raise UserError(f"{prefix}{what} is x{data_scale} but the model is x{model_scale}")
