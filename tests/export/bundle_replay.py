"""Replay a bundle's schedule on Mesa (EGL) from its files alone, as a phone runtime would.

Reads nothing but the bundle: resources, shader files, bindings, uniforms, workgroup counts and
weight blocks from manifest.json, the NPU graph from npu.tflite (LiteRT, the golden profile's
kernels).  Feeds the golden inputs and returns, per golden frame, the NPU input and output and
the display codes it produced.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mnss_kit.gpu.mesa import NUMPY_DTYPES, TEXTURE_FORMATS


def read_array(bundle: Path, entry: dict) -> np.ndarray:
    return np.fromfile(bundle / entry["file"], dtype=np.dtype(entry["dtype"]).newbyteorder("<")).reshape(entry["shape"])


class Replay:
    def __init__(self, ctx, bundle: Path):
        self.ctx, self.bundle = ctx, Path(bundle)
        self.m = json.loads((self.bundle / "manifest.json").read_text())
        self.passes = {p["name"]: p for p in self.m["gpu"]["passes"]}
        self.programs = {n: ctx.compute_shader((self.bundle / p["file"]).read_text()) for n, p in self.passes.items()}
        weights = self.m["gpu"]["weights"]
        raw = (self.bundle / weights["file"]).read_bytes()
        self.blocks = {b["name"]: ctx.buffer(raw[b["offset"]:b["offset"] + b["bytes"]]) for b in weights["blocks"]}
        self.res = {r["name"]: self._allocate(r) for r in self.m["resources"]}
        from mnss_kit.quantize.runtime import TfliteRunner

        self.npu = TfliteRunner((self.bundle / self.m["npu"]["model"]).read_bytes(), self.m["golden"]["profile"])

    def _allocate(self, r: dict):
        if r["kind"] == "buffer":
            return self.ctx.buffer(reserve=r["bytes"])
        components, dtype, _ = TEXTURE_FORMATS[r["format"]]
        if r["kind"] == "texture2d_array":
            return self.ctx.texture_array((*r["size"], r["layers"]), components, dtype=dtype)
        return self.ctx.texture(tuple(r["size"]), components, dtype=dtype)

    def upload(self, name: str, data: np.ndarray) -> None:
        tex = self.res[name]
        fmt = next(r["format"] for r in self.m["resources"] if r["name"] == name)
        components, dtype, _ = TEXTURE_FORMATS[fmt]
        h, w, c = data.shape
        full = np.zeros((h, w, components), np.float32)
        if components == 4:
            full[..., 3] = 1.0
        full[..., :c] = data
        tex.write(np.ascontiguousarray(full.astype(NUMPY_DTYPES[dtype])).tobytes())

    def frame_values(self, frame: dict, previous: dict | None) -> dict:
        """Per-frame uniform values: this golden frame's jitter, the previous one's (unused on a reset)."""
        prev = previous or frame
        return {"offset": tuple(frame["jitter"]), "subpixel": tuple(frame["subpixel"]), "previous_offset": tuple(prev["jitter"]),
                "previous_subpixel": tuple(prev["subpixel"]), "reset": int(frame["reset"])}

    def run_frame(self, frame: dict, previous: dict | None) -> dict:
        arrays = {k: read_array(self.bundle, e) for k, e in frame["arrays"].items()}
        for name in ("color", "depth", "motion"):
            self.upload(name, arrays[name].astype(np.float32))
        values = self.frame_values(frame, previous)
        got = {}
        for step in self.m["schedule"]["steps"]:
            if step["kind"] == "npu":
                got.update(self.run_npu(step))
            elif not (step["skip_on_reset"] and frame["reset"]):
                self.run_gpu(step, values)
        for swap in self.m["schedule"]["end_of_frame"]:
            a, b = swap["swap"]
            self.res[a], self.res[b] = self.res[b], self.res[a]
        w, h = self.m["hr_size"]
        got["display"] = np.frombuffer(self.res["display"].read(), np.uint8).reshape(h, w, 4)[..., :3].copy()
        return got

    def run_gpu(self, step: dict, values: dict) -> None:
        spec, prog = self.passes[step["pass"]], self.programs[step["pass"]]
        for binding in spec["bindings"]:
            target = step["bind"][binding["name"]]
            obj = self.blocks[target[len("weights:"):]] if target.startswith("weights:") else self.res[target]
            if binding["kind"] == "sampler":
                obj.use(location=binding["unit"])
            elif binding["kind"] == "image":
                obj.bind_to_image(binding["unit"], read=False, write=True, format=TEXTURE_FORMATS[binding["format"]][2])
            else:
                obj.bind_to_storage_buffer(binding["unit"])
        for name, spec_value in step["uniforms"].items():
            value = spec_value["value"] if "value" in spec_value else values[spec_value["frame"]]
            if name in prog:
                prog[name].value = tuple(value) if isinstance(value, list) else value
        prog.run(*step["groups"])
        self.ctx.memory_barrier()

    def run_npu(self, step: dict) -> dict:
        (tensor, source), = step["inputs"].items()
        (out_tensor, target), = step["outputs"].items()
        shape = next(b["shape"] for b in self.m["boundary"] if b["tensor"] == tensor)
        count = int(np.prod(shape))
        x = np.frombuffer(self.res[source].read(), np.int8)[:count].reshape(shape).copy()
        y = self.npu.run([x])[out_tensor]
        raw = y.astype(np.int8).tobytes()
        self.res[target].write(raw + b"\0" * (self.res[target].size - len(raw)))
        return {"npu_input": x, "npu_output": y}
