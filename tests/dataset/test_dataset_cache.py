"""The decoded cache: hit, miss, rebuild on change, atomic builds; the dataset fingerprint."""

import os
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest

from mnss_kit.dataset import cache as cache_mod
from mnss_kit.dataset.cache import SequenceCache, dataset_fingerprint, prepare_caches
from mnss_kit.dataset.format import read_buffer, read_meta, read_raw_buffer, write_buffer
from mnss_kit.dataset.loader import WindowDataset
from mnss_kit.errors import UserError
from mnss_kit.fileio import LEGACY_STALE_SECONDS

BUFFERS = [("lr", "color"), ("lr", "depth"), ("lr", "motion"), ("hr", "reference")]


@pytest.fixture
def dataset(synthetic_dataset, tmp_path):
    """A private copy of the synthetic dataset that a test may change."""
    return shutil.copytree(synthetic_dataset, tmp_path / "data", ignore=shutil.ignore_patterns(".cache"))


def rewrite_frame(seq_dir, res, buffer, index, change):
    write_buffer(seq_dir, res, buffer, index, change(read_raw_buffer(seq_dir, res, buffer, index)))


def test_fingerprint_ignores_location_and_times_but_not_content(dataset, synthetic_dataset):
    fp = dataset_fingerprint(dataset)
    assert len(fp) == 64 and fp == dataset_fingerprint(synthetic_dataset)
    assert fp == dataset_fingerprint([dataset / "pan", dataset / "pan_cut"])
    os.utime(dataset / "pan" / "lr" / "color" / "00002.exr", (1, 1))
    assert dataset_fingerprint(dataset) == fp
    (dataset / "pan" / "meta.json").write_text((dataset / "pan" / "meta.json").read_text().replace('"exposure": 1.0', '"exposure": 2.0'))
    assert dataset_fingerprint(dataset) != fp
    assert dataset_fingerprint(dataset / "pan") != dataset_fingerprint(dataset / "pan_cut")


def test_cache_hit_miss_and_rebuild_on_change(dataset, tmp_path, monkeypatch):
    seq = dataset / "pan"
    (first,) = prepare_caches([seq], BUFFERS, tmp_path / "cache", progress=False)
    assert all(first.path(r, b).is_file() for r, b in BUFFERS)
    built_at = first.path("lr", "color").stat().st_mtime_ns

    def no_build(*args, **kwargs):
        raise AssertionError("cache rebuilt although nothing changed")

    with monkeypatch.context() as m:
        m.setattr(SequenceCache, "build", no_build)
        (again,) = prepare_caches([seq], BUFFERS, tmp_path / "cache", progress=False)
    assert again.dir == first.dir and again.path("lr", "color").stat().st_mtime_ns == built_at

    rewrite_frame(seq, "lr", "color", 3, lambda img: img + 0.5)
    (changed,) = prepare_caches([seq], BUFFERS, tmp_path / "cache", progress=False)
    assert changed.key != first.key
    assert not first.dir.exists()  # the stale entry is removed
    meta = read_meta(seq)
    cached = changed.open("lr", "color")[3].astype(np.float32).transpose(1, 2, 0)
    np.testing.assert_allclose(cached, read_buffer(seq, meta, "lr", "color", 3), atol=2.5e-4)


def test_default_cache_lives_in_the_dataset_and_is_not_a_sequence(dataset):
    fp = dataset_fingerprint(dataset)
    ds = WindowDataset(dataset, 2, progress=False)
    assert (dataset / ".cache").is_dir()
    assert len(ds.sequences) == 2 and dataset_fingerprint(dataset) == fp


