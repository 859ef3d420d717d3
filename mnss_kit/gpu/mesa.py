"""Desktop harness: the runtime shader files, flattened, run through EGL (Mesa llvmpipe on a CPU).

Desktop OpenGL 4.3+ accepts ``#version 310 es`` compute shaders (GL_ARB_ES3_1_compatibility),
so the files that ship to the phone run unchanged.  :meth:`MesaPasses.run_pass` runs any pass
from its record (``passes.PASSES``), with the argument and result of
:class:`mnss_kit.gpu.reference.ReferencePasses`: numpy in, numpy out.  The shader of each pass is
the package's (flattened) unless one is given by pass name, e.g. the files of a bundle.
"""

from __future__ import annotations

import functools

from pathlib import Path

import numpy as np

from ..errors import UserError
from . import passes as P
from .glsl import flatten
from .passes import Call
from .weights import Conv3x3, layers_of

# sized format -> (components, moderngl dtype, GL enum for image bindings); moderngl's "f1" is UNORM
TEXTURE_FORMATS = {
    "rgba16f": (4, "f2", 0x881A),
    "rgba32f": (4, "f4", 0x8814),
    "r32f": (1, "f4", 0x822E),
    "rg32f": (2, "f4", 0x8230),
    "rgba8": (4, "f1", 0x8058),
}
NUMPY_DTYPES = {"f2": np.float16, "f4": np.float32, "f1": np.uint8}
MAX_GROUPS_X = 4096  # workgroups along x for the 1D word grid; the rest go along y


def _in_own_context(method):
    """Run a pass with this object's GL context current.

    Another context (the renderer's, another ``MesaPasses``) may have been made current, or
    released, since this one was created; GL calls would then reach the wrong context.
    """

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        self.ctx.__enter__()  # make current, and leave it current as a new context is
        self.ctx.gc()
        return method(self, *args, **kwargs)

    return wrapper


def create_context():
    """A headless OpenGL 4.3+ context through EGL; ``UserError`` if the system cannot provide one."""
    import moderngl

    try:
        return moderngl.create_context(standalone=True, backend="egl", require=430)
    except Exception as e:  # moderngl raises plain Exceptions for missing EGL or drivers
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise UserError(
            f"cannot create an OpenGL 4.3 context through EGL ({first}); install Mesa EGL (libegl1, libgl1-mesa-dri)"
        ) from None


