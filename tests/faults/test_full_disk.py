"""A full disk while a dataset is copied (``data variant``): one line naming the output, nothing left."""

from __future__ import annotations

import shutil

from mnss_kit.cli import main


def test_a_full_disk_during_data_variant_is_one_line_and_leaves_nothing(synthetic_dataset, tmp_path, monkeypatch, capsys):
    def full(src, dst, **kwargs):  # copytree gathers per-file errors into one shutil.Error
        raise shutil.Error([(str(src), str(dst), "[Errno 28] No space left on device")])

    monkeypatch.setattr(shutil, "copytree", full)
    out = tmp_path / "v"
    assert main(["data", "variant", str(synthetic_dataset), "--out", str(out), "--apply", "ldr8"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"cannot write {out}" in err[0] and "No space left on device" in err[0]
    assert not out.exists() and not list(tmp_path.iterdir())


def test_a_full_disk_during_render_is_one_line(tmp_path, monkeypatch, capsys):
    """OpenEXR reports a full disk as a RuntimeError whose text names it."""
    import OpenEXR

    class Full:
        def __init__(self, *args, **kwargs):
            pass

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def write(self, path):
            raise RuntimeError(f"Failed to write pixel data to image file \"{path}\". No space left on device")

    monkeypatch.setattr(OpenEXR, "File", Full)
    out = tmp_path / "r"
    assert main(["render", "tiny_test", "--out", str(out), "--set", "frames=1", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot write" in err[0] and err[0].endswith("No space left on device")
    assert not list(out.rglob("*.exr"))


def test_a_render_with_no_reference_samples_is_refused_by_its_key(tmp_path, capsys):
    assert main(["render", "tiny_test", "--out", str(tmp_path / "r"), "--set", "hr_samples=0", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "hr_samples must be a square" in err[0] and "got 0" in err[0]
