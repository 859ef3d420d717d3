"""Compiling and running the Android app's plain-Java core (android/core) from the tests.

The core (android/core/src/main/java) and its JUnit 4 tests (android/core/src/test/java) are
compiled with javac into a temporary directory; tests run JUnit or the test-only ``ContractTool``
on it.  The JUnit 4, Hamcrest and org.json jars are looked up at ``MNSS_JUNIT_JAR`` /
``MNSS_HAMCREST_JAR`` / ``MNSS_ORG_JSON_JAR`` or Debian's paths
(``apt-get install -y default-jdk-headless junit4 libandroid-json-java``).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
CORE = REPO / "android" / "core"
JUNIT_JAR = Path(os.environ.get("MNSS_JUNIT_JAR", "/usr/share/java/junit4.jar"))
HAMCREST_JAR = Path(os.environ.get("MNSS_HAMCREST_JAR", "/usr/share/java/hamcrest-core.jar"))
# org.json as Android ships it (Debian's build of the Android sources; `dpkg -L libandroid-json-java`)
ORG_JSON_JAR = Path(os.environ.get("MNSS_ORG_JSON_JAR", "/usr/share/java/com.android.json.jar"))
LIBRARIES = ((JUNIT_JAR, "junit4", "MNSS_JUNIT_JAR"), (HAMCREST_JAR, "junit4", "MNSS_HAMCREST_JAR"),
             (ORG_JSON_JAR, "libandroid-json-java", "MNSS_ORG_JSON_JAR"))
LIBRARY_JARS = tuple(jar for jar, _, _ in LIBRARIES)
# Debian's libjogl2-java and libgluegen2-rt-java (their native parts: libjogl2-jni, libgluegen2-jni)
JOGL_JARS = (Path(os.environ.get("MNSS_JOGL_JAR", "/usr/share/java/jogl2.jar")),
             Path(os.environ.get("MNSS_GLUEGEN_JAR", "/usr/share/java/gluegen2-rt.jar")))
JOGL_PACKAGES = "libjogl2-java libjogl2-jni libgluegen2-rt-java libgluegen2-jni"
GLJOGL = REPO / "android" / "gljogl"
JAVA_RELEASE = 17
PACKAGE = "io.mnsskit.core"


@dataclass
class JavaCore:
    """The compiled core plus test classes."""

    classes: Path

    @property
    def classpath(self) -> str:
        return os.pathsep.join([str(self.classes), *map(str, LIBRARY_JARS)])

    def java(self, main: str, *args: str, props: dict[str, str] | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
        flags = [f"-D{k}={v}" for k, v in (props or {}).items()]
        cmd = ["java", "-Xshare:auto", "-XX:TieredStopAtLevel=1", *flags, "-cp", self.classpath, main, *args]
        return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)

    def junit(self, *test_classes: str, props: dict[str, str] | None = None) -> str:
        """Run JUnit 4 test classes (simple names); fail with JUnit's report unless all pass."""
        result = self.java("org.junit.runner.JUnitCore", *(f"{PACKAGE}.{c}" for c in test_classes), props=props)
        if result.returncode != 0:
            pytest.fail(f"JUnit failed:\n{result.stdout[-6000:]}\n{result.stderr[-2000:]}", pytrace=False)
        return result.stdout

    def tool(self, *args: str) -> str:
        """Run the test-only ContractTool; its stdout (fails the test on a non-zero exit)."""
        result = self.java(f"{PACKAGE}.ContractTool", *args)
        if result.returncode != 0:
            pytest.fail(f"ContractTool {' '.join(args)} failed:\n{result.stderr[-4000:]}", pytrace=False)
        return result.stdout


