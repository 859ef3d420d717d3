"""The plain-Java core's own JUnit tests, and the rules that keep android/ honest."""

from __future__ import annotations

import re

from java_harness import CORE, REPO, java_sources

UNIT_TESTS = ("JsonTest", "Int8QuantTest", "ManifestTest", "FrameSchedulerTest", "BundleVerifierTest", "SelfTestTest", "PlaybackTest")
ANDROID = REPO / "android"


def test_junit_unit_tests_pass(java_core):
    out = java_core.junit(*UNIT_TESTS)
    count = int(re.search(r"OK \((\d+) tests?\)", out).group(1))
    assert count >= 30


def test_every_test_class_is_run():
    """A new JUnit class must be listed here or in a contract test, or it would never run."""
    contract = {"QuantVectorsTest", "DisplayVectorsTest", "ContractTool", "MiniBundle"}
    found = {p.stem for p in java_sources("test")}
    assert found == set(UNIT_TESTS) | contract


def test_core_has_no_android_imports():
    """org.json is the one library the core uses: Android ships it, Debian's libandroid-json-java here."""
    offenders = [p.name for p in java_sources("main") if re.search(r"^import\s+(android|androidx)\.", p.read_text(), re.M)]
    assert offenders == [], "android/core must stay plain Java (it is compiled and tested with javac here)"
    libraries = {m for p in java_sources("main") for m in re.findall(r"^import\s+(?:static\s+)?([a-z]+\.[a-z]+)\.", p.read_text(), re.M)}
    assert libraries <= {"java.io", "java.math", "java.nio", "java.security", "java.util", "org.json"}


def test_phone_code_uses_no_java_api_newer_than_android_26():
    """javac --release 17 accepts Java 9+ library calls that Android has only from API 30 (minSdk is 26)."""
    newer = re.compile(r"\b(List|Map|Set)\.(of|copyOf)\(|\.(repeat|strip|isBlank|lines)\(\)?")
    sources = java_sources("main") + list((ANDROID / "app" / "src" / "main" / "java").rglob("*.java"))
    offenders = [f"{p.name}: {m.group(0)}" for p in sources for m in newer.finditer(p.read_text())]
    assert offenders == []


def test_android_carries_no_shader_or_model_copies():
    """Shaders and models come from a bundle on the device; android/ holds none (STYLE.md)."""
    suffixes = {".comp", ".glsl", ".tflite", ".onnx", ".bin", ".pt", ".npz"}
    copies = [str(p.relative_to(ANDROID)) for p in ANDROID.rglob("*") if p.is_file() and p.suffix in suffixes]
    assert copies == []


def test_app_code_takes_bindings_from_the_manifest():
    """Binding units, workgroup sizes and formats live in the manifest, not in the Android glue."""
    app = list((ANDROID / "app" / "src" / "main" / "java").rglob("*.java"))
    assert app, "the Android glue sources are missing"
    for path in app:
        text = path.read_text()
        assert not re.search(r"layout\s*\(\s*binding", text), f"{path.name} declares shader bindings"
        assert not re.search(r"\"\w+_pass\"", text), f"{path.name} names a shader pass; passes come from the manifest"
    assert CORE.is_dir()
