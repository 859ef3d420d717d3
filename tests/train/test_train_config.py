"""The experiment file: typed sections, unknown keys named, typed overrides."""

from __future__ import annotations

import pytest
import yaml

from mnss_kit.cli import main
from mnss_kit.config import CONFIG_DIR
from mnss_kit.errors import UserError
from mnss_kit.train.config import ExperimentConfig, TrainConfig, load_experiment


def test_loads_sections_and_defaults(write_experiment):
    experiment, path = load_experiment(write_experiment(lr=5e-4))
    assert isinstance(experiment, ExperimentConfig) and path.name == "tiny.yaml"
    assert experiment.train.lr == 5e-4 and experiment.train.betas == (0.9, 0.999) and experiment.train.eps == 1e-4
    assert experiment.model.recon_width == 8
    assert experiment.data is None


def test_paper_defaults():
    cfg = TrainConfig()
    assert (cfg.lr, cfg.betas, cfg.eps, cfg.perceptual_weight, cfg.aa_weight) == (1e-3, (0.9, 0.999), 1e-4, 0.1, 5.0)


@pytest.mark.parametrize("section", ["train", "model"])
def test_unknown_key_is_named(write_experiment, section):
    path = write_experiment()
    doc = yaml.safe_load(path.read_text())
    doc[section]["learning_rat"] = 1
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(UserError, match=rf"unknown key '{section}.learning_rat'"):
        load_experiment(path)


def test_unknown_top_level_key_is_named(write_experiment):
    path = write_experiment()
    path.write_text(path.read_text() + "optimiser: adam\n")
    with pytest.raises(UserError, match="unknown key 'optimiser'"):
        load_experiment(path)


def test_overrides_are_typed(write_experiment):
    experiment, _ = load_experiment(write_experiment(), ["train.window=5", "train.betas=[0.5, 0.9]", "model.recon_width=12"])
    assert experiment.train.window == 5 and experiment.train.betas == (0.5, 0.9) and experiment.model.recon_width == 12
    with pytest.raises(UserError, match="'train.window' must be an integer"):
        load_experiment(write_experiment(), ["train.window=five"])
    with pytest.raises(UserError, match="unknown key 'train.windw'"):
        load_experiment(write_experiment(), ["train.windw=5"])


def test_bad_values_are_user_errors(write_experiment):
    with pytest.raises(UserError, match="window must be >= 1"):
        load_experiment(write_experiment(window=0))
    with pytest.raises(UserError, match="schema must be 1"):
        load_experiment(write_experiment(), ["schema=2"])


def test_schedule_helpers():
    cfg = TrainConfig(epochs=3, steps_per_epoch=10, gt_history_epochs=1)
    assert cfg.steps == 30 and TrainConfig(total_steps=7).steps == 7
    assert cfg.uses_gt_history(9) and not cfg.uses_gt_history(10)


def test_shipped_configs_load():
    names = sorted(p.stem for p in (CONFIG_DIR / "models").glob("*.yaml"))
    assert "mnss_x2" in names
    for name in names:
        experiment, _ = load_experiment(name)
        assert experiment.model.scale in (2, 3, 4)


def test_cli_reports_bad_key_without_traceback(write_experiment, capsys):
    assert main(["train", str(write_experiment()), "--set", "train.bogus=1"]) == 2
    err = capsys.readouterr().err
    assert "train.bogus" in err and "Traceback" not in err


def test_changed_train_keys_count_a_key_a_record_lacks_as_its_default():
    from mnss_kit.config import to_dict
    from mnss_kit.train.config import TrainConfig, changed_train_keys

    saved = to_dict(TrainConfig(flicker_weight=4.0))
    del saved["mse_weight"]  # a record written before the key existed
    assert changed_train_keys(saved, TrainConfig(flicker_weight=4.0)) == []
    assert changed_train_keys(saved, TrainConfig(flicker_weight=4.0, mse_weight=1.0)) == ["mse_weight"]
    assert changed_train_keys(saved, TrainConfig(flicker_weight=28.0, lr=3e-4), {"lr"}) == ["flicker_weight"]
