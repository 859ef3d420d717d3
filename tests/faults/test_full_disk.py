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
