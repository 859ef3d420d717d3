"""JOGL on this machine: an OpenGL ES 3.2 context on Mesa llvmpipe with no display, and the GL
calls the app's frame pipeline makes (compute, SSBO, imageStore into RGBA16F / R32UI, barrier,
read-back), through JOGL's GL4ES3 interface: the ground test_gl_pipeline.py stands on
(android/gljogl/JoglContext.java says how the context is obtained)."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from java_harness import GLJOGL, JOGL_JARS, java_sources, javac, jogl_run, missing_jogl

PROBE = Path(__file__).parent / "jogl" / "GlesProbe.java"


def test_jogl_gets_a_gles_3_2_context_that_runs_compute(tmp_path):
    reason = missing_jogl()
    if reason:
        pytest.skip(reason)
    context = [p for p in java_sources("main", GLJOGL) if p.name == "JoglContext.java"]
    javac([PROBE, *context], tmp_path, list(JOGL_JARS), "the JOGL probe")
    run = jogl_run(["java", "-cp", os.pathsep.join(map(str, [tmp_path, *JOGL_JARS])), "GlesProbe"], timeout=120)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-4000:]
    assert re.search(r"^version OpenGL ES 3\.[2-9]", run.stdout, re.M), run.stdout
    assert "checked 48 wrong 0 gl_error 0" in run.stdout
