"""``mnss-kit finetune --detail``: the steering for part of the budget, then a detail branch fitted on
recorded frames; the fit resumes, the judged model is the one with the branch, and a model that
cannot take a branch is refused before any work."""

from __future__ import annotations

import json

import pytest
import torch

from mnss_kit.cli import main
from mnss_kit.dataset.synthetic import write_synthetic_sequence
from mnss_kit.finetune import detail
from mnss_kit.model import checkpoint
from mnss_kit.model.ntaau_lr.net import branch_last_conv


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    root = tmp_path_factory.mktemp("capture")
    write_synthetic_sequence(root / "pan", lr_size=(32, 24), frames=24, name="pan")
    return root


def _branch_is_empty(path) -> bool:
    """Whether the branch's last conv (``net.branch_last_conv``: it starts at zero) is still zero."""
    model, _ = checkpoint.load(path)
    return not branch_last_conv(model.steer.detail).weight.any()


def test_detail_fits_a_branch_after_the_steering(capture, tmp_path):
    out = tmp_path / "ft"
    assert main(["finetune", str(capture), "--out", str(out), "--minutes", "0.1", "--detail", "--no-progress"]) == 0
    fitted = out / "detail" / "model.pt"
    record, _ = checkpoint.read_record(fitted)
    assert record["config"]["detail"] and record["detail_fit"]["steps"] > 0 and record["detail_fit"]["frames"] == 10
    assert not checkpoint.read_record(out / "run" / "model.pt")[0]["config"]["detail"]  # the steering phase has none
    assert not _branch_is_empty(fitted)
    summary = json.loads((out / "heldback.json").read_text())
    assert summary["settings"]["detail"] and summary["methods"]["finetuned"]["psnr"] != summary["methods"]["before"]["psnr"]


def test_a_cut_branch_fit_continues_from_its_last_checkpoint(capture, tmp_path, monkeypatch, caplog):
    monkeypatch.setattr(detail, "SAVE_EVERY_S", 0.0)  # a last.pt after every step
    batch, calls = detail._batch, []

    def cut_at_the_sixth(*args):
        calls.append(1)
        if len(calls) == 6:
            raise KeyboardInterrupt
        return batch(*args)

    out = tmp_path / "ft"
    args = ["finetune", str(capture), "--out", str(out), "--minutes", "0.1", "--detail", "--no-progress"]
    monkeypatch.setattr(detail, "_batch", cut_at_the_sixth)
    assert main(args) == 130 and not (out / "detail" / "model.pt").exists()
    assert (out / "detail" / "last.pt").is_file()
    monkeypatch.setattr(detail, "_batch", batch)
    with caplog.at_level("INFO", logger="mnss_kit.finetune.detail"):
        assert main(args) == 0
    assert "resuming the branch fit at step 5" in caplog.text
    assert checkpoint.read_record(out / "detail" / "model.pt")[0]["detail_fit"]["steps"] > 5


def test_a_branch_fitted_to_another_model_is_not_taken(capture, tmp_path):
    """A finished fit in the output directory is reused only for the model it was fitted to."""
    from mnss_kit.errors import UserError
    from mnss_kit.model.checkpoint import resolve

    fitted = detail.fit_detail(resolve("ntaau_lr_x2"), capture, tmp_path / "d", 0.01, 4, progress=False)
    assert detail.fit_detail(resolve("ntaau_lr_x2"), capture, tmp_path / "d", 0.01, 4, progress=False) == fitted
    with pytest.raises(UserError, match="fitted a branch to another model"):
        detail.fit_detail(resolve("ntaau_lr_modes"), capture, tmp_path / "d", 0.01, 4, progress=False)


