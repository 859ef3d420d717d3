"""The package layout keeps its layers: ops/ is pure numpy, emulate/ never needs torch, no stage
imports a later one (render -> dataset -> model -> train -> eval -> finetune -> quantize -> split ->
export -> emulate -> bench -> stress -> size -> report), and every stage names its modules alike: a
``command.py`` (the command line) and a ``run.py`` (the entry function the command runs)."""

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parent.parent / "mnss_kit"
STAGES = ["render", "dataset", "model", "train", "eval", "finetune", "quantize", "split", "export", "emulate", "bench", "stress",
          "size", "report"]
# Stages that may be imported from anywhere: shared foundations, not pipeline steps.
SHARED = {"ops", "metrics", "config", "errors", "fileio", "resources", "shaders", "gpu", "zoo"}
# Stages without one entry function: ``mnss-kit data`` runs several actions, each in the module named
# by what it does (check, cache, importers, variants).
NO_ENTRY_MODULE = {"dataset"}
# The on-disk dataset format is a contract: the renderer writes it, every later stage reads it.
# So is the family table's list of the buffers each family reads (docs/dataset.md, "Buffers each
# model family needs"): data check names them (model.families is light: no torch at import).
# So is a size file (``mnss-kit size``'s choice), which any command taking a checkpoint resolves
# (model.checkpoint; size.choice imports no stage).
CONTRACT_MODULES = {"mnss_kit.dataset.format", "mnss_kit.dataset.exr", "mnss_kit.model.families", "mnss_kit.size.choice"}


def imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    rel = path.relative_to(PKG.parent).with_suffix("")
    package = list(rel.parts[:-1])
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
                if node.module is None:
                    names.update(f"{mod}.{a.name}" for a in node.names)
                else:
                    names.add(mod)
            else:
                names.add(node.module)
    return names


def python_files(sub: str) -> list[Path]:
    root = PKG / sub
    return sorted(root.rglob("*.py")) if root.is_dir() else []


def stage_of(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] != "mnss_kit" or len(parts) < 2:
        return None
    return parts[1]


def test_every_package_is_a_stage_or_shared():
    packages = {p.parent.name for p in PKG.glob("*/__init__.py")}
    assert packages - set(STAGES) - SHARED == set()
    assert len(STAGES) == len(set(STAGES))


@pytest.mark.parametrize("stage", STAGES)
def test_every_stage_has_a_command_and_a_run_module_the_command_uses(stage):
    """One name per concept: ``command.py`` the command line, ``run.py`` the entry function it runs."""
    root = PKG / stage
    assert (root / "command.py").is_file(), f"{stage}/ has no command.py"
    if stage in NO_ENTRY_MODULE:
        assert not (root / "run.py").exists()
        return
    assert (root / "run.py").is_file(), f"{stage}/ has no run.py"
    assert f"mnss_kit.{stage}.run" in package_imports(root / "command.py"), f"{stage}/command.py does not use run.py"


@pytest.mark.parametrize("path", python_files("ops"), ids=lambda p: p.name)
def test_ops_import_only_numpy(path):
    for mod in imported_modules(path):
        top = mod.split(".")[0]
        if top == "mnss_kit":
            assert stage_of(mod) in ("ops", "errors"), f"{path.name} imports {mod}"
        else:
            assert top in {"numpy", "__future__", "math", "dataclasses", "typing", "functools", "enum"}, (
                f"{path.name} imports {mod}: ops/ may import only numpy"
            )


