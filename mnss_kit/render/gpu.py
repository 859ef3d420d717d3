"""OpenGL plumbing: one EGL context per process, shader loading, render targets, uploads."""

from __future__ import annotations


import numpy as np

from ..errors import UserError
from .. import resources

SHADER_DIR = resources.SHADER_DIR / "render"
GL_SRGB8_ALPHA8 = 0x8C43
_context = None


def context():
    """The process-wide moderngl context (headless EGL; Mesa llvmpipe on a CPU-only machine)."""
    global _context
    if _context is None:
        import moderngl

        try:
            _context = moderngl.create_context(standalone=True, backend="egl", require=330)
        except Exception as e:  # moderngl raises plain Exceptions for missing EGL/drivers
            first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
            raise UserError(f"cannot create an OpenGL 3.3 context through EGL ({first}); install Mesa EGL (libegl1, libgl1-mesa-dri)") from None
    return _context


def environment() -> dict[str, str]:
    """What besides the config decides a render's last bits: the OpenGL driver (llvmpipe's
    rasteriser and vector width) and the numpy and OpenEXR that compute the cameras and write the
    files.  Two machines that differ here may render the same config to different bytes."""
    import OpenEXR
    from importlib.metadata import version

    info = context().info
    return {"gl_renderer": str(info["GL_RENDERER"]), "gl_version": str(info["GL_VERSION"]),
            "numpy": np.__version__, "openexr": getattr(OpenEXR, "__version__", None) or version("OpenEXR")}


def shader_source(name: str) -> str:
    """GLSL text of ``shaders/render/<name>`` with ``#include "file"`` lines expanded."""
    from ..gpu.glsl import flatten_text

    return flatten_text((SHADER_DIR / name).read_text(), SHADER_DIR)


def program(ctx, vertex: str, fragment: str, defines: tuple[str, ...] = ()):
    """Compile a program; ``defines`` become ``#define NAME`` lines after ``#version``."""
    frag = shader_source(fragment)
    if defines:
        version, rest = frag.split("\n", 1)
        frag = "\n".join([version, *(f"#define {d}" for d in defines), rest])
    return ctx.program(vertex_shader=shader_source(vertex), fragment_shader=frag)


def set_uniform(prog, name: str, value) -> None:
    """Set a uniform if the linker kept it; matrices are row-major numpy, sent column-major."""
    if name not in prog:
        return
    if isinstance(value, np.ndarray) and value.ndim == 2:
        prog[name].write(np.ascontiguousarray(value.T, dtype=np.float32).tobytes())
    elif isinstance(value, (np.ndarray, list, tuple)):
        prog[name].value = tuple(float(v) for v in np.ravel(value))
    else:
        prog[name].value = value


def colour_texture(ctx, image: np.ndarray | None):
    """Mipmapped, repeating sRGB texture from ``(H, W, 3|4)`` uint8 (white 1x1 if None)."""
    import moderngl

    if image is None:
        image = np.full((1, 1, 4), 255, np.uint8)
    img = np.asarray(image, dtype=np.uint8)
    if img.shape[2] == 3:
        img = np.concatenate([img, np.full(img.shape[:2] + (1,), 255, np.uint8)], axis=2)
    tex = ctx.texture((img.shape[1], img.shape[0]), 4, np.ascontiguousarray(img).tobytes(), internal_format=GL_SRGB8_ALPHA8)
    tex.build_mipmaps()
    tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    tex.repeat_x = tex.repeat_y = True
    return tex


def float_texture(ctx, data: np.ndarray):
    """Linear-filtered, clamped float32 texture from ``(H, W, C)``."""
    import moderngl

    tex = ctx.texture((data.shape[1], data.shape[0]), data.shape[2], np.ascontiguousarray(data, np.float32).tobytes(), dtype="f4")
    tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    tex.repeat_x = tex.repeat_y = False
    return tex


class Target:
    """G-buffer and shading framebuffers of one resolution, created once and reused every frame.

    G-buffer: albedo, normal+roughness, emissive+metallic (half), world position and
    motion+depth (float32).  Shading: colour (float32, additive accumulation of
    supersamples), F_beta and emissive (half).  All share one depth buffer so
    particles are depth-tested against the opaque scene.  ``gbuffer_lean`` and
    ``accumulate`` leave out what the supersamples of the reference do not need.
    """

    GBUFFER = (("albedo", "f2"), ("normal_rough", "f2"), ("emissive_metal", "f2"), ("position", "f4"), ("motion_depth", "f4"))
    SHADE = (("color", "f4"), ("fbeta", "f2"), ("emissive", "f2"))

    def __init__(self, ctx, size: tuple[int, int]):
        import moderngl

        self.size = size
        self.textures = {}
        for name, dtype in self.GBUFFER + self.SHADE:
            tex = ctx.texture(size, 4, dtype=dtype)
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.textures[name] = tex
        self.depth = ctx.depth_texture(size)
        self.gbuffer = ctx.framebuffer([self.textures[n] for n, _ in self.GBUFFER], self.depth)
        self.shade = ctx.framebuffer([self.textures[n] for n, _ in self.SHADE], self.depth)
        self.gbuffer_lean = ctx.framebuffer([self.textures[n] for n, _ in self.GBUFFER[:4]], self.depth)
        self.accumulate = ctx.framebuffer([self.textures["color"]], self.depth)

    def read(self, fbo_name: str, name: str, components: int) -> np.ndarray:
        """One glReadPixels of attachment ``name``: ``(H, W, components)`` float32, row 0 at the top."""
        fbo = getattr(self, fbo_name)
        names = [n for n, _ in (self.GBUFFER if fbo_name == "gbuffer" else self.SHADE)]
        raw = fbo.read(components=components, attachment=names.index(name), dtype="f4")
        w, h = self.size
        return np.frombuffer(raw, dtype=np.float32).reshape(h, w, components)[::-1]

    def release(self) -> None:
        for obj in [self.gbuffer, self.shade, self.gbuffer_lean, self.accumulate, self.depth, *self.textures.values()]:
            obj.release()