def test_an_interrupted_build_leaves_no_cache_file(dataset, tmp_path, monkeypatch):
    seq = dataset / "pan"
    calls = {"n": 0}
    real_read = cache_mod.read_buffer

    def dying_read(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return real_read(*args, **kwargs)

    monkeypatch.setattr(cache_mod, "read_buffer", dying_read)
    with pytest.raises(KeyboardInterrupt):
        prepare_caches([seq], BUFFERS, tmp_path / "cache", progress=False)
    monkeypatch.setattr(cache_mod, "read_buffer", real_read)
    entry = SequenceCache(seq, tmp_path / "cache")
    assert entry.missing(BUFFERS) == BUFFERS
    assert list(entry.dir.iterdir()) == []  # no half-written array under any name

    # a build killed hard leaves its temporary file: never read, and removed by the next build
    # once its process is gone (a named-by-pid file) or old (a file of an older release)
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    killed = entry.dir / f".lr_color.npy.tmp.{int(dead.stdout)}.abcd1234.npy"
    running = entry.dir / f".lr_color.npy.tmp.{os.getpid()}.abcd1234.npy"
    legacy = entry.dir / ".lr_color.npy.ab12cd34.npy"
    for leftover in (killed, running, legacy):
        leftover.write_bytes(b"partial")
    old = time.time() - 2 * LEGACY_STALE_SECONDS
    os.utime(legacy, (old, old))
    (built,) = prepare_caches([seq], BUFFERS, tmp_path / "cache", progress=False)
    assert built.open("lr", "color").shape == (8, 3, 24, 32)
    assert not killed.exists() and not legacy.exists()
    assert running.exists()  # a concurrent build's file is left alone


@pytest.mark.parametrize("damage", ["truncate", "header", "shape"])
def test_a_damaged_cache_file_is_rebuilt(dataset, tmp_path, caplog, damage):
    seq = dataset / "pan"
    (first,) = prepare_caches([seq], BUFFERS, tmp_path / "cache", progress=False)
    path = first.path("lr", "color")
    good = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(good[: len(good) // 2])
    elif damage == "header":
        path.write_bytes(b"not an npy file" + good[15:])
    else:
        np.save(path, np.zeros((8, 3, 12, 32), np.float16))
    with caplog.at_level("WARNING", logger="mnss_kit.dataset.cache"):
        (again,) = prepare_caches([seq], BUFFERS, tmp_path / "cache", progress=False)
    assert path.read_bytes() == good
    assert again.open("lr", "color").shape == (8, 3, 24, 32)
    (line,) = [r.getMessage() for r in caplog.records if "damaged" in r.getMessage()]
    assert str(path) in line and "rebuilding" in line


def test_nan_pixels_stop_the_loader_with_one_line(dataset, tmp_path):
    def poison(img):
        img[4, 7, 1] = np.nan
        return img

    rewrite_frame(dataset / "pan_cut", "lr", "motion", 2, poison)
    for kwargs in ({"cache_dir": tmp_path / "cache"}, {"cache": False}):
        with pytest.raises(UserError, match=r"00002\.exr: 1 NaN/Inf value\(s\), first at x=7 y=4") as e:
            ds = WindowDataset(dataset, 3, progress=False, **kwargs)
            for i in range(len(ds)):
                ds[i]
        assert "\n" not in str(e.value)


def test_a_build_waits_for_another_one_and_does_not_repeat_it(dataset, tmp_path, monkeypatch):
    """Two trainings started together on the same data decode it once: while another process
    holds the build lock a second build waits, then finds the arrays built."""
    import fcntl
    import threading

    seq, root = dataset / "pan", tmp_path / "cache"
    root.mkdir()
    done = threading.Event()
    with open(root / ".build.lock", "a") as other:
        fcntl.flock(other, fcntl.LOCK_EX)  # the other process, building
        waiting = threading.Thread(target=lambda: (prepare_caches([seq], BUFFERS, root, progress=False), done.set()))
        waiting.start()
        assert not done.wait(0.5)
        for r, b in BUFFERS:  # what the other process builds meanwhile
            SequenceCache(seq, root).build(r, b)
        monkeypatch.setattr(SequenceCache, "build", lambda *a, **k: pytest.fail("built again"))
        fcntl.flock(other, fcntl.LOCK_UN)
    waiting.join(30)
    assert done.is_set()
