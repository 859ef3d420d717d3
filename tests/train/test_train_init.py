"""``mnss-kit train CONFIG --init NAME_OR_CKPT``: fine-tuning starts from a checkpoint's weights, checked first."""

from __future__ import annotations

import torch
import yaml

from mnss_kit import cli
from mnss_kit.config import resolve_config_path
from mnss_kit.model import checkpoint
from mnss_kit.model.families import build_model
from mnss_kit.train.config import load_experiment
from mnss_kit.train.run import train

SHIPPED = "mnss_x2"


def shipped_model_section() -> dict:
    return yaml.safe_load(resolve_config_path(SHIPPED, "models").read_text())["model"]


def largest_change(a: dict, b: dict) -> float:
    return max(float((a[k].float() - b[k].float()).abs().max()) for k in a)


def test_fine_tuning_starts_from_the_shipped_weights(write_experiment, tmp_path):
    experiment, _ = load_experiment(write_experiment(model=shipped_model_section(), epochs=1, steps_per_epoch=2))
    final = train(experiment, tmp_path / "run", progress=False, init=SHIPPED)
    tuned, record = checkpoint.load(final)
    shipped, _ = checkpoint.load(SHIPPED)
    assert record["init"]["path"] == SHIPPED and record["init"]["sha256"] == checkpoint.identity(SHIPPED, record)["sha256"]
    assert record["training"]["steps"] == 2
    # an Adam step moves a weight by at most about lr: two steps from the shipped weights stay within 2 lr of them
    moved = largest_change(tuned.state_dict(), shipped.state_dict())
    assert 0 < moved <= 2 * experiment.train.lr * 1.01, moved
    torch.manual_seed(experiment.train.seed)
    assert largest_change(build_model(experiment.model).state_dict(), shipped.state_dict()) > 100 * moved


def test_a_mismatched_width_is_refused_in_one_line(write_experiment, tmp_path, capsys):
    model = shipped_model_section() | {"recon_width": 16}
    code = cli.main(["train", str(write_experiment(model=model)), "--out", str(tmp_path / "run"), "--init", SHIPPED])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"--init {SHIPPED}: tensor '" in err and "in the checkpoint but" in err and "(16," in err
    assert not (tmp_path / "run").exists()


def test_another_scale_or_resume_is_refused(write_experiment, tmp_path, capsys):
    model = shipped_model_section() | {"scale": 3}
    assert cli.main(["train", str(write_experiment(model=model)), "--out", str(tmp_path / "a"), "--init", SHIPPED]) == 2
    assert "a mnss x2 checkpoint cannot start a mnss x3 model" in capsys.readouterr().err
    path = write_experiment(model=shipped_model_section())
    assert cli.main(["train", str(path), "--out", str(tmp_path / "b"), "--init", SHIPPED, "--resume"]) == 2
    assert "--init starts a new run" in capsys.readouterr().err


def test_a_config_names_the_run_it_fine_tunes(write_experiment, tmp_path, capsys):
    path = write_experiment(model=shipped_model_section(), epochs=1, steps_per_epoch=1, init=SHIPPED)
    final = train(load_experiment(path)[0], tmp_path / "run", progress=False)
    assert checkpoint.read_record(final)[0]["init"]["path"] == SHIPPED
    missing = write_experiment(name="next.yaml", init=str(tmp_path / "base" / "model.pt"))
    assert cli.main(["train", str(missing), "--out", str(tmp_path / "next")]) == 2
    err = capsys.readouterr().err
    assert "train.init" in err and "train that run first" in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "next").exists()


def started_from(name: str, **changes):
    """``(model, identity, checkpoint's model)``: the checkpoint's config with ``changes``, started from its weights."""
    from mnss_kit.model.config import model_config_from_dict
    from mnss_kit.train.init import initial_weights

    shipped, record = checkpoint.load(name)
    config = model_config_from_dict(record["config"] | changes)
    weights, identity = initial_weights(config, name)
    model = build_model(config)
    model.load_state_dict(weights)
    return model, identity, shipped


def test_a_scale_input_model_starts_as_the_checkpoint_without_it():
    """The 1/s input a modes model adds starts with zero weights: its steering equals the 2x checkpoint's."""
    modes, identity, shipped = started_from("ntaau_lr_x2", scale_input=True)
    assert identity["path"] == "ntaau_lr_x2"
    features = torch.rand(1, 9, 16, 16)
    with torch.no_grad():
        assert torch.equal(modes.steer(features), shipped.steer(features[:, :8]))
        assert modes.steer.encode[0].weight[:, 8].abs().sum() == 0


def test_a_detail_model_starts_as_the_checkpoint_without_it(caplog):
    """ntaau_lr's detail branch, absent from the checkpoint, starts with its last conv at zero: the
    model's frames equal the checkpoint's.  The log says a branch is added, not that settings differ."""
    from mnss_kit.model.families import FAMILIES
    from mnss_kit.model.family import example_frame

    with caplog.at_level("INFO", logger="mnss_kit.train.init"):
        model, _, shipped = started_from("ntaau_lr_x2", detail=True, detail_width=8)
    assert "a detail branch is added" in caplog.text and "differ" not in caplog.text, caplog.text
    g = torch.Generator().manual_seed(4)
    state = ref_state = None
    with torch.no_grad():
        for _ in range(3):
            frame = example_frame(FAMILIES["ntaau_lr"], 12, 16, 2, generator=g)
            out, _, state = model(frame, state)
            ref, _, ref_state = shipped(frame, ref_state)
            assert torch.allclose(out, ref, atol=1e-6)


def test_trainable_freezes_every_other_parameter(write_experiment, tmp_path, capsys):
    """``train.trainable`` names the parameters a run trains (a fine-tune that adds ntaau_lr's detail
    branch and keeps the steering it starts from); a prefix that names none is refused in one line."""
    model = shipped_model_section()
    experiment, _ = load_experiment(write_experiment(model=model, epochs=1, steps_per_epoch=2, trainable=["recon."]))
    tuned, _ = checkpoint.load(train(experiment, tmp_path / "run", progress=False, init=SHIPPED))
    shipped, _ = checkpoint.load(SHIPPED)
    before, after = shipped.state_dict(), tuned.state_dict()
    changed = {k for k in before if not torch.equal(before[k], after[k])}
    assert changed and all(k.startswith("recon.") for k in changed), changed
    path = write_experiment(name="none.yaml", model=model, trainable=["nothing."])
    assert cli.main(["train", str(path), "--out", str(tmp_path / "none"), "--init", SHIPPED]) == 2
    err = capsys.readouterr().err
    assert "names no parameter" in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "none").exists()
