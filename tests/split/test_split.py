"""GPU/NPU placement: modes, op support, the no-NPU fallback, estimates and their labels."""

import copy
import json

import pytest
import torch

from mnss_kit.cli import main
from mnss_kit.errors import UserError
from mnss_kit.model.mnss.config import MNSSConfig
from mnss_kit.model.families import build_model
from mnss_kit.ops.npu_ops import NPU_OPS as TABLE
from mnss_kit.split.dataflow import StageFlow, TensorInfo, trace_model
from mnss_kit.split.device import device_from_dict, device_names, load_device
from mnss_kit.split.estimate import estimate_stage
from mnss_kit.split.plan import PLACEMENTS, plan_flow, split_model
from mnss_kit.split.report import format_text

NPU_OPS = list(TABLE)  # a device that accepts every op of the int8 NPU graph
PROFILE = {
    "schema": 1, "name": "test_phone", "soc": "Test SoC",
    "gpu": {"name": "GPU", "fp16_gflops": 1000.0, "achievable_fraction": 0.5},
    "npu": {"name": "NPU", "int8_tops": 10.0, "achievable_fraction": 0.5, "ops": NPU_OPS},
    "memory": {"bandwidth_gbps": 50.0, "achievable_fraction": 0.5},
    "transfer": {"latency_ms": 0.3, "bandwidth_gbps": 5.0},
}
HD = (1280, 720)


def profile(**changes):
    data = copy.deepcopy(PROFILE)
    for key, value in changes.items():
        section, _, field = key.partition("__")
        if field:
            data[section][field] = value
        else:
            data[section] = value
    return device_from_dict(data)


@pytest.fixture(scope="module")
def flow():
    torch.manual_seed(0)
    model = build_model(MNSSConfig(recon_width=4, recon_layers=2, aa_width=4, aa_layers=2)).eval()
    return trace_model(model)


def placed(plan):
    return {s.name: s.placement for s in plan.stages}


def test_shipped_profiles_load():
    names = device_names()
    assert len(names) >= 3
    profiles = [load_device(n) for n in names]
    assert any(p.npu is None for p in profiles), "a profile without a usable NPU is shipped"
    assert sum(p.npu is not None for p in profiles) >= 2
    assert all(p.sources for p in profiles)


def test_default_follows_the_model_and_reports_the_boundary(flow):
    plan = plan_flow(flow, profile(), "default", HD)
    assert placed(plan) == {"warp": "gpu", "inpaint": "gpu", "aa": "gpu", "insert": "gpu", "recon": "npu"}
    crossing = {t.name: t for t in plan.boundary}
    assert set(crossing) == {"insert.out", "recon.out"}
    into_npu, out_of_npu = crossing["insert.out"], crossing["recon.out"]
    assert into_npu.direction == "gpu->npu" and out_of_npu.direction == "npu->gpu"
    assert into_npu.layout == "NHWC" and into_npu.dtype == "int8"
    assert into_npu.shape == [1, 720, 1280, 3] and into_npu.bytes_per_frame == 1280 * 720 * 3
    assert "warp.history (next frame)" in out_of_npu.consumers  # the recurrent history goes back to the GPU
    assert [h.before for h in plan.handoffs] == ["recon", "display"]
    assert plan.estimated_frame_ms == pytest.approx(plan.estimated_stage_ms + plan.estimated_transfer_ms)


def test_all_gpu_has_no_boundary_and_a_reason_for_every_op(flow):
    plan = plan_flow(flow, profile(), "all-gpu", HD)
    assert set(placed(plan).values()) == {"gpu"}
    assert plan.boundary == [] and plan.handoffs == [] and plan.estimated_transfer_ms == 0.0
    for stage in plan.stages:
        assert stage.reason
        assert all(op.reason for op in stage.ops)


def test_aa_on_npu_keeps_the_aa_net_that_takes_the_jitter(flow):
    """The AA net's ops are all NPU ops, but it reads the jitter vector, which no NPU graph input holds."""
    plan = plan_flow(flow, profile(), "aa-on-npu", HD)
    assert plan.npu_stages() == ["recon"]
    aa = next(s for s in plan.stages if s.name == "aa")
    assert not aa.npu_eligible and "frame.jitter" in aa.reason
    assert all(op.npu_accepts and "frame.jitter" in op.reason for op in aa.ops)
    assert [h.direction for h in plan.handoffs] == ["gpu->npu", "npu->gpu"]


