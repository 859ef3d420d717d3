"""``bundle check --run``: a bundle's golden frames replayed from its own files, its shaders compiled.

The hashes prove the files are the ones the manifest lists, not that they work together: a
re-hashed edit (weights scaled, golden bytes flipped, a shader broken) passes them.  The replay
runs the golden inputs through the manifest's schedule as the goldens were made (numpy reference
passes, the NPU graph on the golden profile's LiteRT kernels) and holds every stored array to the
manifest's tolerances; the emulator's numpy backends reproduce the same values bit for bit.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import UserError
from .golden import golden_mismatch, input_dtypes, run_golden
from .reader import Bundle


def replay_golden(root: Path, manifest: dict) -> list[str]:
    """The golden inputs through the bundle's own files (schedule, ``gpu_weights.bin``, the NPU graph
    on the golden profile's LiteRT kernels): one line for the first frame that does not reproduce
    its stored arrays (later frames inherit its history), none if all do."""
    bundle = Bundle(Path(root), manifest)
    frames = [bundle.golden_inputs(i) for i in range(len(manifest["golden"]["frames"]))]
    plan = {"resources": manifest["resources"], "schedule": manifest["schedule"], "weights": bundle.gpu_weights()}
    replayed = run_golden(plan, frames, bundle.npu_model(), manifest["golden"]["profile"], int(manifest["scale"]))
    inputs = set(input_dtypes(manifest["resources"]))
    for i, frame in enumerate(replayed):
        want = {k: v for k, v in bundle.golden(i).items() if k not in inputs}
        mismatch = golden_mismatch(manifest, i, frame.arrays, want)
        if mismatch:
            folder = Path(manifest["golden"]["frames"][i]["arrays"][next(iter(want))]["file"]).parent.as_posix()
            return [f"{folder}: the bundle's files do not reproduce golden frame {i}: {mismatch} differ beyond the "
                    "manifest's tolerances (weights, NPU graph or golden arrays changed)"]
    return []


def compile_shaders(root: Path, manifest: dict) -> tuple[list[str], str]:
    """Each shader file compiled on Mesa through EGL: ``(one line per file that does not compile, note)``;
    no problems and a note saying so where the system has no EGL."""
    from ..gpu.mesa import create_context

    try:
        ctx = create_context()
    except UserError as e:
        return [], f"shaders not compiled ({e})"
    problems = []
    for entry in manifest["gpu"]["passes"]:
        try:
            ctx.compute_shader((Path(root) / entry["file"]).read_text(encoding="utf-8", errors="replace"))
        except Exception as e:  # moderngl raises plain Exceptions carrying the driver's compile log
            problems.append(f"{entry['file']}: does not compile on Mesa ({_first_error(str(e))})")
    return problems, f"{len(manifest['gpu']['passes'])} shaders compiled on Mesa"


def _first_error(log: str) -> str:
    """The first line of a driver's compile log that names an error (else its first line)."""
    lines = [line.strip() for line in log.splitlines() if line.strip()]
    return next((line for line in lines if "error" in line.lower()), lines[0] if lines else "no log")[:200]
