"""JOGL on this machine: an OpenGL ES 3.2 context on Mesa llvmpipe with no display, and the GL
calls the app's frame pipeline makes (compute, SSBO, imageStore into RGBA16F / R32UI, barrier,
read-back), through JOGL's GL4ES3 interface.  The first step towards running the app's GL code
here (tests/android/jogl/GlesProbe.java says how the context is obtained)."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest

from java_harness import JAVA_RELEASE, missing_tools

PROBE = Path(__file__).parent / "jogl" / "GlesProbe.java"
# Debian's libjogl2-java and libgluegen2-rt-java (their native parts: libjogl2-jni, libgluegen2-jni)
JOGL_JARS = (Path(os.environ.get("MNSS_JOGL_JAR", "/usr/share/java/jogl2.jar")),
             Path(os.environ.get("MNSS_GLUEGEN_JAR", "/usr/share/java/gluegen2-rt.jar")))


def test_jogl_gets_a_gles_3_2_context_that_runs_compute(tmp_path):
    reason = missing_tools() or next((f"{jar} not found (apt-get install -y libjogl2-java libjogl2-jni libgluegen2-rt-java "
                                      "libgluegen2-jni)" for jar in JOGL_JARS if not jar.is_file()), None)
    if reason:
        pytest.skip(reason)
    classpath = os.pathsep.join(map(str, JOGL_JARS))
    javac = subprocess.run(["javac", "--release", str(JAVA_RELEASE), "-Xlint:all", "-Werror", "-d", str(tmp_path), "-cp", classpath,
                            str(PROBE)], capture_output=True, text=True, timeout=120)
    assert javac.returncode == 0, javac.stderr
    env = {**os.environ, "EGL_PLATFORM": "surfaceless"}
    run = subprocess.run(["java", "-Djogl.disable.opengldesktop", "-cp", os.pathsep.join([str(tmp_path), classpath]), "GlesProbe"],
                         capture_output=True, text=True, timeout=120, env=env)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-4000:]
    assert re.search(r"^version OpenGL ES 3\.[2-9]", run.stdout, re.M), run.stdout
    assert "checked 48 wrong 0 gl_error 0" in run.stdout
