from dataclasses import dataclass, field
from typing import Literal

import pytest

from mnss_kit.config import apply_overrides, from_dict, load_config
from mnss_kit.errors import UserError


@dataclass
class Inner:
    lr: float = 1e-3
    mode: Literal["a", "b"] = "a"


@dataclass
class Outer:
    name: str
    steps: int = 10
    inner: Inner = field(default_factory=Inner)
    sizes: tuple[int, int] = (4, 3)


def test_valid_config_builds_typed_objects(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("name: x\nsteps: 3\ninner: {lr: 0.5, mode: b}\nsizes: [8, 6]\n")
    cfg = load_config(Outer, p)
    assert cfg == Outer(name="x", steps=3, inner=Inner(lr=0.5, mode="b"), sizes=(8, 6))


@pytest.mark.parametrize(
    "text, needle",
    [
        ("name: x\nstepz: 3\n", "unknown key 'stepz'"),
        ("name: x\ninner: {lrr: 1}\n", "unknown key 'inner.lrr'"),
        ("name: x\nsteps: many\n", "'steps' must be an integer"),
        ("name: x\ninner: {mode: c}\n", "'inner.mode' must be one of"),
        ("steps: 3\n", "missing required key 'name'"),
        ("name: x\nsizes: [1]\n", "'sizes' must have 2 items"),
        ("name: [unclosed\n", "not valid YAML"),
    ],
)
def test_bad_config_names_key_and_file(tmp_path, text, needle):
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(UserError) as e:
        load_config(Outer, p)
    assert needle in str(e.value)
    assert "\n" not in str(e.value)
    if "YAML" not in needle:
        assert str(p) in str(e.value)


def test_overrides_are_typed_not_executed():
    data = apply_overrides({"name": "x", "inner": {"lr": 1.0}}, ["inner.lr=1e-4", "steps=7", "name=__import__('os')"])
    cfg = from_dict(Outer, data)
    assert cfg.inner.lr == pytest.approx(1e-4) and cfg.steps == 7
    assert cfg.name == "__import__('os')"
    with pytest.raises(UserError):
        apply_overrides({}, ["novalue"])
