"""``mnss-kit models``."""

import json

from model_helpers import TINY
from mnss_kit import cli
from mnss_kit.model import checkpoint
from mnss_kit.model.config import config_names
from mnss_kit.model.mnss.config import MNSSConfig
from mnss_kit.model.families import build_model


def test_lists_configs_when_nothing_is_shipped(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(checkpoint, "ZOO_DIR", tmp_path)
    assert cli.main(["models"]) == 0
    out = capsys.readouterr().out
    assert "No checkpoint is shipped" in out
    assert all(name in out for name in config_names())


def test_lists_a_shipped_checkpoint(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(checkpoint, "ZOO_DIR", tmp_path)
    checkpoint.save(tmp_path / "mnss_x2.pt", build_model(MNSSConfig(**TINY)), {"jitter_pattern": "grid"})
    assert cli.main(["models", "--json"]) == 0
    listing = json.loads(capsys.readouterr().out)
    assert [row["name"] for row in listing["checkpoints"]] == ["mnss_x2"]
    assert listing["checkpoints"][0]["macs_per_pixel"] > 0 and "configs" not in listing
    assert cli.main(["models", "--configs", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["configs"]
    assert {r["name"] for r in rows} == set(config_names()) and all(r["macs_per_pixel"] > 0 for r in rows)


def test_the_default_model_is_shipped_and_marked_as_such():
    from mnss_kit.model.run import checkpoint_rows
    from mnss_kit.zoo import DEFAULT_MODEL

    assert [row["name"] for row in checkpoint_rows() if row["default"]] == [DEFAULT_MODEL]
