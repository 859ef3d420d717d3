"""Deferred G-buffer renderer: shadow map, G-buffer, lighting, particles; LR jittered + HR reference.

Per frame: one shadow map; the LR frame (jittered projection, texture mip bias
``log2(1 / scale)``, the jitter in LR pixels at any scale); the HR G-buffers (pixel centres, one sample); the HR
reference as the box-filtered mean of ``hr_samples`` jittered HR passes on a
``k x k`` stratified grid per pixel, accumulated in float32 in a fixed order.
Optionally the references an engine would hold as its native frame:
``reference_4x`` (4 passes on the rotated-grid 4x MSAA positions) and
``reference_taa`` (``mnss_kit.ops.native_taa`` over one Halton-jittered HR pass
per frame, its history carried from frame to frame).

Shading identity (exact up to the stored precision, per RGB channel; see
``shaders/render/lighting.frag`` and ``mnss_kit.ops.brdf``)::

    colour = emissive + F_beta * L,     F_beta = albedo (1 - metallic) + F0 A + B

where ``L`` is the demodulated radiance: the F_beta-weighted mean of the
diffuse light (sky irradiance + shadowed sun / pi) and the specular light
(pre-filtered sky + sun GGX lobe, divided by the split-sum term).  The
``emissive`` buffer holds material emission, the sky radiance (where
F_beta = 0) and the additive particles, so ``L = (colour - emissive) / F_beta``
is well defined wherever F_beta > 0.  This holds for LR colour; the HR
reference is a 16-sample mean and matches the 1-sample HR F_beta only where
the pixel is not an edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..ops import native_taa
from ..ops import scale as scales
from ..ops.brdf import brdf_lut
from . import gpu
from .camera import jittered, perspective
from .scene import Scene

SHADOW_SIZE = 1024
MAX_PARTICLES = 8192


@dataclass(frozen=True)
class FrameSpec:
    time: float
    prev_time: float
    jitter: tuple[float, float]  # LR pixels, +y down
    index: int = 0  # frame of the sequence: the native TAA's jitter phase
    reset: bool = False  # camera cut: the native TAA drops its history


# the standard 4x MSAA sample positions (Direct3D), a rotated grid, in pixels (+y down)
ROTATED_GRID_4X = ((-0.125, -0.375), (0.375, -0.125), (-0.375, 0.125), (0.125, 0.375))


@dataclass
class CameraMatrices:
    view: np.ndarray
    proj: np.ndarray  # unjittered
    position: np.ndarray


class Renderer:
    """Uploads a scene once and renders frames of it at LR and HR."""

    def __init__(self, scene: Scene, lr_size: tuple[int, int], scale: int | float, hr_samples: int = 16,
                 extra_references: tuple[str, ...] = (), hr_size: tuple[int, int] | None = None):
        """``hr_size`` defaults to ``lr_size * scale`` (an integer scale); at a fractional scale give it
        (``ops.scale``: ``lr = round_half_up(hr / s)``).  Both cameras see the HR aspect's view."""
        import moderngl

        self.scene = scene
        self.extra_references = tuple(extra_references)
        self.taa_history = None  # the native TAA's previous output: frames must come in order
        self.lr_size = tuple(lr_size)
        self.hr_size = tuple(hr_size) if hr_size is not None else scales.hr_size_for(lr_size, scale)
        mismatch = scales.size_mismatch(self.lr_size, self.hr_size, scale)
        if mismatch:
            raise ValueError(mismatch)
        self.scale = scale
        self.grid = int(round(math.sqrt(hr_samples)))
        ctx = self.ctx = gpu.context()
        self.programs = {
            "gbuffer": gpu.program(ctx, "gbuffer.vert", "gbuffer.frag"),
            "shadow": gpu.program(ctx, "shadow.vert", "shadow.frag"),
            "sky": gpu.program(ctx, "fullscreen.vert", "sky.frag"),
            "lighting": gpu.program(ctx, "fullscreen.vert", "lighting.frag"),
            "lighting_ref": gpu.program(ctx, "fullscreen.vert", "lighting.frag", ("COLOUR_ONLY",)),
            "particles": gpu.program(ctx, "particles.vert", "particles.frag"),
        }
        self._resources = []
        self._upload_meshes()
        self.lut = self._keep(gpu.float_texture(ctx, brdf_lut()))
        self.shadow_map = self._keep(ctx.depth_texture((SHADOW_SIZE, SHADOW_SIZE)))
        self.shadow_map.compare_func = "<="
        self.shadow_map.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.shadow_fbo = self._keep(ctx.framebuffer(depth_attachment=self.shadow_map))
        self.lr = gpu.Target(ctx, self.lr_size)
        self.hr = gpu.Target(ctx, self.hr_size)
        self.empty_vaos = {n: self._keep(ctx.vertex_array(self.programs[n], [])) for n in ("sky", "lighting", "lighting_ref")}
        corners = np.array([(-1, -1), (1, -1), (-1, 1), (1, 1)], np.float32)
        self.particle_corners = self._keep(ctx.buffer(corners.tobytes()))
        self.particle_data = self._keep(ctx.buffer(reserve=MAX_PARTICLES * 28))
        self.particle_vao = self._keep(ctx.vertex_array(self.programs["particles"], [
            (self.particle_corners, "2f", "in_corner"),
            (self.particle_data, "4f 3f/i", "in_center_size", "in_color"),
        ]))

    def _keep(self, obj):
        self._resources.append(obj)
        return obj

    def _upload_meshes(self) -> None:
        ctx = self.ctx
        textures = {}
        self.draws = []
        for mesh in self.scene.meshes:
            data = np.concatenate([mesh.positions, mesh.normals, mesh.uvs], axis=1).astype(np.float32)
            vbo = self._keep(ctx.buffer(data.tobytes()))
            ibo = self._keep(ctx.buffer(mesh.indices.astype(np.uint32).tobytes()))
            mat = mesh.material
            key = id(mat.base_color_texture)
            if key not in textures:
                textures[key] = self._keep(gpu.colour_texture(ctx, mat.base_color_texture))
            g = self._keep(ctx.vertex_array(self.programs["gbuffer"], [(vbo, "3f 3f 2f", "in_position", "in_normal", "in_uv")], ibo, index_element_size=4))
            s = self._keep(ctx.vertex_array(self.programs["shadow"], [(vbo, "3f 12x 2f", "in_position", "in_uv")], ibo, index_element_size=4))
            self.draws.append((g, s, textures[key], mat))

    # -- camera and light -------------------------------------------------------------

    def camera(self, t: float) -> CameraMatrices:
        s = self.scene.camera.state(t)
        aspect = self.hr_size[0] / self.hr_size[1]  # the display's view (the LR one to the last bit at an integer scale)
        return CameraMatrices(s.view(), perspective(s.fov, aspect, self.scene.near, self.scene.far), s.position)

    def light_matrix(self, t: float, cam: CameraMatrices) -> tuple[np.ndarray, float]:
        """World -> light clip for an orthographic box that follows the view, snapped to texels."""
        direction, _ = self.scene.sun.at(t)
        r = self.scene.shadow_radius
        forward = -cam.view[2, :3]
        centre = cam.position + forward * (0.6 * r)
        up = np.array([0.0, 1.0, 0.0]) if abs(direction[1]) < 0.99 else np.array([1.0, 0.0, 0.0])
        zaxis = direction
        xaxis = np.cross(up, zaxis)
        xaxis /= np.linalg.norm(xaxis)
        yaxis = np.cross(zaxis, xaxis)
        rot = np.stack([xaxis, yaxis, zaxis])  # rows: light-space axes, z towards the sun
        texel = 2.0 * r / SHADOW_SIZE
        c = rot @ centre
        c[:2] = np.floor(c[:2] / texel) * texel  # no shimmer when the camera moves
        c[2] += 2.0 * r  # the light "eye" sits 2r towards the sun from the centre
        view = np.eye(4)
        view[:3, :3] = rot
        view[:3, 3] = -c
        depth = 4.0 * r
        ortho = np.diag([1.0 / r, 1.0 / r, -2.0 / depth, 1.0])
        ortho[2, 3] = -1.0
        return ortho @ view, texel

    # -- passes -------------------------------------------------------------------------

    def _model_matrices(self, t: float) -> list[np.ndarray]:
        return [inst.at(t) for inst in self.scene.instances]

    def _shadow_pass(self, light_vp: np.ndarray, models: list[np.ndarray]) -> None:
        import moderngl

        ctx, prog = self.ctx, self.programs["shadow"]
        self.shadow_fbo.use()
        self.shadow_fbo.clear(depth=1.0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        gpu.set_uniform(prog, "light_view_proj", light_vp)
        for inst, model in zip(self.scene.instances, models):
            _, vao, tex, mat = self.draws[inst.mesh]
            gpu.set_uniform(prog, "model", model)
            gpu.set_uniform(prog, "alpha_test", int(mat.alpha_mode == "mask"))
            gpu.set_uniform(prog, "alpha_cutoff", mat.alpha_cutoff)
            tex.use(0)
            gpu.set_uniform(prog, "base_texture", 0)
            vao.render()

    def _gbuffer_pass(self, target: gpu.Target, vp_jit, vp_cur, vp_prev, models, prev_models, mip_bias: float, sky_mats,
                      lean: bool = False) -> None:
        import moderngl

        ctx, prog = self.ctx, self.programs["gbuffer"]
        fbo = target.gbuffer_lean if lean else target.gbuffer
        fbo.use()
        fbo.depth_mask = True
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.BLEND)
        ctx.depth_func = "<"
        for name, value in (("view_proj", vp_jit), ("cur_view_proj", vp_cur), ("prev_view_proj", vp_prev)):
            gpu.set_uniform(prog, name, value)
        gpu.set_uniform(prog, "mip_bias", mip_bias)
        gpu.set_uniform(prog, "target_size", target.size)
        gpu.set_uniform(prog, "base_texture", 0)
        for inst, model, prev in zip(self.scene.instances, models, prev_models):
            vao, _, tex, mat = self.draws[inst.mesh]
            if mat.alpha_mode == "blend":
                continue  # blended surfaces have no G-buffer entry; effects are drawn as particles
            if mat.double_sided:
                ctx.disable(moderngl.CULL_FACE)
            else:
                ctx.enable(moderngl.CULL_FACE)
            gpu.set_uniform(prog, "model", model)
            gpu.set_uniform(prog, "prev_model", prev)
            gpu.set_uniform(prog, "normal_matrix", np.linalg.inv(model[:3, :3]).T)
            gpu.set_uniform(prog, "base_color", mat.base_color)
            gpu.set_uniform(prog, "roughness", mat.roughness)
            gpu.set_uniform(prog, "metallic", mat.metallic)
            gpu.set_uniform(prog, "emissive", mat.emissive)
            gpu.set_uniform(prog, "alpha_test", int(mat.alpha_mode == "mask"))
            gpu.set_uniform(prog, "alpha_cutoff", mat.alpha_cutoff)
            tex.use(0)
            vao.render()
        # sky where nothing was drawn: far plane, depth-tested, no depth write
        ctx.disable(moderngl.CULL_FACE)
        ctx.depth_func = "<="
        fbo.depth_mask = False
        sky = self.programs["sky"]
        for name, value in zip(("inv_view_proj_rot", "cur_view_proj_rot", "prev_view_proj_rot"), sky_mats):
            gpu.set_uniform(sky, name, value)
        gpu.set_uniform(sky, "target_size", target.size)
        self.empty_vaos["sky"].render(moderngl.TRIANGLES, vertices=3)
        fbo.depth_mask = True
        ctx.depth_func = "<"

    def _lighting_pass(self, target: gpu.Target, accumulate: bool) -> None:
        """Additive: with ``accumulate`` (reference supersamples) colour only, added to what is there."""
        import moderngl

        name = "lighting_ref" if accumulate else "lighting"
        ctx, prog = self.ctx, self.programs[name]
        fbo = target.accumulate if accumulate else target.shade
        fbo.use()
        if not accumulate:
            fbo.clear(0.0, 0.0, 0.0, 0.0)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        for unit, attachment in enumerate(("albedo", "normal_rough", "emissive_metal", "position")):
            target.textures[attachment].use(unit)
            gpu.set_uniform(prog, f"g_{attachment}", unit)
        self.lut.use(4)
        gpu.set_uniform(prog, "brdf_lut", 4)
        self.shadow_map.use(5)
        gpu.set_uniform(prog, "shadow_map", 5)
        self.empty_vaos[name].render(moderngl.TRIANGLES, vertices=3)

    def _particle_pass(self, target: gpu.Target, vp_jit: np.ndarray, view: np.ndarray, particles, accumulate: bool) -> None:
        import moderngl

        if particles is None or len(particles[0]) == 0:
            return
        ctx, prog = self.ctx, self.programs["particles"]
        fbo = target.accumulate if accumulate else target.shade
        fbo.use()
        fbo.depth_mask = False
        ctx.enable(moderngl.DEPTH_TEST | moderngl.BLEND)
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        gpu.set_uniform(prog, "view_proj", vp_jit)
        gpu.set_uniform(prog, "camera_right", view[0, :3])
        gpu.set_uniform(prog, "camera_up", view[1, :3])
        self.particle_vao.render(moderngl.TRIANGLE_STRIP, vertices=4, instances=len(particles[0]))
        fbo.depth_mask = True

    def _upload_particles(self, t: float):
        if self.scene.particles is None:
            return None
        centres, colours = self.scene.particles(t)
        centres, colours = centres[:MAX_PARTICLES], colours[:MAX_PARTICLES]
        data = np.concatenate([centres, colours], axis=1).astype(np.float32)
        if len(data):
            self.particle_data.write(data.tobytes())
        return centres, colours

    # -- frame --------------------------------------------------------------------------

    def _set_light_uniforms(self, t: float, cam: CameraMatrices, light_vp: np.ndarray, texel: float) -> None:
        direction, colour = self.scene.sun.at(t)
        sky = self.scene.sky
        for name in ("sky", "lighting", "lighting_ref"):
            prog = self.programs[name]
            gpu.set_uniform(prog, "sky_zenith", sky.zenith)
            gpu.set_uniform(prog, "sky_horizon", sky.horizon)
            gpu.set_uniform(prog, "sky_ground", sky.ground)
            gpu.set_uniform(prog, "sun_direction", direction)
            gpu.set_uniform(prog, "sun_color", colour)
        to_texture = np.array([[0.5, 0, 0, 0.5], [0, 0.5, 0, 0.5], [0, 0, 0.5, 0.5], [0, 0, 0, 1.0]])
        for name in ("lighting", "lighting_ref"):
            prog = self.programs[name]
            gpu.set_uniform(prog, "shadow_matrix", to_texture @ light_vp)
            gpu.set_uniform(prog, "shadow_texel", texel)
            gpu.set_uniform(prog, "camera_position", cam.position)

    def _draw(self, target: gpu.Target, frame_state: dict, jitter, mip_bias: float, accumulate: bool) -> None:
        """G-buffer + lighting + particles into ``target`` with ``jitter`` in pixels of ``target``.

        With ``accumulate`` only colour is produced and added to the colour target.
        """
        cam, prev = frame_state["cam"], frame_state["prev"]
        proj_j = jittered(cam.proj, jitter, target.size)
        rot, prev_rot = _rotation_only(cam.view), _rotation_only(prev.view)
        sky_mats = (np.linalg.inv(proj_j @ rot), cam.proj @ rot, prev.proj @ prev_rot)
        vp_j = proj_j @ cam.view
        self._gbuffer_pass(target, vp_j, cam.proj @ cam.view, prev.proj @ prev.view,
                           frame_state["models"], frame_state["prev_models"], mip_bias, sky_mats, lean=accumulate)
        self._lighting_pass(target, accumulate)
        self._particle_pass(target, vp_j, cam.view, frame_state["particles"], accumulate)

    def render(self, frame: FrameSpec) -> dict[str, dict[str, np.ndarray]]:
        """All buffers of one frame: ``{"lr": {name: (h, w, C)}, "hr": {name: (H, W, C)}}`` float32.

        With ``extra_references`` also ``hr`` ``reference_4x`` and ``reference_taa``; the TAA needs
        every frame since the last reset passed in order (``advance_taa`` for those not written).
        """
        state = self._begin_frame(frame)
        self._draw(self.lr, state, frame.jitter, -math.log2(self.scale), accumulate=False)
        lr = _read_all(self.lr, "color")
        self._draw(self.hr, state, (0.0, 0.0), 0.0, accumulate=False)
        hr = _read_all(self.hr, "reference")
        g = self.grid  # fixed order: float32 sums are reproducible
        hr["reference"] = self._supersample(state, [((i + 0.5) / g - 0.5, (j + 0.5) / g - 0.5) for j in range(g) for i in range(g)])
        if "4x" in self.extra_references:
            hr["reference_4x"] = self._supersample(state, ROTATED_GRID_4X)
        if "taa" in self.extra_references:
            hr["reference_taa"] = self._taa_frame(frame, state)
        return {"lr": lr, "hr": hr}

    def advance_taa(self, frame: FrameSpec) -> None:
        """Run the native TAA over ``frame`` without rendering the rest (a frame another shard or an
        earlier run wrote, whose history the next frame needs)."""
        self._taa_frame(frame, self._begin_frame(frame))

    def _begin_frame(self, frame: FrameSpec) -> dict:
        """Camera, objects, particles, shadow map and light uniforms of ``frame``: the per-frame state of ``_draw``."""
        t = frame.time
        cam = self.camera(t)
        state = {
            "cam": cam,
            "prev": self.camera(frame.prev_time),
            "models": self._model_matrices(t),
            "prev_models": self._model_matrices(frame.prev_time),
            "particles": self._upload_particles(t),
        }
        light_vp, texel = self.light_matrix(t, cam)
        self._shadow_pass(light_vp, state["models"])
        self._set_light_uniforms(t, cam, light_vp, texel)
        return state

    def _supersample(self, state: dict, offsets) -> np.ndarray:
        """(H, W, 3) float32 mean of HR passes at ``offsets`` (HR pixels), summed in the given order."""
        self.hr.accumulate.use()
        self.hr.accumulate.clear(0.0, 0.0, 0.0, 0.0)
        for offset in offsets:
            self._draw(self.hr, state, offset, 0.0, accumulate=True)
        return self.hr.read("shade", "color", 3) / np.float32(len(offsets))

    def _taa_frame(self, frame: FrameSpec, state: dict) -> np.ndarray:
        """The native TAA's output for ``frame``: one HR pass at the Halton jitter (colour, and motion and
        depth as an engine's jittered velocity pass gives them), blended into the history."""
        self._draw(self.hr, state, native_taa.halton_offset(frame.index), 0.0, accumulate=False)
        motion_depth = self.hr.read("gbuffer", "motion_depth", 3)
        self.taa_history = native_taa.native_taa_step(
            self.hr.read("shade", "color", 3), motion_depth[..., :2], motion_depth[..., 2], self.taa_history, frame.reset)
        return self.taa_history

    def release(self) -> None:
        for obj in reversed(self._resources):
            obj.release()
        self.lr.release()
        self.hr.release()
        for prog in self.programs.values():
            prog.release()


def _rotation_only(view: np.ndarray) -> np.ndarray:
    r = view.copy()
    r[:3, 3] = 0.0
    return r


def _read_all(target: gpu.Target, colour_name: str) -> dict[str, np.ndarray]:
    """Every dataset buffer of ``target`` (one read per attachment)."""
    normal_rough = target.read("gbuffer", "normal_rough", 4)
    motion_depth = target.read("gbuffer", "motion_depth", 3)
    return {
        colour_name: target.read("shade", "color", 3),
        "depth": motion_depth[..., 2:3],
        "motion": motion_depth[..., :2],
        "albedo": target.read("gbuffer", "albedo", 3),
        "normal": normal_rough[..., :3],
        "roughness": normal_rough[..., 3:4],
        "metallic": target.read("gbuffer", "emissive_metal", 4)[..., 3:4],
        "fbeta": target.read("shade", "fbeta", 3),
        "emissive": target.read("shade", "emissive", 3),
    }
