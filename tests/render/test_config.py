"""Data config validation and the command line's one-line errors."""

from __future__ import annotations

import json

import pytest

from mnss_kit.cli import main
from mnss_kit.errors import UserError
from mnss_kit.render.config import load_render_config
from mnss_kit.render.run import parse_shard


def write(tmp_path, text: str):
    path = tmp_path / "cfg.yaml"
    path.write_text(text)
    return str(path)


GOOD = "version: 1\ndefaults: {frames: 5, lr_size: [32, 18]}\nsequences:\n  - {name: a, scene: arena, seed: 1}\n  - {name: b, scene: town, frames: 7}\n"


def test_defaults_merge_and_overrides(tmp_path):
    cfg = load_render_config(write(tmp_path, GOOD))
    assert [(s.name, s.frames, s.lr_size) for s in cfg.sequences] == [("a", 5, (32, 18)), ("b", 7, (32, 18))]
    cfg = load_render_config(write(tmp_path, GOOD), ["frames=3", "b.seed=9", "b.lr_size=[40, 20]"])
    assert [(s.frames, s.seed, s.lr_size) for s in cfg.sequences] == [(3, 1, (32, 18)), (3, 9, (40, 20))]


@pytest.mark.parametrize("text,message", [
    ("sequences:\n  - {name: a, scene: arena, colour: red}\n", r"unknown key 'sequences\[0\].colour'"),
    ("sequences:\n  - {name: a, scene: arena, hr_samples: 10}\n", "hr_samples must be a square"),
    ("sequences:\n  - {name: a, scene: arena, jitter: sobol}\n", "unknown jitter pattern"),
    ("sequences:\n  - {name: a, scene: arena, scale: 4}\n", "grid jitter pattern exists for scales 2 and 3"),
    ("sequences:\n  - {name: a, scene: arena, frames: 0}\n", "frames must be >= 1"),
    ("sequences:\n  - {name: a, scene: castle}\n", "neither built-in"),
    ("sequences:\n  - {name: a, scene: level.glb}\n", "needs a camera-path YAML"),
    ("sequences:\n  - {name: a, scene: arena}\n  - {name: a, scene: town}\n", "duplicate sequence name"),
    ("sequences:\n  - {name: 'a/b', scene: arena}\n", "must use letters"),
    ("sequences: []\n", "non-empty list"),
    ("frames: 3\nsequences:\n  - {name: a, scene: arena}\n", "unknown key 'frames'"),
    ("sequences:\n  - {name: a, scene: arena, extra_references: [msaa]}\n", "extra_references takes each of taa, 4x"),
    ("sequences:\n  - {name: a, scene: arena, extra_references: [taa, taa]}\n", "at most once"),
])
def test_bad_configs_are_user_errors(tmp_path, text, message):
    with pytest.raises(UserError, match=message):
        load_render_config(write(tmp_path, text))


def test_missing_camera_file_is_a_user_error(tmp_path):
    cfg = load_render_config(write(tmp_path, "sequences:\n  - {name: a, scene: arena, frames: 2, camera: nowhere.yaml}\n"))
    from mnss_kit.render.scenes import build_scene

    with pytest.raises(UserError, match="camera path 'nowhere.yaml' not found"):
        build_scene(cfg.sequences[0], cfg)


def test_still_camera_stands_where_the_scenes_own_camera_starts(tmp_path):
    from mnss_kit.render.scenes import build_scene

    text = "sequences:\n  - {name: a, scene: town, seed: 3, frames: 30, start_time: 0.5, camera: CAM}\n"
    moving, still = (load_render_config(write(tmp_path, text.replace("CAM", c))) for c in ("auto", "still"))
    path = build_scene(moving.sequences[0], moving).camera
    held = build_scene(still.sequences[0], still).camera
    first = path.state(0.5)
    assert path.state(1.4).position.tolist() != first.position.tolist()  # the auto camera moves
    for t in (0.0, 0.5, 1.4, 9.0):
        state = held.state(t)
        assert state.position.tolist() == first.position.tolist() and (state.yaw, state.pitch) == (first.yaw, first.pitch)
    assert not held.breaks_history(0.5, 1.4, 16 / 9)