def test_warp_stays_on_the_gpu_because_of_grid_sample(flow):
    plan = plan_flow(flow, profile(), "auto", HD)
    warp = next(s for s in plan.stages if s.name == "warp")
    assert warp.placement == "gpu" and not warp.npu_eligible
    grid = next(op for op in warp.ops if op.op == "GRID_SAMPLE")
    assert not grid.npu_accepts and "no TFLite builtin" in grid.reason


@pytest.mark.parametrize("npu_tops, transfer, expected", [(0.001, (0.3, 5.0), []), (1e6, (0.0, 1e6), ["recon"])])
def test_auto_picks_the_lowest_estimate(flow, npu_tops, transfer, expected):
    latency_ms, bandwidth = transfer
    device = profile(npu__int8_tops=npu_tops, transfer__latency_ms=latency_ms, transfer__bandwidth_gbps=bandwidth)
    auto = plan_flow(flow, device, "auto", HD)
    assert auto.npu_stages() == expected
    for mode in ("default", "all-gpu", "aa-on-npu"):
        assert auto.estimated_frame_ms <= plan_flow(flow, device, mode, HD).estimated_frame_ms + 1e-12
    if not expected:  # eligible stages kept on the GPU say what moving them would cost
        recon = next(s for s in auto.stages if s.name == "recon")
        assert recon.reason.startswith("auto: estimated frame") and "estimated" in recon.reason


def test_npu_without_concatenation_keeps_aa_on_the_gpu(flow):
    device = profile(npu__ops=[op for op in NPU_OPS if op != "CONCATENATION"])
    plan = plan_flow(flow, device, "aa-on-npu", HD)
    assert placed(plan)["aa"] == "gpu" and placed(plan)["recon"] == "npu"
    aa = next(s for s in plan.stages if s.name == "aa")
    assert "CONCATENATION" in aa.reason
    concat = next(op for op in aa.ops if op.op == "CONCATENATION")
    assert not concat.npu_accepts and "npu.ops" in concat.reason
    assert any("aa" in note for note in plan.notes)


@pytest.mark.parametrize("mode", PLACEMENTS)
def test_no_npu_falls_back_to_all_gpu(flow, mode):
    device = profile(npu=None, transfer=None)
    plan = plan_flow(flow, device, mode, HD)
    assert plan.npu_stages() == [] and plan.handoffs == []
    assert any("no usable NPU" in note for note in plan.notes)
    assert all(s.estimate_npu is None for s in plan.stages)
    assert all(op.reason == "the device has no NPU" for s in plan.stages for op in s.ops)
    text = format_text(plan)
    assert "no usable NPU" in text and "Ops on the GPU instead of the NPU" not in text


def test_estimates_scale_with_resolution(flow):
    device = profile()
    small, large = (plan_flow(flow, device, "default", size) for size in ((1280, 720), (2560, 1440)))
    for a, b in zip(small.stages, large.stages):
        assert b.macs == pytest.approx(4 * a.macs)
        if a.bytes_read > 1e5:  # weights are a fixed cost; at these sizes they are negligible
            assert b.bytes_read == pytest.approx(4 * a.bytes_read, rel=1e-3)
            assert b.estimate["estimated_ms"] == pytest.approx(4 * a.estimate["estimated_ms"], rel=1e-3)
    assert [h.bytes for h in large.handoffs] == [4 * h.bytes for h in small.handoffs]


def test_roofline_arithmetic():
    stage = StageFlow("s", "gpu", inputs=[TensorInfo("x", "hr", 4, (1, 4, 2, 2))], macs_per_pixel=100.0)
    device = profile()
    gpu = estimate_stage(stage, "gpu", device, (100, 10), scale=2)
    assert gpu.compute_ms == pytest.approx(2 * 100 * 1000 / (1000e9 * 0.5) * 1e3)
    assert gpu.memory_ms == pytest.approx(2 * 4 * 1000 / (50e9 * 0.5) * 1e3)
    npu = estimate_stage(stage, "npu", device, (100, 10), scale=2)
    assert npu.memory_ms == pytest.approx(gpu.memory_ms / 2)  # int8 against fp16
    assert npu.compute_ms == pytest.approx(2 * 100 * 1000 / (10e12 * 0.5) * 1e3)