class MesaPasses:
    """The runtime passes on the GPU of an OpenGL context (one per instance; reuse it).

    ``sources`` maps pass names to shader source: GLSL text, or the ``Path`` of a file (read
    when the pass first runs and named in errors).  With ``sources`` given, every pass that
    runs must be in it; without, each pass compiles the package's own flattened entry file.
    """

    def __init__(self, ctx=None, sources: dict[str, str | Path] | None = None):
        self.ctx = ctx if ctx is not None else create_context()
        # Dropped per-call textures and buffers are queued and released by the next pass, with this
        # context current: releasing them from __del__ ("auto") would delete whatever objects
        # share their names in the context that happens to be current then.
        self.ctx.gc_mode = "context_gc"
        self.sources = sources
        self._programs: dict[str, object] = {}

    # -- plumbing ------------------------------------------------------------------------------
    def program(self, name: str):
        """The compiled compute shader of pass ``name``; ``UserError`` naming the source if it does not compile."""
        if name not in self._programs:
            origin, text = self._source(name)
            try:
                self._programs[name] = self.compile(text)
            except Exception as e:  # moderngl raises plain Exceptions with the driver's compile log
                first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
                raise UserError(f"{origin}: does not compile on this GL driver ({first})") from None
        return self._programs[name]

    def _source(self, name: str) -> tuple[str, str]:
        """(where the shader of pass ``name`` comes from, its GLSL text)."""
        if self.sources is None:
            return P.PASSES[name].entry, flatten(P.PASSES[name].entry)
        if name not in self.sources:
            raise UserError(f"no shader source for GPU pass {name} (given: {', '.join(self.sources) or 'none'})")
        source = self.sources[name]
        if isinstance(source, Path):
            try:
                return str(source), source.read_text(encoding="utf-8", errors="replace")
            except OSError as e:
                raise UserError(f"{source}: cannot read the shader ({e.strerror})") from None
        return name, source

    def compile(self, source: str):
        """A compute shader from GLSL source (tests use it for helper functions)."""
        return self.ctx.compute_shader(source)

    def texture(self, data: np.ndarray, fmt: str):
        """A 2D texture of sized format ``fmt`` from ``(H, W, C)`` data, C <= the format's channels.

        Missing channels are filled with 0 (alpha with 1); values are converted on the host
        (numpy: float16 rounds to nearest-even).
        """
        components, dtype, _ = TEXTURE_FORMATS[fmt]
        data = np.asarray(data)
        h, w, c = data.shape
        full = np.zeros((h, w, components), dtype=np.float32)
        if components == 4:
            full[..., 3] = 1.0
        full[..., :c] = data
        raw = np.ascontiguousarray(full.astype(NUMPY_DTYPES[dtype])).tobytes()
        return self.ctx.texture((w, h), components, raw, dtype=dtype)

    def texture_array(self, data: np.ndarray):
        """An rgba16f 2D array texture from ``(h, w, C)``: channels ``4l .. 4l+3`` in layer ``l``, zero padded."""
        h, w, c = data.shape
        layers = layers_of(c)
        full = np.zeros((layers * 4, h, w), dtype=np.float16)
        full[:c] = np.moveaxis(np.asarray(data, np.float32), -1, 0)
        stacked = full.reshape(layers, 4, h, w).transpose(0, 2, 3, 1)
        return self.ctx.texture_array((w, h, layers), 4, np.ascontiguousarray(stacked).tobytes(), dtype="f2")

    def empty(self, size: tuple[int, int], fmt: str, layers: int = 0):
        """An output texture (``size`` = (width, height)); a 2D array of ``layers`` if > 0."""
        components, dtype, _ = TEXTURE_FORMATS[fmt]
        if layers:
            return self.ctx.texture_array((*size, layers), components, dtype=dtype)
        return self.ctx.texture(size, components, dtype=dtype)

    @staticmethod
    def read(texture, fmt: str, channels: int) -> np.ndarray:
        """The first ``channels`` channels of a 2D texture or array texture (layers of four channels
        side by side): ``(H, W, channels)`` float32, uint8 for rgba8."""
        components, dtype, _ = TEXTURE_FORMATS[fmt]
        data = np.frombuffer(texture.read(), dtype=NUMPY_DTYPES[dtype])
        if hasattr(texture, "layers"):
            w, h, layers = texture.size
            data = data.reshape(layers, h, w, components).transpose(1, 2, 0, 3).reshape(h, w, layers * components)
        else:
            w, h = texture.size
            data = data.reshape(h, w, components)
        data = data[..., :channels]
        return data.copy() if dtype == "f1" else data.astype(np.float32)

    def run(self, name: str, extent: tuple[int, ...], resources: dict, uniforms: dict) -> None:
        """Bind ``resources`` (binding name -> texture or buffer) as ``passes.PASSES[name]`` says,
        set ``uniforms``, dispatch enough workgroups to cover ``extent`` invocations (x, y, z) and
        wait for the writes."""
        spec = P.PASSES[name]
        prog = self.program(name)
        for binding in spec.bindings:
            obj = resources[binding.name]
            if binding.kind == "sampler":
                obj.use(location=binding.unit)
            elif binding.kind == "image":
                obj.bind_to_image(binding.unit, read=False, write=True, format=TEXTURE_FORMATS[binding.format][2])
            else:
                obj.bind_to_storage_buffer(binding.unit)
        for key, value in uniforms.items():
            if key in prog:  # the linker drops uniforms a pass does not read
                prog[key].value = value
        extent = (*extent, 1, 1)[:3]
        groups = [-(-n // size) for n, size in zip(extent, spec.local_size)]
        if spec.grid == "words":  # a 1D grid folded into 2D: the x count of a dispatch is limited
            groups = [min(groups[0], MAX_GROUPS_X), -(-groups[0] // MAX_GROUPS_X), 1]
        prog.run(*groups)
        self.ctx.memory_barrier()
        self.ctx.finish()

    def _placeholder(self):
        return self.texture(np.zeros((1, 1, 1), np.float32), "r32f")

    def _upload(self, binding, value):
        """The texture or buffer an input binding reads: ``value`` uploaded in the binding's format
        (a placeholder where a pass does not read it, None)."""
        if binding.kind == "buffer":
            data = value.packed() if isinstance(value, Conv3x3) else np.asarray(value, dtype=binding.dtype)
            return self.ctx.buffer(_words(data))
        if value is None:
            return self.texture_array(np.zeros((1, 1, 1), np.float32)) if binding.array else self._placeholder()
        return self.texture_array(value) if binding.array else self.texture(value, binding.format)

    @_in_own_context
    def run_pass(self, name: str, call: Call) -> dict:
        """Pass ``name`` on ``call``, from its record alone: each input binding uploaded, each written
        one allocated at the size ``outputs(call)`` gives (a written buffer zero, a read-and-written one
        with its old contents), ``call.uniforms`` set as they are, one dispatch over the pass's grid
        (the first written image's size, its layers on ``lr_layers``; the words of the first written
        buffer on ``words``).  Returns written binding name -> array, as the reference does."""
        spec = P.PASSES[name]
        shapes = spec.outputs(call)
        resources, written = {}, {}
        for b in spec.bindings:
            if b.kind == "image":
                h, w, channels = shapes[b.name]
                resources[b.name] = self.empty((w, h), b.format, layers_of(channels) if b.array else 0)
            elif b.kind == "buffer" and b.access == "write":
                resources[b.name] = self.ctx.buffer(bytes(_nbytes(shapes[b.name], b.dtype)))
            else:
                resources[b.name] = self._upload(b, call.weights[b.name] if b.name in call.weights else call.read.get(b.name))
            if b.writes:
                written[b.name] = resources[b.name]
        self.run(name, _extent(spec, shapes), resources, {k: _uniform_value(v) for k, v in call.uniforms.items()})
        out = {}
        for key, obj in written.items():
            b, shape = spec.binding(key), shapes[key]
            if b.kind == "image":
                out[key] = self.read(obj, b.format, shape[2])
            else:
                out[key] = np.frombuffer(obj.read(), dtype=b.dtype)[: int(np.prod(shape))].reshape(shape).copy()
        return out


def _extent(spec, shapes: dict) -> tuple[int, ...]:
    """Invocations of one dispatch of ``spec``: the words of its first written buffer on the
    ``words`` grid, else its first written image's (width, height), with its layers on ``lr_layers``."""
    if spec.grid == "words":
        b = next(b for b in spec.bindings if b.kind == "buffer" and b.writes)
        return (_nbytes(shapes[b.name], b.dtype) // 4,)
    h, w, channels = next(shapes[b.name] for b in spec.bindings if b.kind == "image")
    return (w, h, layers_of(channels)) if spec.grid == "lr_layers" else (w, h)


def _uniform_value(value):
    """A uniform value as moderngl sets it: Python numbers, tuples for vectors."""
    value = np.asarray(value).tolist()  # numpy scalars and arrays -> Python numbers and lists
    if isinstance(value, list):
        return tuple(value)
    return int(value) if isinstance(value, bool) else value


def _nbytes(shape, dtype: str) -> int:
    """Bytes of a buffer holding an array of ``shape`` and ``dtype``, in whole 32-bit words."""
    return _padded(int(np.prod(shape)) * np.dtype(dtype).itemsize)


def _padded(nbytes: int) -> int:
    """``nbytes`` rounded up to whole 32-bit words (at least one)."""
    return max(-(-nbytes // 4), 1) * 4


def _words(data) -> bytes:
    """An array as the bytes of a std430 buffer of 32-bit words (int8 NHWC: 4 bytes per word,
    little-endian), zero-padded to whole words."""
    raw = np.ascontiguousarray(data).tobytes()
    return raw + b"\0" * (_padded(len(raw)) - len(raw))
