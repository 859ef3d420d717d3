"""Desktop harness: the runtime shader files, flattened, run through EGL (Mesa llvmpipe on a CPU).

Desktop OpenGL 4.3+ accepts ``#version 310 es`` compute shaders (GL_ARB_ES3_1_compatibility),
so the files that ship to the phone run unchanged.  :class:`MesaPasses` has one method per pass,
with the arguments and results of :class:`mnss_kit.gpu.reference.ReferencePasses`: numpy in,
numpy out.  Bindings come from ``passes.PASSES``; the shader of each pass is the package's
(flattened) unless one is given by pass name, e.g. the files of a bundle.
"""

from __future__ import annotations

import functools

from pathlib import Path

import numpy as np

from ..errors import UserError
from ..ops.jitter import subpixel_index
from . import passes as P
from .glsl import flatten
from .reference import as_jitter
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


def _subpixel(jitter, scale: int) -> tuple[int, int]:
    """The ``ivec2`` uniform of the sampled sub-pixel, from ``ops.jitter.subpixel_index``."""
    dx, dy = subpixel_index(as_jitter(jitter), scale)
    return int(dx), int(dy)


def _vec2(jitter) -> tuple[float, float]:
    jx, jy = as_jitter(jitter)
    return float(jx), float(jy)


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

    # -- passes (signatures of reference.ReferencePasses) ---------------------------------------
    @_in_own_context
    def warp(self, history, prev_depth, motion, prev_jitter, jitter, scale: int):
        hh, hw = history.shape[:2]
        h, w = motion.shape[:2]
        warped, warped_depth = self.empty((hw, hh), "rgba16f"), self.empty((w, h), "r32f")
        res = {
            "history": self.texture(history, "rgba16f"),
            "prev_depth": self.texture(prev_depth, "r32f"),
            "motion": self.texture(motion, "rg32f"),
            "warped": warped,
            "warped_depth": warped_depth,
        }
        uni = {"u_scale": scale, "u_subpixel": _subpixel(jitter, scale), "u_prev_jitter": _vec2(prev_jitter),
               "u_prev_subpixel": _subpixel(prev_jitter, scale)}
        self.run("warp_pass", (hw, hh), res, uni)
        return self.read(warped, "rgba16f", 3), self.read(warped_depth, "r32f", 1)

    @_in_own_context
    def inpaint_weights(self, color, depth, warped, warped_depth, jitter, scale: int, conv: Conv3x3, activation: str):
        h, w = color.shape[:2]
        out = self.empty((w, h), "r32f")
        res = {
            "color": self.texture(color, "rgba16f"),
            "depth": self.texture(depth, "r32f"),
            "warped": self.texture(warped, "rgba16f"),
            "warped_depth": self.texture(warped_depth, "r32f"),
            "weights": self.ctx.buffer(conv.packed().tobytes()),
            "lr_weight": out,
        }
        uni = {"u_scale": scale, "u_subpixel": _subpixel(jitter, scale), "u_activation": P.ACTIVATION_CODES[activation]}
        self.run("inpaint_weights_pass", (w, h), res, uni)
        return self.read(out, "r32f", 1)

    @_in_own_context
    def inpaint_blend(self, color, warped, lr_weight, jitter, scale: int, weight_upsample: str, reset: bool):
        h, w = color.shape[:2]
        out = self.empty((w * scale, h * scale), "rgba16f")
        res = {
            "color": self.texture(color, "rgba16f"),
            "warped": self._placeholder() if reset else self.texture(warped, "rgba16f"),
            "lr_weight": self._placeholder() if reset else self.texture(lr_weight, "r32f"),
            "rectified": out,
        }
        uni = {"u_scale": scale, "u_jitter": _vec2(jitter), "u_subpixel": _subpixel(jitter, scale),
               "u_weight_upsample": P.WEIGHT_UPSAMPLE_CODES[weight_upsample], "u_reset": int(bool(reset))}
        self.run("inpaint_blend_pass", (w * scale, h * scale), res, uni)
        return self.read(out, "rgba16f", 3)

    @_in_own_context
    def avgpool(self, rectified, color, jitter, scale: int, history_at_samples: bool):
        h, w = color.shape[:2]
        channels = P.avgpool_channels(history_at_samples)
        out = self.empty((w, h), "rgba16f", layers=layers_of(channels))
        res = {"rectified": self.texture(rectified, "rgba16f"), "color": self.texture(color, "rgba16f"), "aa_input": out}
        uni = {"u_scale": scale, "u_subpixel": _subpixel(jitter, scale), "u_history_at_samples": int(history_at_samples)}
        self.run("avgpool_pass", (w, h), res, uni)
        return self.read(out, "rgba16f", channels)

    @_in_own_context
    def conv3x3(self, x, conv: Conv3x3, epilogue: str, residual=None):
        h, w, cin = x.shape
        if cin != conv.in_channels:
            raise ValueError(f"input has {cin} channels, the conv expects {conv.in_channels}")
        out_layers = layers_of(conv.out_channels)
        out = self.empty((w, h), "rgba16f", layers=out_layers)
        res = {
            "x": self.texture_array(x),
            "residual": self._placeholder() if residual is None else self.texture(residual, "rgba16f"),
            "weights": self.ctx.buffer(conv.packed().tobytes()),
            "y": out,
        }
        uni = {"u_in_layers": layers_of(cin), "u_out_layers": out_layers, "u_epilogue": P.EPILOGUE_CODES[epilogue]}
        self.run("conv3x3_pass", (w, h, out_layers), res, uni)
        return self.read(out, "rgba16f", conv.out_channels)

    @_in_own_context
    def insert_pack(self, rectified, aa, jitter, scale: int, q_scale: float, q_zero_point: int, profile: str):
        hh, hw = rectified.shape[:2]
        nbytes = hh * hw * 3
        words = -(-nbytes // 4)
        out = self.ctx.buffer(reserve=words * 4)
        uni = {"u_scale": scale, "u_subpixel": _subpixel(jitter, scale), "u_word_count": words,
               **P.quantize_uniforms(q_scale, q_zero_point, profile)}
        res = {"rectified": self.texture(rectified, "rgba16f"), "aa": self.texture_array(aa), "npu_input": out}
        self.run("insert_pack_pass", (words,), res, uni)
        return np.frombuffer(out.read(), dtype=np.int8)[:nbytes].reshape(1, hh, hw, 3).copy()

    @_in_own_context
    def unpack_history(self, npu_output, q_scale: float, q_zero_point: int):
        _, hh, hw, _ = npu_output.shape
        history, display = self.empty((hw, hh), "rgba16f"), self.empty((hw, hh), "rgba8")
        res = {"npu_output": self.ctx.buffer(_packed_int8(npu_output)), "history": history, "display": display}
        uni = {"u_q_scale": float(np.float32(q_scale)), "u_q_zero_point": int(q_zero_point)}
        self.run("unpack_history_pass", (hw, hh), res, uni)
        return self.read(history, "rgba16f", 3), self.read(display, "rgba8", 3)

    @_in_own_context
    def sharpen(self, image, beta: float):
        hh, hw = image.shape[:2]
        display = self.empty((hw, hh), "rgba8")
        res = {"image": self.texture(image, "rgba16f"), "display": display}
        self.run("sharpen_pass", (hw, hh), res, {"u_beta": float(np.float32(beta))})
        return self.read(display, "rgba8", 3)

    # -- FuseSR --------------------------------------------------------------------------------
    @_in_own_context
    def demodulate(self, color, fbeta, emissive, demodulate: bool):
        h, w = color.shape[:2]
        out = self.empty((w, h), "rgba16f", layers=1)
        res = {"color": self.texture(color, "rgba16f"), "l": out,
               "fbeta": self.texture(fbeta, "rgba16f") if demodulate else self._placeholder(),
               "emissive": self.texture(emissive, "rgba16f") if demodulate else self._placeholder()}
        self.run("demodulate_pass", (w, h), res, {"u_demodulate": int(demodulate)})
        return self.read(out, "rgba16f", 3)

    @_in_own_context
    def gbuffer_pack(self, l, features, warped, gbuffers: dict, scale: int, history: bool, reset: bool, q_scale: float,
                     q_zero_point: int, profile: str):
        h, w = l.shape[:2]
        channels = 3 + features.shape[-1] + (3 * scale * scale if history else 0)
        channels += sum(g.shape[-1] for g in gbuffers.values()) * scale * scale
        nbytes = h * w * channels
        words = -(-nbytes // 4)
        out = self.ctx.buffer(reserve=words * 4)
        res = {"l": self.texture_array(l), "features": self.texture_array(features), "npu_input": out,
               "warped": self.texture(warped, "rgba16f") if history and not reset else self._placeholder()}
        for name in P.PACKED_GBUFFERS:
            fmt = P.PASSES["gbuffer_pack_pass"].binding(name).format
            res[name] = self.texture(gbuffers[name], fmt) if name in gbuffers else self._placeholder()
        mask = sum(1 << i for i, name in enumerate(P.PACKED_GBUFFERS) if name in gbuffers)
        uni = {"u_scale": scale, "u_features": features.shape[-1], "u_history": int(history),
               "u_reset": int(bool(reset)), "u_gbuffers": mask, "u_word_count": words,
               **P.quantize_uniforms(q_scale, q_zero_point, profile)}
        self.run("gbuffer_pack_pass", (words,), res, uni)
        return np.frombuffer(out.read(), dtype=np.int8)[:nbytes].reshape(1, h, w, channels).copy()

    @_in_own_context
    def remodulate(self, npu_output, l, fbeta, emissive, scale: int, q_scale: float, q_zero_point: int, demodulate: bool):
        _, hh, hw, _ = npu_output.shape
        history, display = self.empty((hw, hh), "rgba16f"), self.empty((hw, hh), "rgba8")
        res = {"npu_output": self.ctx.buffer(_packed_int8(npu_output)), "history": history, "display": display, "l": self.texture_array(l),
               "fbeta": self.texture(fbeta, "rgba16f") if demodulate else self._placeholder(),
               "emissive": self.texture(emissive, "rgba16f") if demodulate else self._placeholder()}
        uni = {"u_scale": scale, "u_q_scale": float(np.float32(q_scale)), "u_q_zero_point": int(q_zero_point),
               "u_demodulate": int(demodulate)}
        self.run("remodulate_pass", (hw, hh), res, uni)
        return self.read(history, "rgba16f", 3), self.read(display, "rgba8", 3)

    @_in_own_context
    def taau_reproject(self, history, motion, scale: int, reset: bool, blur_penalty: float):
        hh, hw = history.shape[:2]
        out = self.empty((hw, hh), "rgba16f")
        res = {"history": self.texture(history, "rgba16f"), "motion": self.texture(motion, "rg32f"), "reprojected": out}
        uni = {"u_scale": scale, "u_reset": int(bool(reset)), "u_blur_penalty": float(blur_penalty)}
        self.run("taau_reproject_pass", (hw, hh), res, uni)
        return self.read(out, "rgba16f", 4)

    @_in_own_context
    def taau_pack(self, color, reprojected, scale: int, max_weight: float, q_scale: float, q_zero_point: int, profile: str):
        h, w = color.shape[:2]
        channels = 3 + 5 * scale * scale
        nbytes = h * w * channels
        words = -(-nbytes // 4)
        out = self.ctx.buffer(reserve=words * 4)
        res = {"color": self.texture(color, "rgba16f"), "reprojected": self.texture(reprojected, "rgba16f"), "npu_input": out}
        uni = {"u_scale": scale, "u_max_weight": float(max_weight), "u_word_count": words,
               **P.quantize_uniforms(q_scale, q_zero_point, profile)}
        self.run("taau_pack_pass", (words,), res, uni)
        return np.frombuffer(out.read(), dtype=np.int8)[:nbytes].reshape(1, h, w, channels).copy()

    @_in_own_context
    def taau_accumulate(self, npu_output, color, reprojected, motion, jitter, scale: int, q_scale: float, q_zero_point: int,
                        correction_bound: float, box_bound: float, history_gain_min: float, still_motion_px: float,
                        sample_sigma: float, prior_weight: float, max_weight: float):
        _, hh, hw, _ = npu_output.shape
        history, display = self.empty((hw, hh), "rgba16f"), self.empty((hw, hh), "rgba8")
        res = {"npu_output": self.ctx.buffer(_packed_int8(npu_output)), "color": self.texture(color, "rgba16f"),
               "reprojected": self.texture(reprojected, "rgba16f"), "motion": self.texture(motion, "rg32f"),
               "history": history, "display": display}
        uni = {"u_scale": scale, "u_steer_channels": int(npu_output.shape[-1]), "u_jitter": _vec2(jitter), "u_q_scale": float(np.float32(q_scale)),
               "u_q_zero_point": int(q_zero_point), "u_correction_bound": float(correction_bound), "u_box_bound": float(box_bound),
               "u_history_gain_min": float(history_gain_min), "u_still_motion_px": float(still_motion_px),
               "u_sample_sigma": float(sample_sigma), "u_prior_weight": float(prior_weight), "u_max_weight": float(max_weight)}
        self.run("taau_accumulate_pass", (hw, hh), res, uni)
        return self.read(history, "rgba16f", 4), self.read(display, "rgba8", 3)

    @_in_own_context
    def taau_filter(self, npu_output, history, motion, scale: int, q_scale: float, q_zero_point: int,
                    correction_bound: float, filter_bound: float, filter_falloff: float):
        _, hh, hw, _ = npu_output.shape
        display = self.empty((hw, hh), "rgba8")
        res = {"npu_output": self.ctx.buffer(_packed_int8(npu_output)), "history": self.texture(history, "rgba16f"),
               "motion": self.texture(motion, "rg32f"), "display": display}
        uni = {"u_scale": scale, "u_q_scale": float(np.float32(q_scale)), "u_q_zero_point": int(q_zero_point),
               "u_correction_bound": float(correction_bound), "u_filter_bound": float(filter_bound),
               "u_filter_falloff": float(filter_falloff)}
        self.run("taau_filter_pass", (hw, hh), res, uni)
        return self.read(display, "rgba8", 3)

    # -- ntaau_lr ------------------------------------------------------------------------------
    @_in_own_context
    def taau_lr_evidence(self, depth, prev_depth, motion, reset: bool, trust_depth: float, trust_spread_px: float):
        h, w = depth.shape[:2]
        out = self.empty((w, h), "rgba32f")
        res = {"depth": self.texture(depth, "r32f"), "prev_depth": self._placeholder() if reset else self.texture(prev_depth, "r32f"),
               "motion": self.texture(motion, "rg32f"), "evidence": out}
        uni = {"u_reset": int(bool(reset)), "u_trust_depth": float(trust_depth), "u_trust_spread_px": float(trust_spread_px)}
        self.run("taau_lr_evidence_pass", (w, h), res, uni)
        return self.read(out, "rgba32f", 4)

    @_in_own_context
    def taau_lr_reproject(self, history, motion, reset: bool, blur_penalty: float):
        hh, hw = history.shape[:2]
        out = self.empty((hw, hh), "rgba16f")
        res = {"history": self.texture(history, "rgba16f"), "motion": self.texture(motion, "rg32f"), "reprojected": out}
        self.run("taau_lr_reproject_pass", (hw, hh), res, {"u_reset": int(bool(reset)), "u_blur_penalty": float(blur_penalty)})
        return self.read(out, "rgba16f", 4)

    @_in_own_context
    def taau_lr_pack(self, color, reprojected, evidence, scale: int, reset: bool, max_weight: float, q_scale: float,
                     q_zero_point: int, profile: str, scale_input: float = 0.0):
        h, w = color.shape[:2]
        ph, pw = h + h % 2, w + w % 2
        channels = 9 if scale_input else 8
        nbytes = ph * pw * channels
        words = -(-nbytes // 4)
        out = self.ctx.buffer(reserve=words * 4)
        res = {"color": self.texture(color, "rgba16f"), "evidence": self.texture(evidence, "rgba32f"), "npu_input": out,
               "reprojected": self._placeholder() if reset else self.texture(reprojected, "rgba16f")}
        uni = {"u_scale": scale, "u_reset": int(bool(reset)), "u_max_weight": float(max_weight), "u_word_count": words,
               "u_scale_input": float(np.float32(scale_input)), **P.quantize_uniforms(q_scale, q_zero_point, profile)}
        self.run("taau_lr_pack_pass", (words,), res, uni)
        return np.frombuffer(out.read(), dtype=np.int8)[:nbytes].reshape(1, ph, pw, channels).copy()

    @_in_own_context
    def taau_lr_accumulate(self, npu_output, color, reprojected, evidence, jitter, scale: int, q_scale: float, q_zero_point: int,
                           box_bound: float, sample_sigma: float, prior_weight: float, max_weight: float):
        hh, hw = np.asarray(reprojected).shape[:2]  # the HR size at any scale (u_scale 0: a fractional one)
        history, display = self.empty((hw, hh), "rgba16f"), self.empty((hw, hh), "rgba8")
        res = {"npu_output": self.ctx.buffer(_packed_int8(npu_output)), "color": self.texture(color, "rgba16f"),
               "reprojected": self.texture(reprojected, "rgba16f"), "evidence": self.texture(evidence, "rgba32f"),
               "history": history, "display": display}
        uni = {"u_scale": scale, "u_jitter": _vec2(jitter), "u_q_scale": float(np.float32(q_scale)),
               "u_q_zero_point": int(q_zero_point), "u_box_bound": float(box_bound), "u_sample_sigma": float(sample_sigma),
               "u_prior_weight": float(prior_weight), "u_max_weight": float(max_weight)}
        self.run("taau_lr_accumulate_pass", (hw, hh), res, uni)
        return self.read(history, "rgba16f", 4), self.read(display, "rgba8", 3)

    @_in_own_context
    def taau_lr_filter(self, npu_output, history, scale: int, q_scale: float, q_zero_point: int, filter_bound: float,
                       lr_size=None):
        hh, hw = history.shape[:2]
        display = self.empty((hw, hh), "rgba8")
        res = {"npu_output": self.ctx.buffer(_packed_int8(npu_output)), "history": self.texture(history, "rgba16f"),
               "display": display}
        lr = tuple(int(v) for v in lr_size) if lr_size is not None else (hw // scale, hh // scale)
        uni = {"u_scale": scale, "u_lr_size": lr, "u_q_scale": float(np.float32(q_scale)), "u_q_zero_point": int(q_zero_point),
               "u_filter_bound": float(filter_bound)}
        self.run("taau_lr_filter_pass", (hw, hh), res, uni)
        return self.read(display, "rgba8", 3)

    # -- fsr2 ----------------------------------------------------------------------------------
    @_in_own_context
    def fsr2_reconstruct(self, depth, motion, params):
        h, w = depth.shape[:2]
        dilated = self.empty((w, h), "rgba32f")
        previous_depth = self.ctx.buffer(bytes(4 * h * w))  # cleared, as fsr2_accumulate_pass leaves it
        res = {"depth": self.texture(depth, "r32f"), "motion": self.texture(motion, "rg32f"), "dilated": dilated,
               "previous_depth": previous_depth}
        self.run("fsr2_reconstruct_pass", (w, h), res, P.fsr2_uniforms(params))
        return self.read(dilated, "rgba32f", 4), np.frombuffer(previous_depth.read(), np.uint32).copy()

    @_in_own_context
    def fsr2_depth_clip(self, dilated, color, previous_depth, params):
        h, w = dilated.shape[:2]
        analysis = self.empty((w, h), "rgba32f")
        res = {"dilated": self.texture(dilated, "rgba32f"), "color": self.texture(color, "rgba16f"),
               "previous_depth": self.ctx.buffer(np.ascontiguousarray(previous_depth, np.uint32).tobytes()), "analysis": analysis}
        self.run("fsr2_depth_clip_pass", (w, h), res, P.fsr2_uniforms(params))
        return self.read(analysis, "rgba32f", 4)

    @_in_own_context
    def fsr2_accumulate(self, color, dilated, analysis, history, locks, reactive, previous_depth, jitter, scale: int,
                        reset: bool, params):
        hh, hw = history.shape[:2]
        next_history, next_locks = self.empty((hw, hh), "rgba16f"), self.empty((hw, hh), "rgba16f")
        buffer = self.ctx.buffer(np.ascontiguousarray(previous_depth, np.uint32).tobytes())
        res = {"color": self.texture(color, "rgba16f"), "dilated": self.texture(dilated, "rgba32f"),
               "analysis": self.texture(analysis, "rgba32f"), "history": self.texture(history, "rgba16f"),
               "locks": self.texture(locks, "rgba16f"),
               "reactive": self._placeholder() if reactive is None else self.texture(reactive, "r32f"),
               "next_history": next_history, "next_locks": next_locks, "previous_depth": buffer}
        uni = {**P.fsr2_uniforms(params), "u_scale": scale, "u_jitter": _vec2(jitter), "u_reset": int(bool(reset)),
               "u_use_reactive": int(reactive is not None)}
        self.run("fsr2_accumulate_pass", (hw, hh), res, uni)
        return (self.read(next_history, "rgba16f", 4), self.read(next_locks, "rgba16f", 2),
                np.frombuffer(buffer.read(), np.uint32).copy())

    @_in_own_context
    def fsr2_rcas(self, image, sharpness: float):
        hh, hw = image.shape[:2]
        out = self.empty((hw, hh), "rgba16f")
        self.run("fsr2_rcas_pass", (hw, hh), {"image": self.texture(image, "rgba16f"), "output_image": out},
                 {"u_sharpness": float(np.float32(sharpness))})
        return self.read(out, "rgba16f", 3)


def _packed_int8(npu_output) -> bytes:
    """An int8 NHWC NPU output as the bytes of a std430 uint[] buffer (zero-padded to whole words)."""
    raw = np.ascontiguousarray(npu_output, dtype=np.int8).tobytes()
    return raw + b"\0" * (-len(raw) % 4)
