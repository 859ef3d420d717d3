"""The debug views a bundle offers (manifest ``debug_views``, written by the family's GPU plan):
the schema and ``bundle check`` hold them to the resources, and the Java core reads them or
refuses them naming the entry."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from types import SimpleNamespace

import pytest

from mnss_kit.export.check import check_bundle
from mnss_kit.model.mnss.gpu_plan import debug_views


@pytest.fixture()
def copy(tiny_bundle, tmp_path) -> Path:
    return Path(shutil.copytree(tiny_bundle, tmp_path / "bundle"))


def edit(bundle: Path, change) -> None:
    manifest = json.loads((bundle / "manifest.json").read_text())
    change(manifest)
    (bundle / "manifest.json").write_text(json.dumps(manifest))


def test_export_offers_the_weight_map_history_and_motion(tiny_bundle):
    manifest = json.loads((tiny_bundle / "manifest.json").read_text())
    views = {v["name"]: v for v in manifest["debug_views"]}
    assert list(views) == ["weight map", "history taken", "motion"]
    assert views["weight map"]["map"] == "scalar" and views["history taken"]["map"] == "mask"
    assert views["history taken"]["on_reset"] == 1.0 > views["history taken"]["below"]  # nothing marked on a reset
    resources = {r["name"]: r for r in manifest["resources"]}
    assert all(resources[v["resource"]]["kind"] == "texture2d" for v in views.values())
    assert check_bundle(tiny_bundle) == []


def test_a_model_without_history_offers_only_motion():
    assert [v["resource"] for v in debug_views(SimpleNamespace(with_history=False))] == ["motion"]


def test_bundle_check_and_the_java_core_refuse_a_view_of_a_buffer(copy, java_core, tmp_path):
    edit(copy, lambda m: m["debug_views"][0].update(resource="npu_input"))
    assert check_bundle(copy) == ["manifest.json: debug_views/0 ('weight map'): 'npu_input' is not a texture in resources"]
    result = java_core.java("io.mnsskit.core.ContractTool", "read", str(copy), str(tmp_path / "log"))
    assert result.returncode != 0 and "debug_views/0 resource 'npu_input' is not a 2D texture in resources" in result.stderr


def test_schema_requires_a_mask_threshold_and_a_range(copy):
    def change(m):
        del m["debug_views"][1]["below"]
        del m["debug_views"][2]["range"]

    edit(copy, change)
    problems = check_bundle(copy)
    assert any("debug_views/1" in p and "'below' is a required property" in p for p in problems), problems
    assert any("debug_views/2" in p and "'range' is a required property" in p for p in problems), problems


def test_a_bundle_without_views_still_reads(copy, java_core, tmp_path):
    edit(copy, lambda m: m.pop("debug_views"))
    assert check_bundle(copy) == []
    java_core.tool("read", str(copy), str(tmp_path / "log"))