def missing_tools() -> str | None:
    """Why the Java tests cannot run here, or None."""
    for tool in ("javac", "java"):
        if shutil.which(tool) is None:
            return f"{tool} not found (install a JDK {JAVA_RELEASE}+, e.g. apt-get install -y default-jdk-headless)"
    for jar, package, variable in LIBRARIES:
        if not jar.is_file():
            return f"{jar} not found (apt-get install -y {package}, or set {variable})"
    version = subprocess.run(["javac", "-version"], capture_output=True, text=True)
    match = re.search(r"(\d+)", version.stdout + version.stderr)
    if not match or int(match.group(1)) < JAVA_RELEASE:
        return f"javac {JAVA_RELEASE}+ needed, found: {(version.stdout + version.stderr).strip()}"
    return None


def missing_jogl() -> str | None:
    """Why JOGL cannot run here (on top of :func:`missing_tools`), or None."""
    return missing_tools() or next((f"{jar} not found (apt-get install -y {JOGL_PACKAGES})" for jar in JOGL_JARS if not jar.is_file()), None)


def jogl_run(cmd: list[str], timeout: float = 300) -> subprocess.CompletedProcess:
    """Run ``java ...`` the way JOGL gets a display-less OpenGL ES context on Mesa (android/gljogl/JoglContext.java)."""
    env = {**os.environ, "EGL_PLATFORM": "surfaceless"}
    return subprocess.run([cmd[0], "-Djogl.disable.opengldesktop", *cmd[1:]], capture_output=True, text=True, timeout=timeout, env=env)


def java_sources(kind: str, root: Path = CORE) -> list[Path]:
    return sorted((root / "src" / kind / "java").rglob("*.java"))


def javac(sources: list[Path], out: Path, classpath: list[Path], what: str) -> None:
    """javac ``sources`` into ``out`` as the app's build does (warnings are errors); fails the test with javac's errors."""
    cmd = ["javac", "--release", str(JAVA_RELEASE), "-Xlint:all", "-Werror", "-encoding", "UTF-8", "-d", str(out),
           "-cp", os.pathsep.join(map(str, classpath)), *map(str, sources)]
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    if result.returncode != 0:
        pytest.fail(f"javac failed on {what}:\n{result.stderr[-6000:]}", pytrace=False)


def compile_core(out: Path) -> JavaCore:
    """javac the core and its tests into ``out``; fails the test with javac's errors."""
    javac(java_sources("main") + java_sources("test"), out, list(LIBRARY_JARS), "android/core")
    return JavaCore(out)


def compile_gl_pipeline(out: Path) -> Path:
    """javac the core's main sources and android/gljogl (the JOGL binding of the pipeline) into ``out``."""
    javac(java_sources("main") + java_sources("main", GLJOGL), out, [*LIBRARY_JARS, *JOGL_JARS], "android/core + android/gljogl")
    return out


def run_jogl_main(classes: Path, main: str, *args: str) -> subprocess.CompletedProcess:
    """Run ``main`` of the compiled core + android/gljogl on Mesa through JOGL."""
    classpath = os.pathsep.join(map(str, [classes, *LIBRARY_JARS, *JOGL_JARS]))
    return jogl_run(["java", "-Xshare:auto", "-XX:TieredStopAtLevel=1", "-cp", classpath, main, *args])


def run_gl_pipeline(classes: Path, bundle: Path) -> tuple[int, int]:
    """Run the app's frame pipeline over ``bundle``'s golden frames on Mesa through JOGL
    (``GlPipelineCheck``); fails the test unless every GL-produced tensor matches.  Returns
    (tensors, values) compared."""
    run = run_jogl_main(classes, "io.mnsskit.gljogl.GlPipelineCheck", str(bundle))
    print(run.stdout)
    if run.returncode != 0:
        pytest.fail(f"GL pipeline check on {bundle} failed:\n{run.stdout[-6000:]}\n{run.stderr[-4000:]}", pytrace=False)
    match = re.search(r"^compared (\d+) tensors (\d+) values, 0 wrong$", run.stdout, re.M)
    assert match, run.stdout
    return int(match.group(1)), int(match.group(2))