@pytest.mark.parametrize("path", python_files("emulate") + python_files("gpu"), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_emulate_and_gpu_reference_do_not_import_torch(path):
    for mod in imported_modules(path):
        assert mod.split(".")[0] != "torch", f"{path.name} imports {mod}"


@pytest.mark.parametrize("stage", STAGES)
def test_no_stage_imports_a_later_one(stage):
    later = set(STAGES[STAGES.index(stage) + 1 :])
    for path in python_files(stage):
        for mod in imported_modules(path):
            target = stage_of(mod)
            if target in later and mod not in CONTRACT_MODULES:
                pytest.fail(f"{path.relative_to(PKG)} ({stage}) imports {mod} from the later stage {target}")


def test_metrics_import_no_stage():
    for path in python_files("metrics"):
        for mod in imported_modules(path):
            target = stage_of(mod)
            assert target is None or target in SHARED, f"{path.relative_to(PKG)} imports {mod}"


def _family_stage_names() -> dict[str, set[str]]:
    """Stage names of every family, from a model of each family's default config."""
    from mnss_kit.model.families import FAMILIES

    names = {}
    for name, family in FAMILIES.items():
        model = family.build(family.config())
        names[name] = {stage for stage, _, _ in model.stages()}
    return names


def _stage_mentions(path: Path, stages: set[str]) -> list[str]:
    """String constants equal to a stage name, and attribute reads ``model.<stage>``, in ``path``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in stages:
            found.append(f"line {node.lineno}: '{node.value}'")
        elif isinstance(node, ast.Attribute) and node.attr in stages and isinstance(node.value, ast.Name) and node.value.id == "model":
            found.append(f"line {node.lineno}: .{node.attr}")
    return found


def test_no_module_outside_a_family_folder_names_its_stages():
    """Every stage after model/ asks the family record (model.families.FAMILIES) instead.  The GPU
    pass library (gpu/, gpu/passes/) may use its passes' binding names, which are shader interface names; a
    family folder may name its own stages where another family has one of the same name (``steer``)."""
    from mnss_kit.gpu.passes import PASSES

    bindings = {b.name for p in PASSES.values() for b in p.bindings}
    all_stages = _family_stage_names()
    for family, stages in all_stages.items():
        own = PKG / "model" / family
        for path in sorted(PKG.rglob("*.py")):
            if own in path.parents:
                continue
            names = stages - bindings if PKG / "gpu" in path.parents else stages
            folder = path.relative_to(PKG).parts
            if len(folder) > 2 and folder[0] == "model" and folder[1] in all_stages:
                names = names - all_stages[folder[1]]
            mentions = _stage_mentions(path, names)
            assert not mentions, f"{path.relative_to(PKG)} names {family} stages: {'; '.join(mentions)}"


def module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


MODULES = {module_name(p): p for p in sorted(PKG.rglob("*.py"))}


def package_imports(path: Path) -> set[str]:
    """The package's modules that ``path`` imports, at module level or inside functions.

    ``from .pkg import name`` counts as importing ``pkg.name`` when that is a module, else ``pkg``.
    """
    found = set()
    for mod in imported_modules(path):
        while mod and mod not in MODULES:  # ``pkg.name`` where ``name`` is not a module
            mod = mod.rpartition(".")[0]
        if mod:
            found.add(mod)
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):  # ``from pkg import module``: imported_modules keeps only ``pkg``
        if isinstance(node, ast.ImportFrom) and node.module is not None:
            base = module_name(path) if path.name == "__init__.py" else module_name(path).rpartition(".")[0]
            for _ in range(max(node.level - 1, 0)):
                base = base.rpartition(".")[0]
            pkg = f"{base}.{node.module}" if node.level else node.module
            found.update(f"{pkg}.{a.name}" for a in node.names if f"{pkg}.{a.name}" in MODULES)
    found.discard(module_name(path))
    return found


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected groups of more than one module (Tarjan), each sorted."""
    index, low, stack, on_stack, groups = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                groups.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return groups


def test_import_cycles_are_found():
    assert import_cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert import_cycles({"a": {"b"}, "b": set()}) == []


def test_package_has_no_import_cycle():
    graph = {name: package_imports(path) for name, path in MODULES.items()}
    assert import_cycles(graph) == []


def _calls_log10(path: Path) -> bool:
    tree = ast.parse(path.read_text(), filename=str(path))
    return any(isinstance(n, ast.Attribute) and n.attr == "log10" or isinstance(n, ast.Name) and n.id == "log10"
               for n in ast.walk(tree))


def test_only_metrics_computes_psnr():
    """PSNR has one definition (metrics/psnr.py, and its tensor form in metrics/image.py).

    quantize/sensitivity.py computes SQNR, a ratio of summed powers rather than a peak over MSE.
    """
    allowed = {"metrics", "quantize/sensitivity.py"}
    offenders = [str(p.relative_to(PKG)) for p in PKG.rglob("*.py") if _calls_log10(p)]
    assert [p for p in offenders if p.split("/")[0] not in allowed and p not in allowed] == []
    assert "metrics/psnr.py" in offenders


def test_metrics_package_and_emulator_load_without_torch():
    import subprocess
    import sys

    code = ("import sys, mnss_kit.metrics, mnss_kit.emulate.run, mnss_kit.emulate.compare; "
            "assert 'torch' not in sys.modules, 'torch was imported'")
    result = subprocess.run([sys.executable, "-c", code], cwd=PKG.parent, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


def _calls(path: Path, names: set[str]) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    return {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute) and n.attr in names}


def test_one_tflite_reader_and_one_writer():
    """``export/npu_files.py`` parses .tflite files, ``quantize/tflite_writer.py`` builds them; NpuTensor is defined once."""
    readers = [str(p.relative_to(PKG)) for p in PKG.rglob("*.py") if _calls(p, {"InitFromPackedBuf", "InitFromObj", "GetRootAs"})]
    writers = [str(p.relative_to(PKG)) for p in PKG.rglob("*.py") if _calls(p, {"Builder"})]
    tensor_classes = [str(p.relative_to(PKG)) for p in PKG.rglob("*.py")
                      if any(isinstance(n, ast.ClassDef) and n.name == "NpuTensor" for n in ast.walk(ast.parse(p.read_text())))]
    assert readers == ["export/npu_files.py"]
    assert writers == ["quantize/tflite_writer.py"]
    assert tensor_classes == ["export/npu_files.py"]
