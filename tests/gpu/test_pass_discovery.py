"""The GPU pass table is discovered: every ``*_pass.py`` of ``gpu/passes`` is in it, in its ``ORDER``,
and the ordering refuses a duplicate ``ORDER`` or a pass module without ``PASS`` / ``ORDER``."""

from __future__ import annotations

import importlib
from pathlib import Path
from types import SimpleNamespace

import pytest

import mnss_kit.gpu.passes as passes_package
from mnss_kit.gpu.passes import PASS_ORDER, PASSES, discover_pass_modules, order_passes

PASS_DIR = Path(passes_package.__file__).parent


def fake(name: str, **attrs) -> SimpleNamespace:
    return SimpleNamespace(__name__=f"mnss_kit.gpu.passes.{name}", **attrs)


def record(name: str) -> SimpleNamespace:
    return SimpleNamespace(name=name)


def test_discovery_finds_every_pass_file():
    files = sorted(p.stem for p in PASS_DIR.glob("*_pass.py"))
    assert sorted(m.__name__.rpartition(".")[2] for m in discover_pass_modules()) == files
    assert sorted(PASSES) == files


def test_the_table_is_in_order_and_every_order_is_distinct():
    orders = [importlib.import_module(f"mnss_kit.gpu.passes.{name}").ORDER for name in PASS_ORDER]
    assert orders == sorted(orders)
    assert len(set(orders)) == len(orders)
    assert all(type(o) is int for o in orders)


def test_order_passes_sorts_by_order_not_by_name():
    modules = [fake("b_pass", PASS=record("b_pass"), ORDER=20), fake("c_pass", PASS=record("c_pass"), ORDER=5),
               fake("a_pass", PASS=record("a_pass"), ORDER=30)]
    assert tuple(order_passes(modules)) == ("c_pass", "b_pass", "a_pass")


def test_order_passes_refuses_a_duplicate_order():
    modules = [fake("a_pass", PASS=record("a_pass"), ORDER=110), fake("b_pass", PASS=record("b_pass"), ORDER=110)]
    with pytest.raises(ValueError, match=r"a_pass and b_pass both have ORDER = 110"):
        order_passes(modules)


@pytest.mark.parametrize("attrs, missing", [({"ORDER": 10}, "PASS"), ({"PASS": record("a_pass")}, "ORDER"),
                                            ({}, "PASS and no ORDER")])
def test_order_passes_refuses_a_module_without_pass_or_order(attrs, missing):
    with pytest.raises(ValueError, match=f"a_pass defines no {missing}"):
        order_passes([fake("a_pass", **attrs)])


@pytest.mark.parametrize("order", ["110", 110.0, True, None])
def test_order_passes_refuses_an_order_that_is_not_an_int(order):
    with pytest.raises(ValueError, match="ORDER must be an int"):
        order_passes([fake("a_pass", PASS=record("a_pass"), ORDER=order)])


def test_order_passes_refuses_a_pass_named_unlike_its_module():
    with pytest.raises(ValueError, match="declares PASS named 'b_pass'"):
        order_passes([fake("a_pass", PASS=record("b_pass"), ORDER=10)])
