"""Start a run from a checkpoint's weights (``mnss-kit train CONFIG --init NAME_OR_CKPT``).

The checkpoint (a shipped name such as ``mnss_x2`` or a ``.pt`` path) must be of the config's
model family and scale, and every tensor of the config's model must exist in it with the same
shape; otherwise a one-line UserError names the first difference.  Settings that change no
tensor (activations, the history source) may differ: the config's win, and they are logged.
One exception: a model that reads inputs the checkpoint's did not (ntaau_lr's ``scale_input``,
the 1/s map, appended after its other inputs) starts with zero weights on them, so it begins as
the checkpoint's function at every scale.  And a model given a branch the checkpoint lacks (ntaau_lr's
``detail``) takes that branch's own initial weights, whose last conv is zero: it draws nothing.
"""

from __future__ import annotations

import logging

import torch
from torch import nn

from ..config import to_dict
from ..errors import UserError
from ..model import checkpoint
from ..model.config import model_config_from_dict
from ..model.families import build_model

log = logging.getLogger(__name__)


def initial_weights(config, name_or_path: str) -> tuple[dict, dict]:
    """``(state dict, identity)`` of checkpoint ``name_or_path``, checked against the model of ``config``."""
    source, record = checkpoint.load(name_or_path)
    model = build_model(config)  # only its tensor shapes are used
    if record.get("family") != config.family or record.get("scale") != model.scale:
        raise UserError(f"--init {name_or_path}: a {record.get('family')} x{record.get('scale')} checkpoint cannot "
                        f"start a {config.family} x{model.scale} model")
    weights = _with_added_inputs(model.state_dict(), source.state_dict(), _added_inputs(model, source))
    weights = _with_added_branch(weights, model, source)
    _check_tensors(model.state_dict(), weights, name_or_path)
    saved = to_dict(model_config_from_dict(record["config"]))  # keys added since the record read as defaults
    differing = sorted(k for k, v in to_dict(config).items() if saved.get(k) != v)
    if _adds_branch(model, source):  # the branch's own settings are new, not changed
        log.info("--init %s: a detail branch is added, drawing nothing until it is trained", name_or_path)
        differing = [k for k in differing if not k.startswith("detail")]
    if differing:
        log.info("--init %s: model.%s differ from the checkpoint's (the config's are used)",
                 name_or_path, ", model.".join(differing))
    return weights, checkpoint.identity(name_or_path, record)


def _added_inputs(model: nn.Module, source: nn.Module) -> int:
    """Input channels the config's model reads beyond the checkpoint's (the 1/s map of ``scale_input``)."""
    ours, theirs = getattr(model.config, "scale_input", False), getattr(source.config, "scale_input", False)
    return 1 if ours and not theirs else 0


def _with_added_inputs(ours: dict, theirs: dict, added: int) -> dict:
    """``theirs`` with zero weights appended for ``added`` trailing input channels of the first layer
    (the one tensor whose input count differs by exactly ``added``)."""
    if not added:
        return theirs
    widened = dict(theirs)
    for key, tensor in ours.items():
        source = theirs.get(key)
        if (source is not None and tensor.dim() == 4 and source.dim() == 4 and tensor.shape[0] == source.shape[0]
                and tensor.shape[1] == source.shape[1] + added and tensor.shape[2:] == source.shape[2:]):
            zeros = source.new_zeros((source.shape[0], added, *source.shape[2:]))
            widened[key] = torch.cat([source, zeros], dim=1)
    return widened


def _adds_branch(model: nn.Module, source: nn.Module) -> bool:
    """Whether the config's model has ntaau_lr's detail branch and the checkpoint none."""
    return getattr(model.config, "detail", False) and not getattr(source.config, "detail", False)


def _with_added_branch(theirs: dict, model: nn.Module, source: nn.Module) -> dict:
    """``theirs`` plus the tensors of ntaau_lr's detail branch from ``model`` when the checkpoint has none."""
    if not _adds_branch(model, source):
        return theirs
    branch = model.detail_parameters()
    return {**theirs, **{k: v for k, v in model.state_dict().items() if k in branch}}


def _check_tensors(ours: dict, theirs: dict, name: str) -> None:
    for key, tensor in ours.items():
        if key not in theirs:
            raise UserError(f"--init {name}: the checkpoint has no tensor '{key}' (the config's model has a different structure)")
        if tuple(theirs[key].shape) != tuple(tensor.shape):
            raise UserError(f"--init {name}: tensor '{key}' is {tuple(theirs[key].shape)} in the checkpoint but "
                            f"{tuple(tensor.shape)} in the config's model (widths and layers must match)")
    extra = sorted(set(theirs) - set(ours))
    if extra:
        raise UserError(f"--init {name}: the checkpoint's tensor '{extra[0]}' has no place in the config's model")
