"""The renderer's dataset output: determinism, shards, resume, F_beta identity, jitter geometry."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

from mnss_kit.dataset import format as fmt
from mnss_kit.ops import brdf
from mnss_kit.render.config import load_render_config
from mnss_kit.render.run import render_dataset


def files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_all_buffers_written_with_meta(tiny_render):
    meta = fmt.read_meta(tiny_render / "arena")
    assert meta.lr_size == (64, 36) and meta.hr_size == (128, 72) and meta.frame_count == 4
    assert meta.frames[0].reset  # first frame of a sequence
    assert not meta.reverse_z and meta.depth_encoding == "hardware"
    for res in ("lr", "hr"):
        for name in meta.buffers[res]:
            img = fmt.read_raw_buffer(tiny_render / "arena", res, name, 3)
            assert img.shape[:2] == ((36, 64) if res == "lr" else (72, 128)) and np.all(np.isfinite(img))
    depth = fmt.read_raw_buffer(tiny_render / "arena", "hr", "depth", 0)
    assert 0.0 < depth.min() and depth.max() <= 1.0


def test_same_config_gives_byte_identical_files(tiny_config, tiny_render, tmp_path):
    render_dataset(load_render_config(str(tiny_config)), tmp_path, progress=False)
    again = files(tmp_path)
    assert len(again) == 2 + 7 * 18
    assert again == files(tiny_render)


def test_shards_union_equals_full_render_and_resume_skips(tiny_config, tiny_render, tmp_path):
    cfg = load_render_config(str(tiny_config))
    parts = []
    for i in range(3):
        part = tmp_path / f"part{i}"
        summary = render_dataset(cfg, part, shard=(i, 3), progress=False)
        parts.append(files(part))
        assert summary.rendered == [3, 2, 2][i]  # 7 frames dealt round-robin
    frames = [{k for k in p if not k.endswith("meta.json")} for p in parts]
    assert not (frames[0] & frames[1]) and not (frames[1] & frames[2]) and not (frames[0] & frames[2])
    merged = tmp_path / "merged"
    for i in range(3):
        shutil.copytree(tmp_path / f"part{i}", merged, dirs_exist_ok=True)
    assert files(merged) == files(tiny_render)
    again = render_dataset(cfg, merged, progress=False)
    assert again.rendered == 0 and again.skipped == 7


def test_colour_is_emissive_plus_fbeta_times_demodulated_light(tiny_render):
    seq = tiny_render / "arena"
    for res, colour_name in (("lr", "color"),):
        colour = fmt.read_raw_buffer(seq, res, colour_name, 2)
        fbeta = fmt.read_raw_buffer(seq, res, "fbeta", 2)
        emissive = fmt.read_raw_buffer(seq, res, "emissive", 2)
        surface = fbeta.min(-1) > 1e-3
        sky = fbeta.max(-1) == 0.0
        assert surface.mean() > 0.5 and (surface | sky).all()
        light = (colour - emissive)[surface] / fbeta[surface]
        assert np.all(np.isfinite(light)) and light.min() > -2e-3 * (1 + colour[surface].max())
        # half-float storage of three buffers: relative error of a few 1e-3
        np.testing.assert_allclose(colour[sky], emissive[sky], rtol=2e-3, atol=1e-3)


def test_fbeta_matches_numpy_reference_from_gbuffer(tiny_render):
    seq = tiny_render / "town"
    meta = fmt.read_meta(seq)
    f = 1
    w, h = meta.hr_size
    albedo, normal = (fmt.read_raw_buffer(seq, "hr", n, f) for n in ("albedo", "normal"))
    rough, metal = (fmt.read_raw_buffer(seq, "hr", n, f)[..., 0] for n in ("roughness", "metallic"))
    depth = fmt.read_raw_buffer(seq, "hr", "depth", f)[..., 0]
    fbeta = fmt.read_raw_buffer(seq, "hr", "fbeta", f)
    # world position from hardware depth and the (unjittered) matrices in meta
    view = np.array(meta.frames[f].view).reshape(4, 4)
    proj = np.array(meta.frames[f].proj).reshape(4, 4)
    ys, xs = np.mgrid[0:h, 0:w] + 0.5
    ndc = np.stack([xs / w * 2 - 1, 1 - ys / h * 2, depth * 2 - 1, np.ones_like(depth)], -1)
    world = ndc @ np.linalg.inv(proj @ view).T
    world = world[..., :3] / world[..., 3:]
    eye = np.linalg.inv(view)[:3, 3]
    v = eye - world
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    n_dot_v = np.clip((normal * v).sum(-1), 1e-4, 1.0)
    expected = brdf.fbeta(albedo, metal, np.clip(rough, 0.03, 1.0), n_dot_v)
    surface = depth < 1.0
    err = np.abs(expected - fbeta)[surface]
    assert np.median(err) < 5e-3 and np.percentile(err, 99) < 3e-2


def test_jittered_lr_depth_samples_hr_subpixel_centres(tiny_render):
    """MNSS offsets are sub-pixel centres, so LR depth equals HR depth at the visited HR pixel."""
    seq = tiny_render / "arena"
    meta = fmt.read_meta(seq)
    for f in range(meta.frame_count):
        dx, dy = (int(np.floor((j + 0.5) * meta.scale)) for j in meta.frames[f].jitter)
        lr = fmt.read_raw_buffer(seq, "lr", "depth", f)[..., 0]
        hr = fmt.read_raw_buffer(seq, "hr", "depth", f)[..., 0][dy::2, dx::2]
        close = np.abs(lr - hr) < 1e-5
        assert close.mean() > 0.97, (f, close.mean())
