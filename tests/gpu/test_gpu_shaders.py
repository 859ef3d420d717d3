"""The runtime shader files: flattening, ES 3.10 validity (glslangValidator) and agreement of
every declaration with the pass records the harness and the bundle manifest use; one record file
per pass, naming only its own uniforms."""

from __future__ import annotations

import ast
import importlib
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from mnss_kit.gpu import glsl
from mnss_kit.gpu import passes as passes_package
from mnss_kit.gpu.passes import PASSES

ENTRIES = sorted(p.entry for p in PASSES.values())
GLSLANG = shutil.which("glslangValidator")


def test_every_entry_file_has_a_pass_and_every_pass_a_file():
    files = sorted(p.name for p in glsl.RUNTIME_SHADER_DIR.glob("*.comp"))
    assert files == ENTRIES


def test_flatten_includes_each_file_once_and_keeps_the_version_first():
    text = glsl.flatten("inpaint_weights_pass.comp")
    assert text.startswith("#version 310 es\n")
    assert "#include" not in text
    assert text.count("// ---- begin common.glsl") == 1  # reached through three include paths
    assert "uint half_bits(float x)" in text


def test_flatten_rejects_a_missing_include(tmp_path):
    (tmp_path / "a.comp").write_text('#version 310 es\n#include "missing.glsl"\n')
    with pytest.raises(FileNotFoundError, match="missing.glsl"):
        glsl.flatten("a.comp", tmp_path)


def test_flatten_ends_include_cycles(tmp_path):
    (tmp_path / "a.comp").write_text('#version 310 es\n#include "b.glsl"\n')
    (tmp_path / "b.glsl").write_text('#include "c.glsl"\nfloat b;\n')
    (tmp_path / "c.glsl").write_text('#include "b.glsl"\nfloat c;\n')
    text = glsl.flatten("a.comp", tmp_path)
    assert text.index("float c;") < text.index("float b;")
    assert text.count("float b;") == 1


@pytest.mark.skipif(GLSLANG is None, reason="glslangValidator not installed (apt-get install glslang-tools)")
@pytest.mark.parametrize("entry", ENTRIES)
def test_glslang_accepts_flattened_shader_as_es_310(entry, tmp_path):
    path = tmp_path / entry
    path.write_text(glsl.flatten(entry))
    result = subprocess.run([GLSLANG, "-S", "comp", str(path)], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stdout + result.stderr


DECLARATION = re.compile(r"^layout\(([^)]*)\)\s+uniform\s+(?:writeonly\s+|readonly\s+)?highp\s+(\w+)\s+(\w+);", re.M)
BUFFER = re.compile(
    r"^layout\(std430,\s*binding\s*=\s*(\d+)\)\s+(?:readonly\s+|writeonly\s+)?buffer\s+\w+\s*\{\s*(\w+)\s+(\w+)\[\];", re.M
)
UNIFORM = re.compile(r"^uniform\s+\w+\s+(u_\w+);", re.M)
LOCAL_SIZE = re.compile(r"^layout\(local_size_x = (\d+)(?:, local_size_y = (\d+))?(?:, local_size_z = (\d+))?\) in;", re.M)


@pytest.mark.parametrize("name", sorted(PASSES))
def test_shader_declarations_match_the_pass_table(name):
    spec = PASSES[name]
    text = glsl.flatten(spec.entry)
    found = set()
    for qualifiers, gl_type, var in DECLARATION.findall(text):
        unit = int(re.search(r"binding\s*=\s*(\d+)", qualifiers).group(1))
        fmt = qualifiers.split(",")[0].strip() if gl_type.startswith("image") else None
        kind = "image" if gl_type.startswith("image") else "sampler"
        found.add((var, kind, unit, gl_type.endswith("Array"), fmt))
    for unit, element, var in BUFFER.findall(text):
        found.add((var, "buffer", int(unit), False, f"{element}[]"))
    want = {(b.name, b.kind, b.unit, b.array, b.format if b.kind != "sampler" else None) for b in spec.bindings}
    assert found == want
    assert set(UNIFORM.findall(text)) == set(spec.uniforms)
    x, y, z = LOCAL_SIZE.search(text).groups()
    assert (int(x), int(y or 1), int(z or 1)) == spec.local_size


PASS_DIR = Path(passes_package.__file__).parent


def test_every_pass_file_is_in_the_table_and_every_entry_has_a_file():
    files = sorted(p.stem for p in PASS_DIR.glob("*_pass.py"))
    assert files == sorted(PASSES)
    for name, spec in PASSES.items():
        module = importlib.import_module(f"mnss_kit.gpu.passes.{name}")
        assert module.PASS is spec
        assert spec.reference is not None and spec.outputs is not None, name


@pytest.mark.parametrize("name", sorted(PASSES))
def test_a_pass_file_names_only_its_declared_uniforms(name):
    """Uniform names are declared once, in the pass's record; its reference reads only those."""
    tree = ast.parse((PASS_DIR / f"{name}.py").read_text())
    named = {n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str)
             and re.fullmatch(r"u_\w+", n.value)}
    assert named <= set(PASSES[name].uniforms)


def test_a_schedule_step_takes_only_declared_uniforms():
    from mnss_kit.gpu.plan import const, step

    ok = step("sharpen_pass", "sharpen", "enhance", {"image": "history", "display": "display"}, {"u_beta": const(0.1)}, (4, 4), 2)
    assert ok["uniforms"] == {"u_beta": {"value": 0.1}}
    with pytest.raises(ValueError, match="sharpen_pass declares no uniform u_gain"):
        step("sharpen_pass", "sharpen", "enhance", {}, {"u_beta": const(0.1), "u_gain": const(1.0)}, (4, 4), 2)