def test_still_camera_needs_a_built_in_scene(tmp_path):
    with pytest.raises(UserError, match="needs a camera-path YAML"):
        load_render_config(write(tmp_path, "sequences:\n  - {name: a, scene: level.glb, camera: still}\n"))


@pytest.mark.parametrize("text", ["1", "a/b", "2/2", "-1/3", "1/0"])
def test_bad_shards(text):
    with pytest.raises(UserError, match="--shard"):
        parse_shard(text)


def test_cli_reports_bad_config_in_one_line(tmp_path, capsys):
    code = main(["render", write(tmp_path, "sequences:\n  - {name: a, scene: arena, fps: -1}\n"), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "fps > 0" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert main(["render", "no_such_config", "--out", str(tmp_path / "o")]) == 2
    assert "no data config 'no_such_config'" in capsys.readouterr().err


def test_rerender_with_another_config_into_same_directory_is_refused(tmp_path):
    from mnss_kit.render.run import render_dataset

    base = "sequences:\n  - {name: a, scene: arena, frames: 1, lr_size: [16, 9], hr_samples: 1}\n"
    render_dataset(load_render_config(write(tmp_path, base)), tmp_path / "out", progress=False)
    changed = load_render_config(write(tmp_path, base.replace("frames: 1", "frames: 1, seed: 5")))
    with pytest.raises(UserError, match="different config"):
        render_dataset(changed, tmp_path / "out", progress=False)
    assert render_dataset(changed, tmp_path / "out", overwrite=True, progress=False).rendered == 1


def test_meta_records_the_environment_and_a_resume_elsewhere_names_what_changed(tmp_path, monkeypatch):
    from mnss_kit.render import gpu
    from mnss_kit.render.run import render_dataset

    config = load_render_config(write(tmp_path, "sequences:\n  - {name: a, scene: arena, frames: 1, lr_size: [16, 9], hr_samples: 1}\n"))
    render_dataset(config, tmp_path / "out", progress=False)
    recorded = json.loads((tmp_path / "out" / "a" / "meta.json").read_text())["scene"]["environment"]
    assert recorded == gpu.environment() and recorded["gl_renderer"] and recorded["numpy"]
    monkeypatch.setattr(gpu, "environment", lambda: {**recorded, "numpy": "0.0.1"})
    with pytest.raises(UserError, match=f"other libraries \\(numpy {recorded['numpy']} -> 0.0.1\\)"):
        render_dataset(config, tmp_path / "out", progress=False)
    # a sequence rendered before meta.json recorded the environment is resumed as it is
    meta_path = tmp_path / "out" / "a" / "meta.json"
    meta = json.loads(meta_path.read_text())
    del meta["scene"]["environment"]
    meta_path.write_text(json.dumps(meta))
    assert render_dataset(config, tmp_path / "out", progress=False).rendered == 0
    assert "environment" not in json.loads(meta_path.read_text())["scene"]


def test_shipped_configs_load():
    for name in ("default", "tiny", "train_x2", "test_x2"):
        cfg = load_render_config(name)
        assert cfg.sequences
    default = load_render_config("default").sequences
    assert len(default) == 1 and default[0].frames >= 120 and tuple(default[0].lr_size) == (640, 360)
    train = {s.camera for s in load_render_config("train_x2").sequences}
    test = {s.camera for s in load_render_config("test_x2").sequences}
    assert not train & test - {"auto"} and "auto" not in test  # held-out camera paths


def test_output_path_that_is_a_file_is_a_user_error(tmp_path):
    from mnss_kit.render.run import render_dataset

    (tmp_path / "taken").write_text("x")
    cfg = load_render_config(write(tmp_path, "sequences:\n  - {name: a, scene: arena, frames: 1}\n"))
    with pytest.raises(UserError, match="not a directory"):
        render_dataset(cfg, tmp_path / "taken", progress=False)


def test_missing_egl_is_a_user_error(monkeypatch):
    import moderngl

    from mnss_kit.render import gpu

    def no_egl(**kwargs):
        raise Exception("libEGL.so.1: cannot open shared object file")

    monkeypatch.setattr(gpu, "_context", None)
    monkeypatch.setattr(moderngl, "create_context", no_egl)
    with pytest.raises(UserError, match="cannot create an OpenGL 3.3 context through EGL .*libEGL"):
        gpu.context()
