"""The split pipeline (bundle shaders on Mesa + ``npu.tflite`` in LiteRT) against the unsplit PyTorch
model, recurrently over a sequence with a camera cut, through ``scripts/studies/split_e2e.py``.

Tolerance.  The split output differs from the fp32 model by int8 quantization.  Two roundings
are unavoidable even with every other layer exact: the NPU output to int8 steps of ``s`` (the
boundary's output scale) and the display to 8 bits (steps of 1/255), each an RMS error of
``step / sqrt(12)``; with ``s`` = 1/255 (the history range [0, 1]) they add up to about
0.41 steps.  The int8 layers inside the network and the fp16 GPU storage add rounding of the
same order.  The check allows an RMS difference of ``ERROR_STEPS`` = 1 output step on every
frame (about 2.5x the two unavoidable roundings), i.e. a per-frame PSNR of at least
``20 log10(1 / (ERROR_STEPS * s))`` (48.1 dB for ``s`` = 1/255, read from the bundle).  On the
tiny test model the pipeline measures about 54 dB; the same pipeline with its recurrent history
dropped measures about 20-24 dB after the first frame (checked below, so the tolerance can fail).
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import pytest

from mnss_kit.errors import UserError

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "studies" / "split_e2e.py"
ERROR_STEPS = 1.0


def _script():
    spec = importlib.util.spec_from_file_location("split_e2e", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _emulator(bundle):
    from mnss_kit.emulate.frame_loop import Emulator
    from mnss_kit.gpu import mesa

    try:
        mesa.create_context()
    except UserError as e:
        pytest.skip(str(e))
    return Emulator(bundle, "tflite-ref", "litert", "mesa")


def _tolerance_db(emulator) -> float:
    step = float(emulator.spec.boundary("npu->gpu")["scale"])
    return 20.0 * math.log10(1.0 / (ERROR_STEPS * step))


def test_split_pipeline_matches_the_pytorch_model(bundle, tiny_ckpt, synthetic_dataset, tmp_path):
    from mnss_kit.model import checkpoint

    script = _script()
    emulator = _emulator(bundle)
    model, _ = checkpoint.load(tiny_ckpt)
    result = script.compare_sequence(model, emulator, synthetic_dataset / "pan_cut", None)

    assert result["frames"] == 8 and result["cuts"] == [5]
    per_frame = result["per_frame_split_vs_pytorch_psnr_db"]
    tolerance = _tolerance_db(emulator)
    assert all(math.isfinite(p) for p in per_frame), "split output identical to fp32: int8 NPU stage not in the loop?"
    assert min(per_frame) >= tolerance, (per_frame, tolerance)
    assert abs(result["psnr_delta_db"]) <= 1.0  # scored by the same metric code, the two stay close
    summary = script.summarize({"pan_cut": result}, budget_db=0.2)
    assert summary["budget_holds_overall"] == (summary["psnr_delta_db"] <= 0.2)
    report = {"command": "split_e2e", "model": "tiny", "resolution": "64x48", "calibration": "synthetic",
              **script._environment(emulator), "npu_profile": "tflite-ref", "sequences": {"pan_cut": result},
              "summary": summary}
    script.write_doc(report, tmp_path / "split_e2e.md")
    doc = (tmp_path / "split_e2e.md").read_text()
    assert "| pan_cut | 8 | 5 |" in doc and "BUILTIN_REF" in doc and "llvmpipe" in doc.lower()


def test_tolerance_catches_a_split_pipeline_without_history(bundle, tiny_ckpt, synthetic_dataset):
    """The same comparison with the emulator's history dropped every frame must fail the tolerance."""
    from mnss_kit.model import checkpoint

    script = _script()
    emulator = _emulator(bundle)
    run_frame = emulator.run_frame
    emulator.run_frame = lambda frame, **kw: run_frame(dict(frame, reset=True), **kw)
    model, _ = checkpoint.load(tiny_ckpt)
    result = script.compare_sequence(model, emulator, synthetic_dataset / "pan", None)
    assert min(result["per_frame_split_vs_pytorch_psnr_db"]) < _tolerance_db(emulator)
