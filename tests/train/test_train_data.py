"""The resumable window stream and rendering missing data."""

from __future__ import annotations

import pytest
import torch

from mnss_kit.errors import UserError
from mnss_kit.train.config import DataSection, TrainConfig
from mnss_kit.train.data import PassWindows, StepSampler, ensure_data, open_windows


def test_ranks_read_disjoint_shards_of_every_pass():
    windows, world, batch = 10, 2, 3
    streams = [list(StepSampler(windows, batch, rank, world, seed=4, start_step=0, end_step=10)) for rank in range(world)]
    per_pass = 5  # ceil(10 / 2)
    for p in range(3):
        shards = [{i for q, i in s if q == p} for s in streams]
        assert len(shards[0]) == per_pass and shards[0].isdisjoint(shards[1])
        assert shards[0] | shards[1] == set(range(windows))


def test_resumed_stream_continues_the_uninterrupted_one():
    full = list(StepSampler(7, 4, 1, 2, seed=0, start_step=0, end_step=9))
    tail = list(StepSampler(7, 4, 1, 2, seed=0, start_step=5, end_step=9))
    assert len(full) == 36 and tail == full[5 * 4 :]
    assert list(StepSampler(7, 4, 1, 2, seed=1, start_step=0, end_step=9)) != full


def test_crop_depends_on_pass_and_index_only(synthetic_dataset, tmp_path):
    cfg = TrainConfig(train_data=str(synthetic_dataset), window=3, crop=8, cache_dir=str(tmp_path))
    draws = PassWindows(open_windows(cfg, cfg.train_dirs(), cfg.crop, progress=False))
    first = draws[(3, 2)]
    for other in [(0, 2), (1, 5)]:  # other draws in between change nothing
        draws[other]
    again = draws[(3, 2)]
    for key in first:
        torch.testing.assert_close(first[key], again[key], rtol=0, atol=0)
    assert first["color"].shape == (3, 3, 8, 8) and first["reference"].shape == (3, 3, 16, 16)
    crops = set()
    for p in range(6):
        draws.windows.set_epoch(p)
        crops.add(draws.windows.crop_for(2))
    assert len(crops) > 1  # new crops every pass


def test_missing_data_without_render_config(tmp_path):
    cfg = TrainConfig(train_data=str(tmp_path / "absent"))
    with pytest.raises(UserError, match="names no render config"):
        ensure_data(cfg, None)


def test_missing_data_is_rendered_then_renamed(tmp_path, monkeypatch):
    calls = []

    def fake_render_dataset(render_cfg, out_dir, progress):
        calls.append(out_dir)
        (out_dir / "seq").mkdir(parents=True)
        return type("Summary", (), {"rendered": 1, "seconds": 0.0})()

    monkeypatch.setattr("mnss_kit.render.run.render_dataset", fake_render_dataset)
    monkeypatch.setattr("mnss_kit.render.config.load_render_config", lambda name, overrides=None: name)
    target = tmp_path / "train_x2"
    ensure_data(TrainConfig(train_data=str(target)), DataSection(train="tiny"))
    assert calls == [tmp_path / "train_x2.partial"] and (target / "seq").is_dir()
    ensure_data(TrainConfig(train_data=str(target)), DataSection(train="tiny"))
    assert len(calls) == 1  # present data is not rendered again


def test_several_training_directories_each_render_their_config(tmp_path, monkeypatch):
    rendered = {}

    def fake_render_dataset(render_cfg, out_dir, progress):
        rendered[out_dir.name] = render_cfg
        (out_dir / "seq").mkdir(parents=True)
        return type("Summary", (), {"rendered": 1, "seconds": 0.0})()

    monkeypatch.setattr("mnss_kit.render.run.render_dataset", fake_render_dataset)
    monkeypatch.setattr("mnss_kit.render.config.load_render_config", lambda name, overrides=None: (name, overrides))
    dirs = [str(tmp_path / "plain"), str(tmp_path / "centre")]
    (tmp_path / "plain").mkdir()  # present: not rendered
    ensure_data(TrainConfig(train_data=dirs), DataSection(train=["tiny", "tiny jitter=center"]))
    assert rendered == {"centre.partial": ("tiny", ["jitter=center"])}
    with pytest.raises(UserError, match=r"names 1 render config\(s\) for the 2 director"):
        ensure_data(TrainConfig(train_data=[str(tmp_path / "a"), str(tmp_path / "b")]), DataSection(train="tiny"))