def test_detail_refuses_a_model_without_a_branch_in_one_line(capture, tmp_path, capsys):
    assert main(["finetune", str(capture), "--out", str(tmp_path / "o"), "--model", "mnss_x2", "--detail"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--detail" in err[0] and "mnss" in err[0]
    assert not (tmp_path / "o" / "run").exists()


def test_an_empty_branch_leaves_the_model_as_it_was(capture):
    from mnss_kit.eval.frames import iter_frames
    from mnss_kit.dataset import format as fmt

    plain, _ = checkpoint.load("ntaau_lr_x2")
    branched, _ = detail.with_empty_branch(checkpoint.resolve("ntaau_lr_x2"))
    frame = next(iter_frames(capture / "pan", fmt.read_meta(capture / "pan"))).inputs
    with torch.no_grad():
        a = plain(frame, plain.initial_state(frame))[0]
        b = branched(frame, branched.initial_state(frame))[0]
    assert torch.equal(a, b)


def test_recorded_frames_are_thinned_evenly_past_the_memory_budget(monkeypatch):
    counts = [("a", 10), ("b", 10)]
    assert len(detail._kept_indices(counts, 4, 100, 2, 4)) == 12  # all after each warm-up
    monkeypatch.setattr(detail, "RECORD_BYTES", 2 * 7 * 4 * 100 * 4)  # room for 4 frames
    kept = sorted(detail._kept_indices(counts, 4, 100, 2, 4))
    assert kept == [("a", 4), ("a", 7), ("b", 4), ("b", 7)]


def test_a_capture_of_odd_size_below_the_crop_is_fitted(tmp_path):
    """Crops are even (the encoder-decoder branch halves them once), also when the capture is smaller
    than a crop and odd."""
    write_synthetic_sequence(tmp_path / "cap" / "odd", lr_size=(27, 21), frames=8, name="odd")
    fitted = detail.fit_detail(checkpoint.resolve("ntaau_lr_x2"), tmp_path / "cap", tmp_path / "d", 0.01, 4,
                               progress=False)
    assert checkpoint.read_record(fitted)[0]["detail_fit"]["steps"] > 0


def test_recorded_frames_know_the_frame_before_unless_the_camera_cut(tmp_path):
    write_synthetic_sequence(tmp_path / "cap" / "cut", lr_size=(16, 12), frames=10, name="cut", cut_at=7)
    model, _ = detail.with_empty_branch(checkpoint.resolve("ntaau_lr_x2"))
    recorded = detail.record_frames(model, tmp_path / "cap", warmup=4, progress=False)
    assert recorded.previous == [-1, 0, 1, -1, 3, 4]  # frames 4..9; 4 and the cut at 7 have none before
    assert recorded.motions[0].shape == (2, 12, 16)


def test_paired_crops_take_the_same_place_of_the_frame_before():
    s, n = 2, 4
    lr = [torch.full((3, 8, 10), float(i)) for i in range(n)]
    hr = [torch.full((3, 16, 20), float(i)) for i in range(n)]
    for t in lr + hr:  # a ramp, so a crop's place shows in its values
        t += torch.arange(t.shape[-1]).float() / 100
    recorded = detail.Recorded(lr, hr, [h + 1 for h in hr], [torch.zeros(2, 8, 10)] * n, [-1, 0, 1, -1])
    pool = detail._fitted_entries(recorded, paired=True)
    assert pool == [1, 2]
    x, display, reference, motion, before = detail._batch(recorded, pool, 4, 4, s, paired=True)
    x_prev, display_prev, reference_prev = before
    assert torch.allclose(x - x_prev, torch.ones_like(x)) and torch.allclose(display - display_prev, torch.ones_like(display))
    assert torch.equal(reference_prev, display_prev + 1) and motion.shape == (detail.BATCH, 2, 4, 4)
    assert detail._batch(recorded, pool, 4, 4, s)[4] is None


def test_a_fit_with_a_flicker_weight_needs_two_consecutive_frames():
    one = detail.Recorded([torch.zeros(3, 4, 4)], [torch.zeros(3, 8, 8)], [torch.zeros(3, 8, 8)], [torch.zeros(2, 4, 4)], [-1])
    with pytest.raises(detail.UserError, match="consecutive"):
        detail._fitted_entries(one, paired=True)


def test_a_narrower_branch_is_fitted_and_a_fit_of_another_width_is_not_resumed(capture, tmp_path, capsys):
    out = tmp_path / "ft"
    args = ["finetune", str(capture), "--out", str(out), "--minutes", "0.1", "--detail", "--no-progress"]
    assert main([*args, "--detail-width", "4"]) == 0
    record, _ = checkpoint.read_record(out / "detail" / "model.pt")
    assert record["config"]["detail_width"] == 4 and record["detail_fit"]["width"] == 4
    assert json.loads((out / "heldback.json").read_text())["settings"]["detail_width"] == 4
    assert main(args) == 2  # the default width (BRANCH's) into the same output
    err = capsys.readouterr().err.strip()
    assert f"width 4, not {detail.BRANCH['detail_width']}" in err and len(err.splitlines()) == 1


def test_detail_width_needs_detail_and_a_positive_width(capture, tmp_path, capsys):
    args = ["finetune", str(capture), "--out", str(tmp_path / "ft"), "--minutes", "0.1", "--no-progress"]
    assert main([*args, "--detail-width", "8"]) == 2
    assert main([*args, "--detail", "--detail-width", "0"]) == 2
    assert "without --detail" in capsys.readouterr().err


def test_the_help_gives_the_shipped_width(capsys):
    with pytest.raises(SystemExit):
        main(["finetune", "--help"])
    assert f"(default: {detail.BRANCH['detail_width']})" in capsys.readouterr().out
