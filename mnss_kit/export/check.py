"""``bundle check``: everything a bundle claims, verified against its files.

Order: the manifest (format, version gate, schema), then every listed file (present, size,
SHA-256; no unlisted files), then the NPU files (tensor names, shapes and quantization of the
manifest against ``npu.tflite``, and ``npu.tflite`` against ``npu_qdq.onnx``), the boundary
tensors (against the NPU tensors, remaps recomputed), the GPU weight blocks and the golden
arrays (inside their files, sizes matching shape and dtype, float values finite), the recorded
sequence if there is one (every input resource, frames x the bundle's sizes, decompressing to its
stated size, float values finite), and the
schedule (every pass, resource and weight block it names exists).  Each problem is one line naming the file or tensor.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UserError
from .boundary import texture_remaps
from ..fileio import sha256_file
from ..gpu.passes import PASSES
from ..gpu.plan import WEIGHTS_PREFIX, groups
from ..ops.jitter import subpixel_index
from .manifest import bundle_files, read_manifest, schema_problems, sha256_bytes
from .npu_files import NpuModel, nchw_to_nhwc, read_onnx, read_tflite
from .sequence import input_dtypes, read_sequence_array

DTYPE_SIZES = {"int8": 1, "uint8": 1, "int16": 2, "float16": 2, "float32": 4, "int32": 4}


def check_bundle(bundle: str | Path) -> list[str]:
    """Problems found in ``bundle`` (empty: the bundle is sound).

    A missing or foreign manifest and a newer format version raise ``UserError`` instead: nothing
    else can be checked then.
    """
    root = Path(bundle)
    manifest = read_manifest(root)
    problems = schema_problems(manifest)
    if problems:  # the later checks index into the structure the schema guarantees
        return problems
    problems += check_files(root, manifest)
    sizes = check_sizes(manifest)
    if sizes:  # every shape, uniform and jitter entry below follows from scale and sizes
        return problems + sizes
    problems += check_consistency(manifest)
    bad_files = {line.split(":", 1)[0] for line in problems}
    problems += check_npu(root, manifest, bad_files)
    problems += check_boundary(manifest)
    problems += check_weights(root, manifest, bad_files)
    problems += check_golden(root, manifest, bad_files)
    problems += check_sequence(root, manifest, bad_files)
    problems += check_schedule(manifest)
    problems += check_debug_views(manifest)
    return problems


def check_sizes(manifest: dict) -> list[str]:
    """One line if ``scale``, ``lr_size``, ``hr_size`` and the model config's scale disagree
    (the hashes cannot catch an edited manifest)."""
    scale, lr, hr = manifest["scale"], manifest["lr_size"], manifest["hr_size"]
    config_scale = (manifest["model"].get("config") or {}).get("scale")
    disagree = []
    if not float(scale).is_integer():  # a quality mode: lr_size = round_half_up(hr_size / s) per axis
        from ..ops.scale import size_mismatch

        why = size_mismatch(lr, hr, scale)
        if why:
            disagree.append(why)
    elif [scale * v for v in lr] != hr:
        disagree.append(f"hr_size {hr} is not scale {scale} x lr_size {lr} ({[scale * v for v in lr]})")
    if config_scale is not None and config_scale != scale:
        disagree.append(f"scale {scale} differs from model.config.scale {config_scale}")
    return [f"manifest.json: {'; '.join(disagree)}"] if disagree else []


def check_consistency(manifest: dict) -> list[str]:
    """What the manifest says twice agrees with itself: jitter sub-pixels, texture sizes, NPU
    shapes, the ``u_scale`` uniforms, workgroup counts and the placement's resolution follow from
    ``scale``, ``lr_size`` and ``hr_size``."""
    return (_jitter_problems(manifest) + _resource_size_problems(manifest) + _npu_size_problems(manifest)
            + _schedule_size_problems(manifest) + _placement_problems(manifest))


def _jitter_problems(manifest: dict) -> list[str]:
    scale, jitter = manifest["scale"], manifest["jitter"]
    problems = []
    if len(jitter["sequence"]) != jitter["period"]:
        problems.append(f"manifest.json: jitter.sequence has {len(jitter['sequence'])} entries for period {jitter['period']}")
    entries = [(f"jitter.sequence[{i}]", e["offset"], e["subpixel"]) for i, e in enumerate(jitter["sequence"])]
    entries += [(f"golden frame {f['index']}", f["jitter"], f["subpixel"]) for f in manifest["golden"]["frames"]]
    for where, offset, subpixel in entries:
        expected = subpixel_index(np.asarray(offset, np.float32), scale).tolist()
        if subpixel != expected:
            problems.append(f"manifest.json: {where}: subpixel {subpixel} does not follow from offset {offset} "
                            f"at scale {scale} ({expected})")
            break  # one line: the table was made for another scale
    return problems


def _resource_size_problems(manifest: dict) -> list[str]:
    allowed = [manifest["lr_size"], manifest["hr_size"], [1, 1]]  # [1, 1]: placeholders
    return [f"manifest.json: resource '{r['name']}' is {r['size'][0]}x{r['size'][1]}, neither lr_size {manifest['lr_size']} "
            f"nor hr_size {manifest['hr_size']}"
            for r in manifest["resources"] if r["kind"] != "buffer" and r["size"] not in allowed]


def _npu_size_problems(manifest: dict) -> list[str]:
    """The NPU output is the HR image (export takes the bundle's size from it) or, for a net that
    halves its resolution at LR (ntaau_lr), the LR size rounded up to even; its input is HR or LR
    (rounded up to even as well)."""
    tensors = {t["name"]: t for t in manifest["npu"]["tensors"]}
    w, h = manifest["lr_size"]
    even = [w + w % 2, h + h % 2]
    problems = []
    for role, sizes in (("outputs", [manifest["hr_size"], even]), ("inputs", [manifest["hr_size"], manifest["lr_size"], even])):
        for name in manifest["npu"][role]:
            shape = tensors.get(name, {}).get("shape")
            if shape and len(shape) == 4 and [shape[2], shape[1]] not in sizes:
                problems.append(f"manifest.json: NPU tensor '{name}' is {shape[2]}x{shape[1]}, the bundle's "
                                f"{'hr_size' if role == 'outputs' else 'hr_size or lr_size'} (or the LR size rounded up "
                                f"to even) is {' or '.join(f'{w}x{h}' for w, h in sizes)}")
    return problems


def _schedule_size_problems(manifest: dict) -> list[str]:
    """``u_scale`` is the bundle's scale; LR and HR grids cover their size with whole workgroups."""
    scale, lr = manifest["scale"], tuple(manifest["lr_size"])
    fractional = not float(scale).is_integer()
    u_scale = 0 if fractional else scale  # a fractional bundle's passes get 0: their textures' sizes give the ratio
    hr = tuple(manifest["hr_size"]) if fractional else None
    passes = {p["name"]: p for p in manifest["gpu"]["passes"]}
    problems = []
    for i, step in enumerate(manifest["schedule"]["steps"]):
        if step["kind"] != "gpu" or step["pass"] not in passes:
            continue  # check_schedule names an unknown pass
        where = f"manifest.json: schedule step {i} ({step['pass']})"
        value = step["uniforms"].get("u_scale", {}).get("value", u_scale)
        if value != u_scale:
            problems.append(f"{where}: u_scale {value}, the bundle's scale is {scale}"
                            + (" (a fractional scale's passes take u_scale 0)" if fractional else ""))
        spec = passes[step["pass"]]
        if spec["grid"] in ("hr", "lr", "lr_layers"):
            expected = groups(spec["grid"], tuple(spec["workgroup_size"]), lr, 1 if fractional else scale, hr_size=hr)[:2]
            if step["groups"][:2] != expected:
                problems.append(f"{where}: workgroups {step['groups'][0]}x{step['groups'][1]} do not cover its "
                                f"{spec['grid'].split('_')[0]} grid ({expected[0]}x{expected[1]} needed)")
    return problems


def _placement_problems(manifest: dict) -> list[str]:
    placement = manifest.get("placement")
    if not placement or placement.get("resolution") in (None, manifest["hr_size"]):
        return []
    return [f"manifest.json: placement.resolution {placement['resolution']} differs from hr_size {manifest['hr_size']}"]


def check_debug_views(manifest: dict) -> list[str]:
    """Every debug view names a texture resource (the schema has checked the rest)."""
    textures = {r["name"] for r in manifest["resources"] if r["kind"] != "buffer"}
    return [f"manifest.json: debug_views/{i} ('{view['name']}'): '{view['resource']}' is not a texture in resources"
            for i, view in enumerate(manifest.get("debug_views", [])) if view["resource"] not in textures]


def check_files(root: Path, manifest: dict) -> list[str]:
    """Every listed file exists with its size and hash; nothing unlisted lies in the bundle."""
    problems = []
    listed = manifest["files"]
    for name, entry in listed.items():
        path = root / name
        if not path.is_file():
            problems.append(f"{name}: missing (listed in manifest.json)")
            continue
        size = path.stat().st_size
        if size != entry["bytes"]:
            problems.append(f"{name}: {size} bytes, manifest.json says {entry['bytes']}")
        elif sha256_file(path) != entry["sha256"]:
            problems.append(f"{name}: SHA-256 differs from manifest.json (file changed or corrupt)")
    for name in bundle_files(root):
        if name not in listed:
            problems.append(f"{name}: not listed in manifest.json")
    return problems


def check_npu(root: Path, manifest: dict, bad_files: set[str]) -> list[str]:
    """Manifest NPU tensors vs ``npu.tflite``, and ``npu.tflite`` vs ``npu_qdq.onnx``."""
    npu = manifest["npu"]
    tflite_name, onnx_name = npu["model"], npu["onnx"]
    if tflite_name in bad_files or onnx_name in bad_files:
        return []  # already reported; the contents are not the exported ones
    try:
        tflite = read_tflite((root / tflite_name).read_bytes(), tflite_name)
        onnx = read_onnx((root / onnx_name).read_bytes(), onnx_name)
    except UserError as e:
        return [str(e)]
    problems = _manifest_vs_tflite(npu, tflite, tflite_name)
    problems += tflite_vs_onnx(tflite, onnx, tflite_name, onnx_name)
    return problems


def _manifest_vs_tflite(npu: dict, tflite: NpuModel, name: str) -> list[str]:
    problems = []
    for role in ("inputs", "outputs"):
        if npu[role] != getattr(tflite, role):
            problems.append(f"{name}: {role} are {getattr(tflite, role)}, manifest.json says {npu[role]}")
    listed = {t["name"] for t in npu["tensors"]}
    for entry in npu["tensors"]:
        t = tflite.tensors.get(entry["name"])
        where = f"{name}: tensor '{entry['name']}'"
        if t is None:
            problems.append(f"{where}: not in the file (listed in manifest.json)")
            continue
        if list(t.shape) != entry["shape"]:
            problems.append(f"{where}: shape {list(t.shape)}, manifest.json says {entry['shape']}")
        if t.dtype != entry["dtype"]:
            problems.append(f"{where}: dtype {t.dtype}, manifest.json says {entry['dtype']}")
        if t.scale.tolist() != [entry["scale"]] or t.zero_point.tolist() != [entry["zero_point"]]:
            problems.append(f"{where}: quantization (scale {t.scale.tolist()}, zero point {t.zero_point.tolist()}) differs from "
                            f"manifest.json (scale {entry['scale']}, zero point {entry['zero_point']})")
    for t in tflite.activations():
        if t.name not in listed:
            problems.append(f"{name}: tensor '{t.name}' is not listed in manifest.json npu.tensors")
    return problems


def tflite_vs_onnx(tflite: NpuModel, onnx: NpuModel, tflite_name: str, onnx_name: str) -> list[str]:
    problems = []
    for role in ("inputs", "outputs"):
        if getattr(tflite, role) != getattr(onnx, role):
            problems.append(f"{onnx_name}: {role} {getattr(onnx, role)} differ from {tflite_name} {getattr(tflite, role)}")
    for io in tflite.inputs + tflite.outputs:
        a, b = tflite.tensors[io], onnx.tensors.get(io)
        if b is not None and len(b.shape) == 4 and nchw_to_nhwc(b.shape) != a.shape:
            problems.append(f"{onnx_name}: tensor '{io}' shape {list(b.shape)} (NCHW) does not match {tflite_name} {list(a.shape)} (NHWC)")
    for t in tflite.tensors.values():
        if not t.quantized:
            continue
        other = onnx.tensors.get(t.name)
        if other is None or not other.quantized:
            problems.append(f"{onnx_name}: tensor '{t.name}' has no quantization (it has in {tflite_name})")
            continue
        if other.scale.tolist() != t.scale.tolist() or other.zero_point.tolist() != t.zero_point.tolist():
            problems.append(f"{onnx_name}: tensor '{t.name}' quantization differs from {tflite_name} "
                            f"(scale {_brief(other.scale)} vs {_brief(t.scale)}, zero point {_brief(other.zero_point)} vs {_brief(t.zero_point)})")
    return problems


def _brief(values: np.ndarray) -> str:
    values = values.tolist()
    return str(values[0]) if len(values) == 1 else f"[{values[0]}, ... {len(values)} values]"


def check_boundary(manifest: dict) -> list[str]:
    """Boundary tensors agree with the NPU tensor they name; remaps match their scale and zero point."""
    problems = []
    tensors = {t["name"]: t for t in manifest["npu"]["tensors"]}
    resources = {r["name"] for r in manifest["resources"]}
    for entry in manifest["boundary"]:
        where = f"manifest.json: boundary tensor '{entry['tensor']}'"
        t = tensors.get(entry["tensor"])
        if t is None:
            problems.append(f"{where}: not an NPU tensor")
            continue
        for key in ("shape", "dtype", "scale", "zero_point"):
            if entry[key] != t[key]:
                problems.append(f"{where}: {key} {entry[key]} differs from npu.tensors ({t[key]})")
        if entry["texture_remap"] != texture_remaps(entry["scale"], entry["zero_point"]):
            problems.append(f"{where}: texture_remap does not follow from its scale and zero point")
        if entry["bytes"] != int(np.prod(entry["shape"])):
            problems.append(f"{where}: bytes {entry['bytes']} != product of shape {entry['shape']}")
        if entry["buffer"]["resource"] not in resources:
            problems.append(f"{where}: buffer resource '{entry['buffer']['resource']}' is not in resources")
    return problems


def check_weights(root: Path, manifest: dict, bad_files: set[str]) -> list[str]:
    """Each GPU weight block lies inside its file and has the recorded hash and size."""
    weights = manifest["gpu"]["weights"]
    name = weights["file"]
    if name in bad_files or not (root / name).is_file():
        return []
    data = (root / name).read_bytes()
    problems = []
    for block in weights["blocks"]:
        where = f"{name}: weight block '{block['name']}'"
        end = block["offset"] + block["bytes"]
        if end > len(data):
            problems.append(f"{where}: bytes {block['offset']}..{end} run past the end of the file ({len(data)} bytes)")
            continue
        if block["bytes"] != int(np.prod(block["shape"])) * DTYPE_SIZES[weights["dtype"]]:
            problems.append(f"{where}: {block['bytes']} bytes do not hold shape {block['shape']} of {weights['dtype']}")
        if block["offset"] % weights["alignment"]:
            problems.append(f"{where}: offset {block['offset']} is not a multiple of {weights['alignment']}")
        if sha256_bytes(data[block["offset"]:end]) != block["sha256"]:
            problems.append(f"{where}: SHA-256 differs from manifest.json")
            continue
        problems += _non_finite(data[block["offset"]:end], weights["dtype"], where)
    return problems


def _non_finite(raw: bytes, dtype: str, where: str) -> list[str]:
    """A problem line if the little-endian float values in ``raw`` hold NaN or Inf (none for integers)."""
    kind = np.dtype(dtype).newbyteorder("<")
    if kind.kind != "f" or len(raw) % kind.itemsize:
        return []
    bad = int(np.count_nonzero(~np.isfinite(np.frombuffer(raw, dtype=kind))))
    return [f"{where}: {bad} NaN or Inf value{'s' if bad != 1 else ''}"] if bad else []


def check_golden(root: Path, manifest: dict, bad_files: set[str]) -> list[str]:
    """Golden arrays: listed files, shapes that fit the bundle's sizes, sizes that match shape x dtype."""
    problems = []
    listed = manifest["files"]
    expected_shapes = golden_shapes(manifest)
    for frame in manifest["golden"]["frames"]:
        missing = [k for k in expected_shapes if k not in frame["arrays"]]
        if missing:
            problems.append(f"manifest.json: golden frame {frame['index']} lacks the arrays {', '.join(missing)}")
        for key, array in frame["arrays"].items():
            if key not in expected_shapes:
                problems.append(f"manifest.json: golden frame {frame['index']} holds '{key}', which is no input, "
                                "boundary or output resource")
            name = array["file"]
            if key in expected_shapes and array["shape"] != expected_shapes[key]:
                problems.append(f"{name}: golden '{key}' has shape {array['shape']}, the bundle's sizes need {expected_shapes[key]}")
            if name not in listed:
                problems.append(f"{name}: golden array '{key}' of frame {frame['index']} is not listed in files")
                continue
            if name in bad_files:
                continue
            expected = int(np.prod(array["shape"])) * DTYPE_SIZES[array["dtype"]]
            if listed[name]["bytes"] != expected:
                problems.append(f"{name}: {listed[name]['bytes']} bytes, shape {array['shape']} of {array['dtype']} needs {expected}")
                continue
            problems += _non_finite((root / name).read_bytes(), array["dtype"], f"{name}: golden '{key}' of frame {frame['index']}")
    return problems


def check_sequence(root: Path, manifest: dict, bad_files: set[str]) -> list[str]:
    """The recorded sequence (if any): one array per input resource, (frames, h, w, channels) at the
    bundle's sizes in the golden dtype, decompressing to the stated bytes, finite."""
    sequence = manifest.get("sequence")
    if sequence is None:
        return []
    problems = []
    n = sequence["frame_count"]
    if len(sequence["frames"]) != n or [f["index"] for f in sequence["frames"]] != list(range(n)):
        problems.append(f"manifest.json: sequence lists {len(sequence['frames'])} frames (indices 0..) for frame_count {n}")
    dtypes = input_dtypes(manifest["resources"])
    shapes = golden_shapes(manifest)
    arrays = sequence["arrays"]
    for name in sorted(set(dtypes) - set(arrays)):
        problems.append(f"manifest.json: sequence lacks input resource '{name}'")
    for name, entry in arrays.items():
        where = f"{entry['file']}: sequence '{name}'"
        if name not in dtypes:
            problems.append(f"manifest.json: sequence holds '{name}', which is no input resource")
            continue
        expected = [n, *shapes[name]]
        if entry["shape"] != expected or entry["dtype"] != dtypes[name]:
            problems.append(f"{where} is {entry['dtype']} {entry['shape']}, the bundle needs {dtypes[name]} {expected}")
            continue
        if entry["file"] not in manifest["files"]:
            problems.append(f"{where} is not listed in files")
            continue
        if entry["file"] in bad_files:
            continue
        try:
            data = read_sequence_array(root, entry)
        except UserError as e:
            problems.append(str(e))
            continue
        problems += _non_finite(data.tobytes(), entry["dtype"], where)
    return problems


def golden_shapes(manifest: dict) -> dict[str, list[int]]:
    """Shapes of the golden arrays the manifest implies (``export.golden.golden_arrays``): every
    input resource and the output resource as (height, width, channels), every boundary buffer
    with the shape of the NPU tensor it carries."""
    from .golden import golden_arrays

    boundary = {b["buffer"]["resource"]: b["shape"] for b in manifest["boundary"]}
    resources = {r["name"]: r for r in manifest["resources"]}
    out = {}
    for name in golden_arrays(manifest["resources"]):
        r = resources[name]
        if r["role"] != "boundary":
            out[name] = [r["size"][1], r["size"][0], r["channels"]]
        elif name in boundary:
            out[name] = list(boundary[name])
    return out


def check_schedule(manifest: dict) -> list[str]:
    """Every name the schedule uses is defined and fits: shaders, resources (kind and image format),
    weight blocks, NPU tensors."""
    problems = []
    passes = {p["name"]: p for p in manifest["gpu"]["passes"]}
    resources = {r["name"]: r for r in manifest["resources"]}
    blocks = {b["name"] for b in manifest["gpu"]["weights"]["blocks"]}
    npu = manifest["npu"]
    for i, step in enumerate(manifest["schedule"]["steps"]):
        where = f"manifest.json: schedule step {i}"
        if step["kind"] == "npu":
            for tensor, resource in {**step["inputs"], **step["outputs"]}.items():
                if tensor not in npu["inputs"] + npu["outputs"]:
                    problems.append(f"{where}: '{tensor}' is not an input or output of {npu['model']}")
                if resources.get(resource, {}).get("kind") != "buffer":
                    problems.append(f"{where}: '{resource}' is not a buffer in resources")
            continue
        shader = passes.get(step["pass"])
        if shader is None:
            problems.append(f"{where}: pass '{step['pass']}' is not in gpu.passes")
            continue
        where = f"{where} ({step['pass']})"
        declared = {b["name"]: b for b in shader["bindings"]}
        for name, target in step["bind"].items():
            binding = declared.get(name)
            if binding is None:
                problems.append(f"{where}: binds '{name}', which the shader does not declare")
                continue
            problem = _binding_problem(binding, target, resources, blocks)
            if problem:
                problems.append(f"{where}: '{name}' -> '{target}': {problem}")
        missing = set(declared) - set(step["bind"])
        if missing:
            problems.append(f"{where}: nothing bound to {', '.join(sorted(missing))}")
        unset = _unset_uniforms(step, shader)
        if unset:
            problems.append(f"{where}: no value for {', '.join(unset)} (a bundle from another mnss-kit version: export it again)")
    return problems


def _unset_uniforms(step: dict, shader: dict) -> list[str]:
    """Uniforms the pass takes, in the bundle's shader list or in this toolkit's, that the step sets no value for."""
    known = PASSES.get(step["pass"])
    wanted = set(shader["uniforms"]) | set(known.uniforms if known else ())
    return sorted(wanted - set(step["uniforms"]))


def _binding_problem(binding: dict, target: str, resources: dict, blocks: set[str]) -> str | None:
    """Why ``target`` cannot serve ``binding`` (None if it can)."""
    if target.startswith(WEIGHTS_PREFIX):
        if target[len(WEIGHTS_PREFIX):] not in blocks:
            return "no such weight block"
        return None if binding["kind"] == "buffer" else f"a weight block bound to a {binding['kind']}"
    resource = resources.get(target)
    if resource is None:
        return "not in resources"
    if (binding["kind"] == "buffer") != (resource["kind"] == "buffer"):
        return f"a {resource['kind']} bound to a {binding['kind']}"
    if binding["kind"] != "buffer" and binding.get("array", False) != (resource["kind"] == "texture2d_array"):
        return f"a {resource['kind']} where the shader declares {'an array' if binding.get('array') else 'a 2D'} texture"
    if binding["kind"] == "image" and resource["format"] != binding["format"]:
        return f"format {resource['format']}, the image unit is declared {binding['format']}"
    return None
