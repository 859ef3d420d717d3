"""One bad frame must cost one frame, for every family, on a rendered sequence with the faults of
``mnss-kit stress``.

A small render of the stress scenario the faults corrupt (``fast_objects``: the arena, figures
running past the camera), and the faults exactly as ``mnss-kit stress`` applies them
(``stress.scenarios.FAULTS``: NaN colour on the middle of frame 8, +Inf LR and HR depth on its top
third), judged by its rule (``stress.run.fault_entry``): every output finite, back within 0.5 dB of
the clean run at most 2 frames after the bad one.  FuseSR also reads F_beta, emissive, normal and
albedo: NaN and +-Inf in each of them (sanitized as ``ops.sanitize.sanitize_gbuffer``).  The tiny
synthetic sequences of ``test_bad_frame.py`` are too smooth to show a slow recovery; this one showed
mnss_x2's (see ``test_mnss_keeps_its_history_at_a_bad_sample``)."""

from __future__ import annotations

import pytest
import torch

from mnss_kit.dataset.loader import eval_sequences
from mnss_kit.metrics.psnr import psnr
from mnss_kit.model.checkpoint import load
from mnss_kit.stress.run import fault_entry
from mnss_kit.stress.scenarios import FAULTS, Fault, corrupt

RENDERED = """
version: 1
defaults: {lr_size: [64, 36], scale: 2, jitter: grid, hr_samples: 4, fps: 30, frames: 24}
sequences:
  - {name: fast_objects, scene: arena, seed: 105}
"""
FAMILIES = ("ntaau_x2", "ntaau_lr_x2", "mnss_x2", "fusesr_x2_hybrid")
GBUFFER_VALUES = {"nan": float("nan"), "inf": float("inf"), "neginf": float("-inf")}


def _gbuffer_faults() -> list[Fault]:
    """One frame of NaN, +Inf or -Inf in one of FuseSR's material G-buffers (LR and HR where it reads both)."""
    frame = FAULTS[0].frame
    out = []
    for name in ("fbeta", "emissive", "normal", "albedo"):
        keys = (f"lr_{name}", f"hr_{name}") if name in ("fbeta", "emissive") else (f"hr_{name}",)
        for label, value in GBUFFER_VALUES.items():
            out.append(Fault(f"{label}_{name}", f"one frame of {label} {name}", FAULTS[0].source, keys, value, frame,
                             (0.2, 0.2, 0.7, 0.7)))
    return out


GBUFFER_FAULTS = {f.name: f for f in _gbuffer_faults()}


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """``fast_objects`` rendered small (64x36 -> 128x72, 24 frames, a cut after frame 14); skipped without EGL."""
    from mnss_kit.render.config import load_render_config
    from mnss_kit.render.run import render_dataset

    root = tmp_path_factory.mktemp("bad_frame_render")
    (root / "data.yaml").write_text(RENDERED)
    try:
        render_dataset(load_render_config(str(root / "data.yaml")), root / "out", progress=False)
    except Exception as e:  # noqa: BLE001 (no EGL display, no GL context)
        pytest.skip(f"cannot render: {e}")
    return root / "out" / "fast_objects"


_MODELS: dict = {}


def _family(name):
    if name not in _MODELS:
        model, _ = load(name)
        _MODELS[name] = model.eval()
    return _MODELS[name]


def _frames(path, model) -> list[dict]:
    keys = list(model.required_inputs()) if hasattr(model, "required_inputs") else []
    (sequence,) = eval_sequences(path, hr_buffers=[k[3:] for k in keys if k.startswith("hr_")],
                                 lr_buffers=[k[3:] for k in keys if k.startswith("lr_")], progress=False)
    return list(sequence)


def _rows(model, frames, fault=None) -> list[dict]:
    """Per-frame rows as the stress evaluation writes them (PSNR NaN where an output or the state is
    not finite), ``fault`` applied to its frame."""
    state, rows = None, []
    with torch.no_grad():
        for t, frame in enumerate(frames):
            seen = corrupt(frame, fault) if fault is not None and t == fault.frame else frame
            if state is None:
                state = model.initial_state(seen)
            output, _, state = model(seen, state)
            finite = bool(torch.isfinite(output).all()) and all(bool(torch.isfinite(v).all()) for v in state.values())
            image = output[0].permute(1, 2, 0).numpy().clip(0, 1)
            value = psnr(image, frame["reference"][0].permute(1, 2, 0).numpy()) if finite else float("nan")
            rows.append({"method": "model", "frame": t, "psnr": value})
    return rows


def _assert_recovers(model, frames, fault):
    entry = fault_entry(fault, _rows(model, frames), _rows(model, frames, fault), ["model"])["methods"]["model"]
    assert entry["finite"], entry
    assert entry["passed"], (entry["frames_to_recover"], entry["clean_psnr"], entry["fault_psnr"])


@pytest.mark.parametrize("fault", [f.name for f in FAULTS])
@pytest.mark.parametrize("family", FAMILIES)
def test_every_family_recovers_from_a_stress_fault(rendered, family, fault):
    model = _family(family)
    (chosen,) = [f for f in FAULTS if f.name == fault]
    _assert_recovers(model, _frames(rendered, model), chosen)


@pytest.mark.parametrize("fault", list(GBUFFER_FAULTS))
def test_fusesr_recovers_from_a_bad_gbuffer(rendered, fault):
    """NaN / +-Inf in one frame of F_beta, emissive (LR and HR), normal or albedo (HR): finite, and
    back within 0.5 dB of the clean run at most 2 frames after."""
    model = _family("fusesr_x2_hybrid")
    _assert_recovers(model, _frames(rendered, model), GBUFFER_FAULTS[fault])


def test_mnss_keeps_its_history_at_a_bad_sample(rendered):
    """mnss_x2 used to need 3 frames after the NaN block (on this render 2.83, 1.45, 0.34 dB below the
    clean run 1, 2, 3 frames after): the sanitized (black) block entered its output, which is its
    history; on the next frame its inpainting weight there was about 0.88, not 1, and from the frame
    after on back to its clean value (about 0.15: the history kept), so the residue faded slowly.  A
    non-finite colour sample is no sample now: weight 0 (the warped history is kept) and no AA value
    inserted.  The bad frame itself costs well under 1 dB, the frames after it almost nothing, and
    the clean run is unchanged bit for bit."""
    model = _family("mnss_x2")
    frames = _frames(rendered, model)
    (fault,) = [f for f in FAULTS if f.name == "nan_frame"]
    clean, faulty = _rows(model, frames), _rows(model, frames, fault)
    drops = [c["psnr"] - f["psnr"] for c, f in zip(clean, faulty)][fault.frame:fault.frame + 3]
    assert drops[0] < 1.0 and max(drops[1:]) < 0.3, drops
