"""MesaPasses compiles shader sources given by pass name (a bundle's files) instead of the package's."""

from __future__ import annotations

import numpy as np
import pytest

from mnss_kit.errors import UserError
from mnss_kit.gpu.glsl import flatten
from mnss_kit.gpu.passes import PASSES

from gpu_helpers import random_conv
from pass_calls import NamedPasses


def test_given_source_is_what_runs(mesa, tmp_path):
    """The sharpen pass from a file, edited to write black: the edit is visible, other passes need a source too."""
    from mnss_kit.gpu.mesa import MesaPasses

    text = flatten(PASSES["sharpen_pass"].entry)
    edited = text.replace("void main()", "void main_unused()", 1) + (
        "\nvoid main() { imageStore(display, ivec2(gl_GlobalInvocationID.xy), vec4(0.0)); }\n")
    path = tmp_path / "sharpen_pass.comp"
    path.write_text(edited)
    image = np.full((8, 8, 3), 0.5, np.float32)
    assert mesa.sharpen(image, 0.15).max() > 0
    passes = NamedPasses(MesaPasses(mesa.ctx, sources={"sharpen_pass": path}))
    assert passes.sharpen(image, 0.15).max() == 0
    with pytest.raises(UserError, match="no shader source for GPU pass conv3x3_pass"):
        passes.conv3x3(image[..., :3], random_conv(np.random.default_rng(0), 3, 3), "none")


def test_text_sources_and_compile_errors_name_their_origin(mesa, tmp_path):
    from mnss_kit.gpu.mesa import MesaPasses

    image = np.full((4, 4, 3), 0.25, np.float32)
    text = NamedPasses(MesaPasses(mesa.ctx, sources={"sharpen_pass": flatten(PASSES["sharpen_pass"].entry)}))
    np.testing.assert_array_equal(text.sharpen(image, 0.15), mesa.sharpen(image, 0.15))
    broken = tmp_path / "broken.comp"
    broken.write_text("#version 310 es\nvoid main() { this is not glsl; }\n")
    with pytest.raises(UserError, match=r"broken\.comp: does not compile"):
        NamedPasses(MesaPasses(mesa.ctx, sources={"sharpen_pass": broken})).sharpen(image, 0.15)
    with pytest.raises(UserError, match=r"missing\.comp: cannot read"):
        NamedPasses(MesaPasses(mesa.ctx, sources={"sharpen_pass": tmp_path / "missing.comp"})).sharpen(image, 0.15)