def test_every_time_is_labelled_an_estimate(flow):
    plan = plan_flow(flow, profile(), "aa-on-npu", HD)
    data = json.loads(json.dumps(plan.to_dict()))
    assert "estimate" in data["estimate_note"]

    def walk(node):
        if isinstance(node, dict):
            for key, value in node.items():
                if key.endswith("_ms"):
                    assert key.startswith("estimated_"), key
                walk(value)
            if "estimated_ms" in node:
                assert node["label"] == "estimate"
        elif isinstance(node, list):
            for value in node:
                walk(value)

    walk(data)
    text = format_text(plan)
    assert "ESTIMATES" in text and "est. ms" in text and "[estimate]" in text


@pytest.mark.parametrize(
    "change, message",
    [
        ({"gpu__colour": "red"}, "unknown key"),
        ({"npu__ops": ["CONV2D"]}, "did you mean CONV_2D"),
        ({"npu__ops": ["CONV_2D", "GATHER_ND"]}, "not an op of the int8 NPU graph"),
        ({"memory__achievable_fraction": 1.5}, "achievable_fraction"),
        ({"transfer": None}, "transfer"),
        ({"gpu__fp16_gflops": "fast"}, "must be a number"),
    ],
)
def test_bad_profile_is_a_user_error(change, message):
    with pytest.raises(UserError, match=message):
        profile(**change)


def test_bad_device_file_is_a_user_error(tmp_path):
    with pytest.raises(UserError, match="no devices config"):
        load_device(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("schema: 1\nname: [unclosed\n")
    with pytest.raises(UserError, match="not valid YAML"):
        load_device(bad)


def test_split_model_api_and_cli(tmp_path, capsys):
    model = build_model(MNSSConfig(recon_width=4, recon_layers=2, aa_width=4, aa_layers=2)).eval()
    plan = split_model(model, load_device("helio_g99"), "auto", (640, 360))
    assert plan.npu_stages() == [] and plan.resolution == [640, 360]
    out = tmp_path / "plan.json"
    assert main(["split", "mnss_x2_tiny", "--device", "snapdragon_8_gen_1", "--resolution", "640x360",
                 "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["device"] == "snapdragon_8_gen_1" and data["resolution"] == [640, 360]
    assert "ESTIMATES" in capsys.readouterr().out
    assert main(["split", "mnss_x2_tiny", "--device", "snapdragon_8_gen_1", "--resolution", "720p"]) == 2
    assert main(["split", "mnss_x2_tiny", "--device", "no_such_phone"]) == 2


@pytest.fixture(scope="module")
def modes():
    """ntaau_lr_x2 (a family that takes any scale) placed at the quality mode 1.5 and at its own 2."""
    from mnss_kit.split.run import run_split

    return {s: run_split("ntaau_lr_x2", "snapdragon_8_gen_1", scale=s) for s in (1.5, 2)}


def test_split_at_a_quality_mode_uses_the_rounded_lr_size(modes):
    lr_w, lr_h = round(1280 / 1.5), round(720 / 1.5)  # 853 x 480, as ops.scale.lr_size_for rounds
    plan = modes[1.5]
    assert plan.scale == 1.5 and plan.lr_size == [lr_w, lr_h] and plan.resolution == [1280, 720]
    assert plan.boundary, "the steer stage's LR tensors cross to the NPU and back"
    for tensor in plan.boundary:
        channels = tensor.shape[3]
        assert tensor.shape == [1, lr_h, lr_w, channels]
        assert tensor.bytes_per_frame == lr_w * lr_h * channels
    assert "x1.5 from 853x480" in format_text(plan)


def test_split_costs_less_at_a_larger_scale(modes):
    assert modes[2].lr_size == [640, 360]
    assert modes[2].estimated_frame_ms < modes[1.5].estimated_frame_ms


def test_split_cli_scale_in_json(tmp_path):
    out = tmp_path / "plan.json"
    assert main(["split", "ntaau_lr_x2", "--device", "snapdragon_8_gen_1", "--scale", "1.5", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["scale"] == 1.5 and data["lr_size"] == [853, 480]


def test_split_refuses_a_fractional_scale_for_an_integer_family(capsys):
    assert main(["split", "mnss_x2", "--device", "snapdragon_8_gen_1", "--scale", "1.5"]) == 2
    err = capsys.readouterr().err.strip()
    assert "the mnss family takes integer scales only" in err and "\n" not in err


@pytest.mark.parametrize("value", ["0.5", "1.0", "nan", "9"])
def test_split_refuses_bad_scales(value, capsys):
    assert main(["split", "ntaau_lr_x2", "--device", "snapdragon_8_gen_1", "--scale", value]) == 2
    err = capsys.readouterr().err.strip()
    assert "--scale" in err and "\n" not in err and "Traceback" not in err
