"""MACs per output pixel against a hand count."""

import pytest

from mnss_kit.model.mnss.config import MNSSConfig
from mnss_kit.model.families import build_model
from mnss_kit.model.macs import count_macs
from mnss_kit.model.mnss.costs import fixed_macs

# recon 4 wide, 2 layers; aa 5 wide, 2 layers; inpaint is one 3x3 conv 4 -> 1
TINY = dict(recon_width=4, recon_layers=2, aa_width=5, aa_layers=2)


def hand_count(scale: int, recon_resolution: str) -> dict[str, float]:
    """3x3 conv: 9 * c_in * c_out MACs per output pixel of its own resolution; LR pixels are 1/s^2 of HR."""
    lr = 1 / scale**2
    recon_io = 3 * scale**2 if recon_resolution == "lr" else 3
    recon_per_own_pixel = 9 * (recon_io * 4 + 4 * recon_io)
    return {
        "inpaint": 9 * 4 * 1 * lr,
        "aa": 9 * (6 * 5 + 5 * 3) * lr,
        "recon": recon_per_own_pixel * (lr if recon_resolution == "lr" else 1),
    }


@pytest.mark.parametrize("scale, recon_resolution", [(2, "lr"), (2, "hr"), (3, "lr")])
def test_conv_macs_match_hand_count(scale, recon_resolution):
    report = count_macs(build_model(MNSSConfig(scale=scale, recon_resolution=recon_resolution, **TINY)))
    expected = hand_count(scale, recon_resolution)
    for stage, macs in expected.items():
        assert report.stages[stage].conv == pytest.approx(macs)
    assert report.stages["warp"].conv == 0 and report.stages["insert"].conv == 0
    assert report.by_placement("npu") == pytest.approx(expected["recon"] + report.stages["recon"].fixed)
    assert report.total == pytest.approx(sum(expected.values()) + sum(c.fixed for c in report.stages.values()))


def test_x2_lr_tiny_numbers():
    """The same count written out: inpaint 9*4/4 = 9, aa 9*45/4 = 101.25, recon 9*(12*4+4*12)/4 = 216."""
    report = count_macs(build_model(MNSSConfig(**TINY)))
    assert [report.stages[s].conv for s in ("inpaint", "aa", "recon")] == [9.0, 101.25, 216.0]


def test_history_at_samples_adds_three_aa_inputs():
    """aa 9 * (9 * 5 + 5 * 3) / 4 = 135: the extraction itself is a copy, no MACs."""
    report = count_macs(build_model(MNSSConfig(aa_history_at_samples=True, **TINY)))
    assert report.stages["aa"].conv == 135.0


def test_count_does_not_depend_on_frame_size():
    model = build_model(MNSSConfig(**TINY))
    assert count_macs(model, (4, 6)).total == pytest.approx(count_macs(model, (10, 7)).total)


def test_fixed_gpu_costs_are_labelled_per_stage():
    model = build_model(MNSSConfig(enhance=True, **TINY))
    report = count_macs(model)
    assert list(report.stages) == ["warp", "inpaint", "aa", "insert", "recon", "enhance"]
    assert report.stages["enhance"].fixed == fixed_macs(model.config)["enhance"] > 0
    assert report.stages["warp"].fixed > 0 and report.stages["warp"].placement == "gpu"
    single = count_macs(build_model(MNSSConfig(history="none", **TINY)))
    assert "warp" not in single.stages and single.stages["inpaint"].conv == 0


def test_params_counted():
    model = build_model(MNSSConfig(**TINY))
    assert count_macs(model).params == sum(p.numel() for p in model.parameters())
