"""Every shipped checkpoint exports: a bundle a user would make first, checked by `bundle check`.
The default ntaau_x2 trains on three jitter patterns; its bundle asks for the grid one."""

from __future__ import annotations

import json

import pytest

from mnss_kit.cli import main
from mnss_kit.model.checkpoint import shipped_names


@pytest.mark.parametrize("name", ["ntaau_x2", "ntaau_x2_fast", "ntaau_lr_x2", "ntaau_lr_modes"])
def test_a_shipped_ntaau_checkpoint_exports_a_valid_bundle(name, tmp_path, synthetic_dataset):
    assert name in shipped_names()
    out = tmp_path / "bundle"
    assert main(["export", name, "--out", str(out), "--resolution", "64x48", "--data", str(synthetic_dataset),
                 "--no-progress"]) == 0
    assert main(["bundle", "check", str(out)]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["jitter"]["pattern"] == "grid"
