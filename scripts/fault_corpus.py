"""A corpus of fault cases over every subcommand, run against tiny inputs in a temp directory (issue 45).

Each case makes a damaged input, a wrong scale, a bad output path or an interrupted run, runs one
``mnss-kit`` command (in-process through ``mnss_kit.cli.main``, or as a subprocess where a signal or a
second writer is needed) and is classed as:

- ``clear``: a non-zero exit with an ``error:`` line (or ``data check``'s problem lines), no traceback;
- ``handled``: the command did the right thing (exit 0 where the input is valid, e.g. a 1.5x render);
- ``traceback``: a Python traceback reached the user;
- ``silent``: exit 0 on an input that should be refused;
- ``leftover``: a half-written output was left after the failure or after a rerun;
- ``unclear``: a non-zero exit without any line saying why.

    .venv/bin/python scripts/fault_corpus.py --out /tmp/fault_corpus.json [--only SUBSTRING]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import logging
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

REPO = Path(__file__).resolve().parents[1]
KIT = str(REPO / ".venv" / "bin" / "mnss-kit")
if not Path(KIT).exists():
    KIT = shutil.which("mnss-kit") or "mnss-kit"


class _Stderr:
    """The log handler's stream: whatever sys.stderr is at the time of writing."""

    def write(self, text):
        return sys.stderr.write(text)

    def flush(self):
        sys.stderr.flush()


@dataclass
class Case:
    name: str
    command: str  # subcommand it exercises
    prepare: Callable  # (ctx, scratch) -> argv list (or None: the case runs itself and returns a Result)
    expect: str = "error"  # error | ok | either
    leftover: Callable | None = None  # (scratch) -> message when something half-written is left
    note: str = ""


@dataclass
class Result:
    name: str
    command: str
    outcome: str
    code: int | None
    line: str = ""
    seconds: float = 0.0
    detail: str = ""
    argv: list = field(default_factory=list)


# ---------------------------------------------------------------------------- running


def run_inprocess(argv: list[str]) -> tuple[int | None, str, str, str]:
    """(exit code, stderr, stdout, traceback text) of ``mnss-kit argv`` run in this process."""
    from mnss_kit.cli import main

    err, out = io.StringIO(), io.StringIO()
    tb = ""
    code: int | None
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = main([str(a) for a in argv])
        except SystemExit as e:  # argparse
            code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
            if not isinstance(e.code, int) and e.code is not None:
                print(e.code, file=sys.stderr)
        except BaseException:  # noqa: BLE001 - anything else is what a user would see as a traceback
            code = None
            tb = traceback.format_exc()
    return code, err.getvalue(), out.getvalue(), tb


def run_sub(argv: list, cwd: Path, timeout: float = 300) -> tuple[int | None, str, str]:
    p = subprocess.run([KIT, *map(str, argv)], cwd=cwd, capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stderr, p.stdout


def error_line(stderr: str) -> str:
    lines = [ln for ln in stderr.splitlines() if "error:" in ln or "ERROR" in ln or ln.startswith("mnss-kit")]
    return lines[-1] if lines else ""


def classify(case: Case, code, stderr: str, stdout: str, tb: str, scratch: Path) -> tuple[str, str]:
    if tb or "Traceback (most recent call last)" in stderr:
        last = (tb or stderr).strip().splitlines()[-1] if (tb or stderr).strip() else ""
        return "traceback", last
    line = error_line(stderr)
    if code == 0:
        if case.expect == "error":
            return "silent", (stderr.strip().splitlines() or [""])[-1]
        outcome = "handled"
    else:
        if case.expect == "ok":
            return ("clear" if line else "unclear"), line or (stderr.strip().splitlines() or [""])[-1]
        if not line and case.command in ("data check", "bundle check") and code == 1:
            problems = [ln for ln in (stdout + stderr).splitlines() if ln.strip()]  # its problem lines
            line = problems[0] if problems else ""
        outcome = "clear" if line else "unclear"
    if case.leftover:
        left = case.leftover(scratch)
        if left:
            return "leftover", left
    return outcome, line


def run_case(case: Case, ctx: dict, root: Path) -> Result:
    scratch = root / case.name
    scratch.mkdir(parents=True)
    start = time.time()
    here = os.getcwd()
    os.chdir(scratch)
    try:
        prepared = case.prepare(ctx, scratch)
        if isinstance(prepared, Result):
            prepared.seconds = time.time() - start
            return prepared
        argv = [str(a) for a in prepared]
        code, stderr, stdout, tb = run_inprocess(argv)
        outcome, line = classify(case, code, stderr, stdout, tb, scratch)
        detail = tb.strip().splitlines()[-1] if tb else ""
        return Result(case.name, case.command, outcome, code, line[:300], time.time() - start, detail, argv)
    except Exception:  # noqa: BLE001 - a case that fails to prepare is the corpus' bug: report it
        return Result(case.name, case.command, "corpus-error", None, traceback.format_exc().splitlines()[-1],
                      time.time() - start)
    finally:
        os.chdir(here)


# ---------------------------------------------------------------------------- inputs


def make_context(root: Path) -> dict:
    import torch

    from mnss_kit.cli import main
    from mnss_kit.dataset.synthetic import write_synthetic_sequence
    from mnss_kit.model import checkpoint
    from mnss_kit.model.config import load_model_config
    from mnss_kit.model.families import build_model, randomise_convs

    torch.set_num_threads(1)
    base = root / "_inputs"
    data = base / "data"
    write_synthetic_sequence(data / "pan", name="pan", frames=6)
    write_synthetic_sequence(data / "pan_cut", name="pan_cut", frames=6, cut_at=3)
    torch.manual_seed(0)
    model = randomise_convs(build_model(load_model_config("mnss_x2_tiny")).eval())
    ckpt = checkpoint.save(base / "tiny.pt", model, {"jitter_pattern": "grid"})
    bundle = base / "bundle"
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        code = main(["export", str(ckpt), "--out", str(bundle), "--resolution", "64x48", "--data", str(data),
                     "--golden-frames", "2", "--no-progress"])
    assert code == 0, "export of the tiny bundle failed"
    readonly = base / "readonly"
    readonly.mkdir()
    readonly.chmod(0o555)
    return {"data": data, "ckpt": ckpt, "bundle": bundle, "base": base,
            # root ignores permission bits: /proc refuses every mkdir, as a read-only mount does
            "readonly": Path("/proc/mnss_fault_corpus") if os.geteuid() == 0 else readonly}


def copy_data(ctx, scratch: Path, seq: str | None = None) -> Path:
    if seq:
        return Path(shutil.copytree(ctx["data"] / seq, scratch / "data" / seq))
    return Path(shutil.copytree(ctx["data"], scratch / "data", ignore=shutil.ignore_patterns(".cache")))


def copy_bundle(ctx, scratch: Path) -> Path:
    return Path(shutil.copytree(ctx["bundle"], scratch / "bundle"))


def read_exr(path: Path) -> np.ndarray:
    from mnss_kit.dataset.exr import read_exr as r  # noqa: PLC0415

    return r(path)


def write_exr(path: Path, arr: np.ndarray, channels=None) -> None:
    from mnss_kit.dataset.exr import write_exr as w  # noqa: PLC0415

    w(path, arr, half=False, channels=channels)


# data damages: (scratch data root) -> None; all on sequence pan
def _d_truncate(buf, frame=1):
    def f(d: Path):
        p = d / "pan" / buf / f"{frame:05d}.exr"
        p.write_bytes(p.read_bytes()[: p.stat().st_size // 3])
    return f


def _d_empty(buf, frame=1):
    def f(d: Path):
        (d / "pan" / buf / f"{frame:05d}.exr").write_bytes(b"")
    return f


def _d_value(buf, value, frame=2, whole=False):
    def f(d: Path):
        p = d / "pan" / buf / f"{frame:05d}.exr"
        a = read_exr(p).astype(np.float32).copy()
        if whole:
            a[...] = value
        else:
            a[2:6, 3:9, ...] = value
        write_exr(p, a, channels=("Z",) if buf.endswith("depth") else None)
    return f


def _d_shape(buf, frame=1):
    def f(d: Path):
        p = d / "pan" / buf / f"{frame:05d}.exr"
        a = read_exr(p)
        write_exr(p, np.ascontiguousarray(a[: a.shape[0] // 2, : a.shape[1] // 2]))
    return f


def _d_missing_buffer(buf):
    def f(d: Path):
        shutil.rmtree(d / "pan" / buf)
    return f


def _d_missing_frame(buf, frame=3):
    def f(d: Path):
        (d / "pan" / buf / f"{frame:05d}.exr").unlink()
    return f


def _d_meta(edit):
    def f(d: Path):
        p = d / "pan" / "meta.json"
        if isinstance(edit, str):
            p.write_text(edit)
        else:
            m = json.loads(p.read_text())
            edit(m)
            p.write_text(json.dumps(m))
    return f


def _m_set(key, value):
    def e(m):
        m[key] = value
    return e


def _m_frames(fn):
    def e(m):
        m["frames"] = fn(m["frames"])
    return e


def _m_jitter_nan(m):
    m["frames"][1]["jitter"] = [float("nan"), 0.0]


DATA_DAMAGES = {
    "lr-color-truncated": _d_truncate("lr/color"),
    "hr-reference-truncated": _d_truncate("hr/reference"),
    "lr-depth-empty-file": _d_empty("lr/depth"),
    "lr-color-nan": _d_value("lr/color", np.nan),
    "lr-color-inf": _d_value("lr/color", np.inf),
    "lr-color-negative": _d_value("lr/color", -5.0, whole=True),
    "lr-depth-inf": _d_value("lr/depth", np.inf),
    "lr-motion-nan": _d_value("lr/motion", np.nan),
    "lr-motion-1e9": _d_value("lr/motion", 1e9, whole=True),
    "lr-motion-1e9-patch": _d_value("lr/motion", 1e9),
    "hr-reference-nan": _d_value("hr/reference", np.nan),
    "lr-color-wrong-shape": _d_shape("lr/color"),
    "hr-reference-wrong-shape": _d_shape("hr/reference"),
    "lr-motion-missing-buffer": _d_missing_buffer("lr/motion"),
    "hr-reference-missing-buffer": _d_missing_buffer("hr/reference"),
    "lr-color-missing-frame": _d_missing_frame("lr/color"),
    "meta-empty": _d_meta(""),
    "meta-not-json": _d_meta("{\"format\": \"mnss-dataset\", "),
    "meta-no-frames": _d_meta(_m_frames(lambda f: [])),
    "meta-scale-3": _d_meta(_m_set("scale", 3)),
    "meta-scale-1.5": _d_meta(_m_set("scale", 1.5)),
    "meta-lr-size-negative": _d_meta(_m_set("lr_size", [-32, 24])),
    "meta-jitter-nan": _d_meta(_m_jitter_nan),
}
# which (damage, command) pairs to run: the checker everywhere, the readers on the sharpest ones
DATA_COMMANDS = {
    "data check": lambda ctx, s, d: ["data", "check", d],
    "eval": lambda ctx, s, d: ["eval", ctx["ckpt"], "--data", d, "--json", s / "out.json", "--no-progress"],
    "emulate": lambda ctx, s, d: ["emulate", ctx["bundle"], "--data", d / "pan", "--out", s / "out", "--frames", 3,
                                  "--no-progress"],
    "data variant": lambda ctx, s, d: ["data", "variant", d, "--out", s / "out", "--apply", "ldr8"],
    "quantize": lambda ctx, s, d: ["quantize", ctx["ckpt"], "--data", d, "--out", s / "out", "--frames", 2,
                                   "--pipeline-frames", 0, "--no-progress"],
    "train": lambda ctx, s, d: ["train", write_train_config(s, d), "--out", s / "out", "--no-progress"],
    "data info": lambda ctx, s, d: ["data", "info", d],
    "data cache": lambda ctx, s, d: ["data", "cache", d, "--cache-dir", s / "out"],
    "finetune": lambda ctx, s, d: ["finetune", d, "--model", ctx["ckpt"], "--out", s / "out", "--minutes", "0.05",
                                   "--no-progress"],
    "size": lambda ctx, s, d: ["size", "--data", d, "--target", "psnr:10", "--ladder", write_train_config(s, d),
                               "--steps", 2, "--out", s / "out", "--no-progress"],
    "stress": lambda ctx, s, d: ["stress", "--models", ctx["ckpt"], "--data", d, "--out", s / "out",
                                 "--max-frames", 3, "--no-crops", "--no-progress"],
    "bench": lambda ctx, s, d: ["bench", "--models", ctx["ckpt"], "--data", d, "--out", s / "b.json", "--charts",
                                s / "charts", "--work", s / "w", "--quick", "--no-progress"],
    "export --data": lambda ctx, s, d: ["export", ctx["ckpt"], "--out", s / "out", "--resolution", "64x48",
                                        "--data", d, "--golden-frames", 1, "--no-progress"],
    "export --sequence": lambda ctx, s, d: ["export", ctx["ckpt"], "--out", s / "out", "--resolution", "64x48",
                                            "--data", ctx["data"], "--sequence", d, "--golden-frames", 1,
                                            "--no-progress"],
    "quantize --eval-data": lambda ctx, s, d: ["quantize", ctx["ckpt"], "--data", ctx["data"], "--eval-data", d,
                                               "--out", s / "out", "--frames", 2, "--pipeline-frames", 2,
                                               "--no-progress"],
}
DATA_MATRIX = {
    "data check": list(DATA_DAMAGES),
    "eval": ["lr-color-truncated", "lr-depth-empty-file", "lr-color-nan", "lr-motion-nan", "lr-color-wrong-shape",
             "hr-reference-missing-buffer", "lr-color-missing-frame", "meta-not-json", "meta-scale-1.5",
             "meta-jitter-nan", "hr-reference-nan"],
    "emulate": ["lr-color-truncated", "lr-color-nan", "lr-depth-inf", "lr-color-wrong-shape",
                "lr-motion-missing-buffer", "meta-empty", "meta-scale-3"],
    "data variant": ["lr-color-truncated", "lr-color-nan", "lr-motion-missing-buffer", "meta-not-json"],
    "quantize": ["lr-color-truncated", "lr-color-nan", "meta-no-frames"],
    "train": ["lr-color-truncated", "lr-color-inf", "meta-lr-size-negative", "lr-motion-1e9", "meta-no-frames"],
    "data info": ["lr-color-truncated", "meta-not-json", "meta-no-frames", "lr-motion-missing-buffer"],
    "data cache": ["lr-color-truncated", "lr-color-nan", "lr-color-wrong-shape", "meta-empty", "meta-no-frames"],
    "finetune": ["lr-color-truncated", "lr-color-nan", "meta-no-frames", "lr-motion-1e9"],
    "size": ["lr-color-nan", "meta-not-json"],
    "stress": ["lr-color-truncated", "lr-depth-inf"],
    "bench": ["lr-color-nan", "meta-no-frames"],
    "export --data": ["lr-color-nan", "lr-motion-1e9", "meta-scale-3", "lr-color-missing-frame"],
    "export --sequence": ["lr-color-nan", "hr-reference-wrong-shape"],
    "quantize --eval-data": ["lr-color-nan", "lr-color-truncated"],
    "eval ": ["lr-motion-1e9", "lr-motion-1e9-patch", "meta-no-frames", "lr-depth-inf"],
    "emulate ": ["lr-motion-1e9", "meta-no-frames", "lr-color-inf"],
}
# damages after which the data is still valid (warnings allowed): the command should run
DATA_OK = {"lr-color-negative": "either", "lr-motion-1e9-patch": "either"}


def write_train_config(scratch: Path, data: Path) -> Path:
    import yaml

    model = {"family": "mnss", "scale": 2, "recon_width": 8, "recon_layers": 2, "aa_width": 4, "aa_layers": 1}
    train = {"train_data": str(data), "window": 3, "batch_size": 1, "crop": 12, "epochs": 1, "steps_per_epoch": 2,
             "gt_history_epochs": 0, "bptt": 2, "threads": 1, "log_every": 1, "checkpoint_every": 1, "val_every": 0,
             "cache_dir": str(scratch / "cache")}
    path = scratch / "train.yaml"
    path.write_text(yaml.safe_dump({"schema": 1, "model": model, "train": train}))
    return path


def data_case(damage: str, command: str) -> Case:
    command = command.strip()

    def prepare(ctx, s):
        d = copy_data(ctx, s)
        DATA_DAMAGES[damage](d)
        return DATA_COMMANDS[command](ctx, s, d)

    def left(s: Path):
        out = s / "out"
        if out.exists() and any(out.rglob("*")) and command in ("data variant", "quantize", "train"):
            return f"{out} left with {sum(1 for _ in out.rglob('*'))} entries"
        return ""

    expect = "either" if command == "data info" else DATA_OK.get(damage, "error")  # info describes, need not judge
    return Case(f"{command.replace(' --', '-').replace(' ', '-')}--{damage}", command.split(" --")[0], prepare,
                expect, left)


# ---------------------------------------------------------------------------- scales

SCALES = ["0.5", "1.0", "nan", "9", "1.5", "inf", "-2", "x2"]


def scale_case(command: str, scale: str) -> Case:
    def prepare(ctx, s):
        return {
            "render": ["render", "tiny_test", "--out", s / "out", "--set", "frames=2", "--scale", scale,
                       "--no-progress"],
            "eval": ["eval", ctx["ckpt"], "--data", ctx["data"] / "pan", "--scale", scale, "--max-frames", 3,
                     "--no-progress"],
            "export": ["export", ctx["ckpt"], "--out", s / "out", "--resolution", "64x48", "--scale", scale,
                       "--data", ctx["data"], "--golden-frames", 1, "--no-progress"],
            "emulate": ["emulate", ctx["bundle"], "--data", ctx["data"] / "pan", "--out", s / "out", "--frames", 2,
                        "--scale", scale, "--no-progress"],
            "bench": ["bench", "--out", s / "b.json", "--charts", s / "charts", "--work", s / "work", "--models",
                      "none", "--data", ctx["data"], "--scale", scale, "--quick", "--no-progress"],
            "data check": ["data", "check", ctx["data"], "--scale", scale],
        }[command]

    return Case(f"{command.replace(' ', '-')}--scale-{scale}", command, prepare, "error")


def fractional_ok_cases() -> list[Case]:
    """A fractional scale where it is valid: rendered with a pattern that allows it, then checked."""

    def render(ctx, s):
        return ["render", "tiny_test", "--out", s / "out", "--set", "frames=2", "--set", "jitter=halton", "--scale",
                "1.5", "--no-progress"]

    def check(ctx, s):
        code, err, out = run_sub(render(ctx, s), s)
        if code != 0:
            return _result("render--scale-1.5-halton-then-check", "render", "clear" if error_line(err) else "unclear",
                           code, error_line(err))
        return ["data", "check", s / "out", "--scale", "1.5"]

    return [Case("render--scale-1.5-halton", "render", render, "ok"),
            Case("data-check--scale-1.5-rendered", "data check", check, "ok")]


# ---------------------------------------------------------------------------- bundles


def _b_rm(rel_glob):
    def f(b: Path):
        hits = sorted(b.glob(rel_glob))
        assert hits, rel_glob
        hits[0].unlink()
    return f


def _b_truncate(rel_glob):
    def f(b: Path):
        p = sorted(b.glob(rel_glob))[0]
        p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    return f


def _b_manifest(edit):
    def f(b: Path):
        p = b / "manifest.json"
        if isinstance(edit, str):
            p.write_text(edit)
        else:
            m = json.loads(p.read_text())
            edit(m)
            p.write_text(json.dumps(m, indent=1))
    return f


def _mf_scale(m):
    m["scale"] = 4


def _mf_version(m):
    m["version"] = 999


def _mf_drop_first_key(m):
    for k in ("lr_size", "hr_size", "scale"):
        m.pop(k, None)


BUNDLE_DAMAGES = {
    "missing-shader": _b_rm("shaders/warp_pass.comp"),
    "missing-tflite": _b_rm("npu.tflite"),
    "truncated-tflite": _b_truncate("npu.tflite"),
    "missing-golden": _b_rm("golden/frame_001/npu_output.bin"),
    "manifest-deleted": _b_rm("manifest.json"),
    "manifest-empty": _b_manifest(""),
    "manifest-not-json": _b_manifest("{\"schema\": "),
    "manifest-scale-edited": _b_manifest(_mf_scale),
    "manifest-version-edited": _b_manifest(_mf_version),
    "manifest-sizes-removed": _b_manifest(_mf_drop_first_key),
    "gpu-weights-truncated": _b_truncate("gpu_weights.bin"),
    "golden-npu-output-empty": lambda b: (b / "golden" / "frame_000" / "npu_output.bin").write_bytes(b""),
    "shader-garbage": lambda b: (b / "shaders" / "conv3x3_pass.comp").write_text("#version 310 es\nvoid main( {"),
}


def bundle_case(damage: str, command: str) -> Case:
    def prepare(ctx, s):
        b = copy_bundle(ctx, s)
        BUNDLE_DAMAGES[damage](b)
        if command == "bundle check":
            return ["bundle", "check", b]
        return ["emulate", b, "--data", ctx["data"] / "pan", "--out", s / "out", "--frames", 2, "--no-progress"]

    return Case(f"{command.replace(' ', '-')}--{damage}", command, prepare, "error")


def bundle_extra_cases() -> list[Case]:
    def path_is_file(ctx, s):
        (s / "b").write_text("not a bundle")
        return ["bundle", "check", s / "b"]

    def empty_dir(ctx, s):
        (s / "b").mkdir()
        return ["bundle", "check", s / "b"]

    def emulate_empty_dir(ctx, s):
        (s / "b").mkdir()
        return ["emulate", s / "b", "--data", ctx["data"] / "pan", "--out", s / "out", "--no-progress"]

    def emulate_frames_zero(ctx, s):
        return ["emulate", ctx["bundle"], "--data", ctx["data"] / "pan", "--out", s / "out", "--frames", 0,
                "--no-progress"]

    def emulate_compare_missing(ctx, s):
        return ["emulate", "--compare", s / "a", s / "b"]

    def emulate_compare_files(ctx, s):
        (s / "a").write_text("x")
        (s / "b").write_bytes(b"\x00" * 10)
        return ["emulate", "--compare", s / "a", s / "b"]

    return [Case("bundle-check--path-is-a-file", "bundle check", path_is_file),
            Case("bundle-check--empty-dir", "bundle check", empty_dir),
            Case("emulate--bundle-empty-dir", "emulate", emulate_empty_dir),
            Case("emulate--frames-0", "emulate", emulate_frames_zero),
            Case("emulate--compare-missing-dumps", "emulate", emulate_compare_missing),
            Case("emulate--compare-garbage-files", "emulate", emulate_compare_files)]


# ---------------------------------------------------------------------------- checkpoints

CKPT_DAMAGES = {
    "empty": lambda p, c: p.write_bytes(b""),
    "truncated": lambda p, c: p.write_bytes(c.read_bytes()[: c.stat().st_size // 2]),
    "text": lambda p, c: p.write_text("this is not a checkpoint\n"),
    "missing": lambda p, c: None,
    "directory": lambda p, c: p.mkdir(),
}


def ckpt_case(damage: str, command: str) -> Case:
    def prepare(ctx, s):
        p = s / "model.pt"
        CKPT_DAMAGES[damage](p, ctx["ckpt"])
        return {
            "eval": ["eval", p, "--data", ctx["data"] / "pan", "--max-frames", 2, "--no-progress"],
            "quantize": ["quantize", p, "--data", ctx["data"], "--out", s / "out", "--frames", 2,
                         "--pipeline-frames", 0, "--no-progress"],
            "export": ["export", p, "--out", s / "out", "--resolution", "64x48", "--data", ctx["data"],
                       "--no-progress"],
            "split": ["split", p, "--device", "snapdragon_8_gen_1"],
            "finetune": ["finetune", ctx["data"], "--model", p, "--out", s / "out", "--minutes", "0.05",
                         "--no-progress"],
            "train --init": ["train", write_train_config(s, ctx["data"]), "--out", s / "out", "--init", p,
                             "--no-progress"],
        }[command]

    return Case(f"{command.replace(' --', '-').replace(' ', '-')}--ckpt-{damage}", command.split()[0], prepare)


# ---------------------------------------------------------------------------- output paths

OUTPUT_COMMANDS = {
    "render": lambda ctx, s, o: ["render", "tiny_test", "--out", o, "--set", "frames=2", "--no-progress"],
    "eval --json": lambda ctx, s, o: ["eval", ctx["ckpt"], "--data", ctx["data"] / "pan", "--max-frames", 2,
                                      "--json", o, "--no-progress"],
    "export": lambda ctx, s, o: ["export", ctx["ckpt"], "--out", o, "--resolution", "64x48", "--data", ctx["data"],
                                 "--no-progress"],
    "emulate": lambda ctx, s, o: ["emulate", ctx["bundle"], "--data", ctx["data"] / "pan", "--out", o, "--frames",
                                  2, "--no-progress"],
    "data variant": lambda ctx, s, o: ["data", "variant", ctx["data"], "--out", o, "--apply", "ldr8"],
    "quantize": lambda ctx, s, o: ["quantize", ctx["ckpt"], "--data", ctx["data"], "--out", o, "--frames", 2,
                                   "--pipeline-frames", 0, "--no-progress"],
    "split --json": lambda ctx, s, o: ["split", ctx["ckpt"], "--device", "snapdragon_8_gen_1", "--json", o],
    "train": lambda ctx, s, o: ["train", write_train_config(s, ctx["data"]), "--out", o, "--no-progress"],
    "data cache": lambda ctx, s, o: ["data", "cache", ctx["data"] / "pan", "--cache-dir", o],
}
OUTPUT_KINDS = {
    # a file where a directory (or a file's parent) is expected
    "out-under-a-file": lambda ctx, s: _w(s / "f", "x", s / "f" / "out"),
    "read-only-location": lambda ctx, s: ctx["readonly"] / "out",
}


def output_case(command: str, kind: str) -> Case:
    def prepare(ctx, s):
        return OUTPUT_COMMANDS[command](ctx, s, OUTPUT_KINDS[kind](ctx, s))

    return Case(f"{command.replace(' --', '-').replace(' ', '-')}--{kind}", command.split()[0], prepare)


def out_is_file_case(command: str) -> Case:
    def prepare(ctx, s):
        (s / "o").write_text("precious")
        return OUTPUT_COMMANDS[command](ctx, s, s / "o")

    def left(s: Path):
        return "" if (s / "o").is_file() and (s / "o").read_text() == "precious" else "the file at --out was replaced"

    expect = "error" if command not in ("eval --json", "split --json") else "either"
    return Case(f"{command.replace(' --', '-').replace(' ', '-')}--out-is-a-file", command.split()[0], prepare,
                expect, left if expect == "error" else None)


# ---------------------------------------------------------------------------- configs and arguments


def misc_cases() -> list[Case]:
    cases = []

    def render_set(key_value, expect="error"):
        def prepare(ctx, s):
            return ["render", "tiny_test", "--out", s / "out", "--set", "frames=2", "--set", key_value,
                    "--no-progress"]
        return Case(f"render--set-{key_value}", "render", prepare, expect)

    for kv in ["frames=0", "frames=-3", "lr_size=[0,90]", "lr_size=[-160,90]", "hr_samples=-1", "scene=nowhere",
               "jitter=sideways", "fps=0", "nosuchkey=1", "lr_size=[99999,99999]"]:
        cases.append(render_set(kv))

    def config_case(command: str, text: str, name: str):
        """``command`` given a config file holding ``text``."""
        def prepare(ctx, s):
            (s / "config.yaml").write_text(text)
            return [command, s / "config.yaml", "--out", s / "out", "--no-progress"]
        return Case(f"{command}--config-{name}", command, prepare)

    def render_config(text: str, name: str):
        return config_case("render", text, name)

    cases += [render_config("", "empty"), render_config("version: 1\nsequences: []\n", "no-sequences"),
              render_config("version: 1\nsequences: [{name: a}]\n", "sequence-without-scene"),
              render_config("- just\n- a list\n", "a-list"), render_config("version: 1\nsequences: {a: 1\n", "bad-yaml")]
    cases.append(Case("render--config-missing", "render",
                      lambda ctx, s: ["render", s / "nope.yaml", "--out", s / "out", "--no-progress"]))
    cases.append(Case("render--shard-3-of-2", "render",
                      lambda ctx, s: ["render", "tiny_test", "--out", s / "out", "--shard", "3/2", "--no-progress"]))

    def train_config(text: str, name: str):
        return config_case("train", text, name)

    cases += [train_config("", "empty"), train_config("schema: 1\nmodel: {family: nope}\n", "unknown-family"),
              train_config("\x00\x01\x02garbage", "binary")]

    def train_set(kv):
        def prepare(ctx, s):
            return ["train", write_train_config(s, ctx["data"]), "--out", s / "out", "--set", kv, "--no-progress"]
        return Case(f"train--set-{kv}", "train", prepare)

    cases += [train_set(kv) for kv in ["train.epochs=-1", "train.batch_size=0", "train.lr=nan", "train.nosuch=1",
                                       "model.scale=1.5", "train.crop=0"]]
    cases.append(Case("train--data-missing", "train", lambda ctx, s: [
        "train", write_train_config(s, s / "nowhere"), "--out", s / "out", "--no-progress"]))
    cases.append(Case("train--resume-without-run", "train", lambda ctx, s: [
        "train", write_train_config(s, ctx["data"]), "--out", s / "out", "--resume", "--no-progress"]))

    # data check / info / import on non-datasets
    def nd(ctx, s):
        (s / "d").mkdir()
        return ["data", "check", s / "d"]
    cases.append(Case("data-check--empty-dir", "data check", nd))
    cases.append(Case("data-check--missing-dir", "data check", lambda ctx, s: ["data", "check", s / "nowhere"]))
    cases.append(Case("data-check--a-file", "data check",
                      lambda ctx, s: _w(s / "f", "x", ["data", "check", s / "f"])))
    cases.append(Case("data-info--missing-dir", "data", lambda ctx, s: ["data", "info", s / "nowhere"]))
    cases.append(Case("data-import-nss--empty-dir", "data import",
                      lambda ctx, s: (s / "cap").mkdir() or ["data", "import", "nss", s / "cap", "--out", s / "out"]))
    cases.append(Case("data-import-images--no-mapping", "data import",
                      lambda ctx, s: (s / "cap").mkdir() or ["data", "import", "images", s / "cap", "--out",
                                                             s / "out"]))
    cases.append(Case("data-import-images--mapping-missing", "data import", lambda ctx, s: (s / "cap").mkdir() or [
        "data", "import", "images", s / "cap", "--mapping", s / "nope.yaml", "--out", s / "out"]))
    cases.append(Case("data-variant--unknown-variant", "data variant", lambda ctx, s: [
        "data", "variant", ctx["data"], "--out", s / "out", "--apply", "sepia"]))

    # split / models / eval arguments
    cases += [
        Case("split--device-unknown", "split", lambda ctx, s: ["split", ctx["ckpt"], "--device", "nokia_3310"]),
        Case("split--resolution-0x0", "split",
             lambda ctx, s: ["split", ctx["ckpt"], "--device", "snapdragon_8_gen_1", "--resolution", "0x0"]),
        Case("split--resolution-garbage", "split",
             lambda ctx, s: ["split", ctx["ckpt"], "--device", "snapdragon_8_gen_1", "--resolution", "wide"]),
        Case("split--model-unknown-name", "split",
             lambda ctx, s: ["split", "no_such_model", "--device", "snapdragon_8_gen_1"]),
        Case("eval--data-missing", "eval", lambda ctx, s: ["eval", ctx["ckpt"], "--data", s / "nowhere"]),
        Case("eval--max-frames-0", "eval",
             lambda ctx, s: ["eval", ctx["ckpt"], "--data", ctx["data"] / "pan", "--max-frames", 0,
                             "--no-progress"]),
        Case("eval--methods-unknown", "eval",
             lambda ctx, s: ["eval", ctx["ckpt"], "--data", ctx["data"] / "pan", "--methods", "magic",
                             "--no-progress"]),
        Case("export--resolution-odd", "export",
             lambda ctx, s: ["export", ctx["ckpt"], "--out", s / "out", "--resolution", "63x47", "--data",
                             ctx["data"], "--no-progress"]),
        Case("export--golden-frames-0", "export",
             lambda ctx, s: ["export", ctx["ckpt"], "--out", s / "out", "--resolution", "64x48", "--data",
                             ctx["data"], "--golden-frames", 0, "--no-progress"], "either"),
        Case("export--device-unknown", "export",
             lambda ctx, s: ["export", ctx["ckpt"], "--out", s / "out", "--resolution", "64x48", "--device",
                             "nokia_3310", "--data", ctx["data"], "--no-progress"]),
        Case("quantize--frames-0", "quantize",
             lambda ctx, s: ["quantize", ctx["ckpt"], "--data", ctx["data"], "--out", s / "out", "--frames", 0,
                             "--pipeline-frames", 0, "--no-progress"]),
        Case("finetune--capture-missing", "finetune",
             lambda ctx, s: ["finetune", s / "nowhere", "--out", s / "out", "--no-progress"]),
        Case("finetune--hold-back-too-many", "finetune",
             lambda ctx, s: ["finetune", ctx["data"], "--model", ctx["ckpt"], "--out", s / "out", "--hold-back",
                             100, "--minutes", "0.05", "--no-progress"]),
        Case("finetune--minutes-negative", "finetune",
             lambda ctx, s: ["finetune", ctx["data"], "--model", ctx["ckpt"], "--out", s / "out", "--minutes",
                             "-1", "--no-progress"]),
        Case("size--target-garbage", "size",
             lambda ctx, s: ["size", "--data", ctx["data"], "--target", "psnr>>", "--out", s / "out",
                             "--no-progress"]),
        Case("size--data-missing", "size",
             lambda ctx, s: ["size", "--data", s / "nowhere", "--target", "psnr:30", "--out", s / "out",
                             "--no-progress"]),
        Case("stress--data-missing", "stress",
             lambda ctx, s: ["stress", "--data", s / "nowhere", "--out", s / "out", "--no-progress"]),
        Case("stress--models-unknown", "stress",
             lambda ctx, s: ["stress", "--models", "no_such_model", "--data", ctx["data"], "--out", s / "out",
                             "--no-progress"]),
        Case("bench--models-unknown", "bench",
             lambda ctx, s: ["bench", "--models", "no_such_model", "--data", ctx["data"], "--out", s / "b.json",
                             "--work", s / "w", "--quick", "--no-progress"]),
        Case("report--bench-missing", "report",
             lambda ctx, s: ["report", "--bench", s / "nope.json", "--out", s / "out"]),
        Case("report--bench-not-json", "report",
             lambda ctx, s: _w(s / "b.json", "{nope", ["report", "--bench", s / "b.json", "--out",
                                                                   s / "out"])),
        Case("report--stress-empty", "report",
             lambda ctx, s: _w(s / "st.json", "", ["report", "--stress", s / "st.json", "--out",
                                                               s / "out"])),
        Case("report--size-wrong-json", "report",
             lambda ctx, s: _w(s / "sz.json", "[1, 2, 3]", ["report", "--size", s / "sz.json", "--out",
                                                                        s / "out"])),
        Case("models--unknown-argument", "models", lambda ctx, s: ["models", "--frobnicate"]),
        Case("demo--out-is-a-file", "demo",
             lambda ctx, s: _w(s / "o", "x", ["demo", "--out", s / "o", "--no-progress"])),
    ]
    return cases


# ---------------------------------------------------------------------------- captures and the rest


def _nss(s: Path, **kw) -> Path:
    import importlib.util  # the tests' capture writer, loaded by path: tests/ is no package

    spec = importlib.util.spec_from_file_location("capture_helpers", REPO / "tests" / "dataset" / "capture_helpers.py")
    helpers = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(helpers)
    helpers.write_nss_capture(s / "cap", **kw)
    return s / "cap"


def _nss_json(edit):
    def f(cap: Path):
        p = cap / "0000.json"
        m = json.loads(p.read_text())
        edit(m)
        p.write_text(json.dumps(m))
    return f


NSS_DAMAGES = {
    "json-garbage": lambda cap: (cap / "0000.json").write_text("{\"Version\": "),
    "json-binary": lambda cap: (cap / "0000.json").write_bytes(bytes(range(256))),
    "json-no-frames": _nss_json(lambda m: m.update(Frames=[])),
    "json-no-target-resolution": _nss_json(lambda m: m.pop("TargetResolution")),
    "json-missing": lambda cap: (cap / "0000.json").unlink(),
    "motion-folder-missing": lambda cap: shutil.rmtree(cap / "x2" / "motion"),
    "ground-truth-folder-missing": lambda cap: shutil.rmtree(cap / "ground_truth"),
    "color-empty-file": lambda cap: (cap / "x2" / "color" / "0000" / "0001.exr").write_bytes(b""),
    "color-wrong-size": lambda cap: shutil.copy(cap / "ground_truth" / "0000" / "0001.exr",
                                                cap / "x2" / "color" / "0000" / "0001.exr"),
}


def nss_case(damage: str) -> Case:
    def prepare(ctx, s):
        NSS_DAMAGES[damage](_nss(s))
        return ["data", "import", "nss", s / "cap", "--out", s / "out"]

    def left(s: Path):
        return f"{s / 'out'} left behind" if (s / "out").exists() else ""

    return Case(f"data-import-nss--{damage}", "data import", prepare, "error", left)


def more_cases() -> list[Case]:
    def nss_ok(ratio):
        def prepare(ctx, s):
            _nss(s, hr_size=(48, 24), ratios=(ratio,))
            return ["data", "import", "nss", s / "cap", "--out", s / "out"]
        return prepare

    return [
        *[nss_case(d) for d in NSS_DAMAGES],
        Case("data-import-nss--ratio-1_5", "data import", nss_ok("1_5"), "ok"),
        Case("data-import-nss--out-is-a-file", "data import",
             lambda ctx, s: _nss(s) and _w(s / "o", "x", ["data", "import", "nss", s / "cap", "--out", s / "o"])),
        Case("data-import-nss--capture-is-a-file", "data import",
             lambda ctx, s: _w(s / "cap", "x", ["data", "import", "nss", s / "cap", "--out", s / "out"])),
        Case("data-import-images--mapping-binary", "data import",
             lambda ctx, s: (s / "cap").mkdir() or _w(s / "m.yaml", bytes(range(256)), [
                 "data", "import", "images", s / "cap", "--mapping", s / "m.yaml", "--out", s / "out"])),
        Case("models--json-and-configs", "models", lambda ctx, s: ["models", "--json", "--configs"], "ok"),
        Case("models--positional-garbage", "models", lambda ctx, s: ["models", "mnss_x2"]),
        Case("demo--read-only-location", "demo", lambda ctx, s: ["demo", "--out", ctx["readonly"] / "d",
                                                                  "--no-progress"]),
        Case("demo--minutes-negative", "demo", lambda ctx, s: ["demo", "--out", s / "d", "--minutes", "-1",
                                                               "--no-progress"]),
        Case("demo--minutes-nan", "demo", lambda ctx, s: ["demo", "--out", s / "d", "--minutes", "nan",
                                                          "--no-progress"]),
        Case("stress--max-frames-0", "stress",
             lambda ctx, s: ["stress", "--models", ctx["ckpt"], "--data", ctx["data"], "--out", s / "out",
                             "--max-frames", 0, "--no-progress"]),
        Case("stress--out-is-a-file", "stress",
             lambda ctx, s: _w(s / "o", "x", ["stress", "--models", ctx["ckpt"], "--data", ctx["data"], "--out",
                                              s / "o", "--no-progress"])),
        Case("size--held-out-99", "size",
             lambda ctx, s: ["size", "--data", ctx["data"], "--held-out", 99, "--target", "psnr:10", "--out",
                             s / "out", "--no-progress"]),
        Case("size--budget-ms-negative", "size",
             lambda ctx, s: ["size", "--data", ctx["data"], "--target", "psnr:10", "--budget-ms", "-3", "--out",
                             s / "out", "--no-progress"]),
        Case("size--output-size-garbage", "size",
             lambda ctx, s: ["size", "--data", ctx["data"], "--target", "psnr:10", "--output-size", "big", "--out",
                             s / "out", "--no-progress"]),
        Case("size--steps-0", "size",
             lambda ctx, s: ["size", "--data", ctx["data"], "--target", "psnr:10", "--steps", 0, "--out",
                             s / "out", "--no-progress"]),
        Case("size--ladder-missing", "size",
             lambda ctx, s: ["size", "--data", ctx["data"], "--target", "psnr:10", "--ladder", s / "nope.yaml",
                             "--out", s / "out", "--no-progress"]),
        Case("report--budget-ms-nan", "report",
             lambda ctx, s: _w(s / "sz.json", "{}", ["report", "--size", s / "sz.json", "--budget-ms", "nan",
                                                     "--out", s / "out"])),
        Case("report--bench-a-directory", "report",
             lambda ctx, s: (s / "b").mkdir() or ["report", "--bench", s / "b", "--out", s / "out"]),
        Case("report--stress-binary", "report",
             lambda ctx, s: _w(s / "st.json", bytes(range(256)), ["report", "--stress", s / "st.json", "--out",
                                                                  s / "out"])),
        Case("eval--crops-is-a-file", "eval",
             lambda ctx, s: _w(s / "c", "x", ["eval", ctx["ckpt"], "--data", ctx["data"] / "pan", "--max-frames",
                                              2, "--crops", s / "c", "--no-progress"])),
        Case("eval--csv-read-only", "eval",
             lambda ctx, s: ["eval", ctx["ckpt"], "--data", ctx["data"] / "pan", "--max-frames", 2, "--csv",
                             ctx["readonly"] / "m.csv", "--no-progress"]),
        Case("emulate--compare-empty-dirs", "emulate",
             lambda ctx, s: (s / "a").mkdir() or (s / "b").mkdir() or ["emulate", "--compare", s / "a", s / "b"]),
        Case("emulate--no-bundle", "emulate", lambda ctx, s: ["emulate", "--data", ctx["data"], "--out", s / "o"]),
        Case("bench--devices-unknown", "bench",
             lambda ctx, s: ["bench", "--models", ctx["ckpt"], "--data", ctx["data"], "--devices", "nokia_3310",
                             "--out", s / "b.json", "--work", s / "w", "--quick", "--no-progress"]),
        Case("split--json-is-a-directory", "split",
             lambda ctx, s: (s / "j").mkdir() or ["split", ctx["ckpt"], "--device", "snapdragon_8_gen_1", "--json",
                                                  s / "j"]),
        Case("quantize--method-unknown", "quantize",
             lambda ctx, s: ["quantize", ctx["ckpt"], "--method", "guess", "--out", s / "out"]),
        Case("quantize--a16-negative", "quantize",
             lambda ctx, s: ["quantize", ctx["ckpt"], "--data", ctx["data"], "--a16", "-1", "--out", s / "out",
                             "--frames", 2, "--pipeline-frames", 0, "--no-progress"]),
        Case("export--checkpoint-without-quantize-dir", "export",
             lambda ctx, s: ["export", ctx["ckpt"], "--checkpoint", ctx["ckpt"], "--out", s / "out", "--resolution",
                             "64x48", "--data", ctx["data"], "--no-progress"]),
        Case("export--frames-0-with-sequence", "export",
             lambda ctx, s: ["export", ctx["ckpt"], "--out", s / "out", "--resolution", "64x48", "--data",
                             ctx["data"], "--sequence", ctx["data"], "--frames", 0, "--no-progress"]),
    ]


# ---------------------------------------------------------------------------- interrupted runs, two writers


def _w(path: Path, text, then):
    """Write ``text`` (str or bytes) to ``path``, then return ``then``."""
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return then


def _result(name, command, outcome, code, line, detail=""):
    return Result(name, command, outcome, code, line[:300], 0.0, detail)


def _interrupt(argv: list, cwd: Path, after: float) -> tuple[int | None, str]:
    p = subprocess.Popen([KIT, *map(str, argv)], cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(after)
    p.send_signal(signal.SIGINT)
    try:
        _, err = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        p.kill()
        _, err = p.communicate()
    return p.returncode, err


def sigint_case(name: str, command: str, argv_fn, after: float, rerun_fn, verify) -> Case:
    """SIGINT ``after`` seconds in, then rerun: the interruption prints no traceback, the rerun succeeds and
    ``verify(scratch)`` finds a whole output (no half-written file)."""

    def prepare(ctx, s):
        code, err = _interrupt(argv_fn(ctx, s), s, after)
        if code == 0:
            return _result(name, command, "corpus-error", code, "finished before SIGINT landed")
        if "Traceback" in err:
            return _result(name, command, "traceback", code, err.strip().splitlines()[-1])
        code2, err2, _ = run_sub(rerun_fn(ctx, s), s)
        if "Traceback" in err2:
            return _result(name, command, "traceback", code2, err2.strip().splitlines()[-1])
        if code2 != 0:
            return _result(name, command, "leftover", code2, "rerun after SIGINT failed: " + error_line(err2))
        problem = verify(ctx, s)
        if problem:
            return _result(name, command, "leftover", code2, problem)
        return _result(name, command, "handled", code2, f"SIGINT exit {code}, rerun ok")

    return Case(name, command, prepare, "ok")


def _verify_dataset(ctx, s):
    code, err, out = run_sub(["data", "check", s / "out"], s)
    return "" if code == 0 else f"data check after rerun: exit {code}: {(err or out).strip().splitlines()[:1]}"


def _verify_bundle(ctx, s):
    code, err, out = run_sub(["bundle", "check", s / "out"], s)
    return "" if code == 0 else f"bundle check after rerun: exit {code}: {(out or err).strip().splitlines()[:1]}"


def _verify_train(ctx, s):
    return "" if (s / "out" / "model.pt").is_file() else "no model.pt after rerun"


def two_writers_case(name: str, command: str, argv_fn, verify) -> Case:
    """Two processes writing the same output at once: one may refuse, neither may traceback, and what is left
    must be whole."""

    def prepare(ctx, s):
        argv = argv_fn(ctx, s)
        ps = [subprocess.Popen([KIT, *map(str, argv)], cwd=s, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True) for _ in range(2)]
        outs = [p.communicate(timeout=300) for p in ps]
        codes = [p.returncode for p in ps]
        errs = [e for _, e in outs]
        for e, c in zip(errs, codes):
            if "Traceback" in e:
                return _result(name, command, "traceback", c, e.strip().splitlines()[-1])
        if all(c != 0 for c in codes):
            return _result(name, command, "clear" if all(error_line(e) for e in errs) else "unclear", codes[0],
                           error_line(errs[0]))
        problem = verify(ctx, s)
        if problem:
            return _result(name, command, "leftover", 0, problem)
        refused = [error_line(e) for e, c in zip(errs, codes) if c != 0]
        return _result(name, command, "handled", 0, refused[0] if refused else "both succeeded, output whole")

    return Case(name, command, prepare, "ok")


def big_data(s: Path) -> Path:
    """A sequence big enough that a copy of it takes seconds."""
    from mnss_kit.dataset.synthetic import write_synthetic_sequence

    if not (s / "big").exists():
        write_synthetic_sequence(s / "big" / "seq", lr_size=(384, 288), frames=24, name="seq")
    return s / "big"


def process_cases() -> list[Case]:
    render = lambda ctx, s: ["render", "tiny_test", "--out", s / "out", "--set", "frames=3", "--no-progress"]  # noqa: E731
    render_long = lambda ctx, s: ["render", "tiny_test", "--out", s / "out", "--set", "frames=12",  # noqa: E731
                                  "--no-progress"]
    export = lambda ctx, s: ["export", ctx["ckpt"], "--out", s / "out", "--resolution", "64x48", "--data",  # noqa: E731
                             ctx["data"], "--golden-frames", 1, "--no-progress"]
    export_long = lambda ctx, s: ["export", ctx["ckpt"], "--out", s / "out", "--resolution", "64x48",  # noqa: E731
                                  "--golden-frames", 1, "--no-progress"]  # renders its own calibration frames
    export_over = lambda ctx, s: [*export(ctx, s), "--overwrite"]  # noqa: E731
    variant = lambda ctx, s: ["data", "variant", big_data(s), "--out", s / "out", "--apply", "ldr8"]  # noqa: E731
    variant_over = lambda ctx, s: [*variant(ctx, s), "--overwrite"]  # noqa: E731

    def train(ctx, s):
        return ["train", write_train_config(s, ctx["data"]), "--out", s / "out", "--no-progress"]

    def train_long(ctx, s):
        return [*train(ctx, s), "--set", "train.steps_per_epoch=2000"]

    def train_resume(ctx, s):
        return [*train(ctx, s), "--resume"] if (s / "out" / "last.pt").exists() else train(ctx, s)

    return [
        sigint_case("render--sigint-then-rerun", "render", render_long, 3.0, render_long, _verify_dataset),
        sigint_case("export--sigint-then-rerun", "export", export_long, 3.0, export_over, _verify_bundle),
        sigint_case("data-variant--sigint-then-rerun", "data variant", variant, 1.8, variant_over,
                    lambda ctx, s: ""),
        sigint_case("train--sigint-then-rerun", "train", train_long, 4.0, train_resume, _verify_train),
        two_writers_case("render--two-writers", "render", render, _verify_dataset),
        two_writers_case("export--two-writers", "export", export, _verify_bundle),
    ]


# ---------------------------------------------------------------------------- the corpus


def corpus() -> list[Case]:
    cases: list[Case] = []
    for command, damages in DATA_MATRIX.items():
        cases += [data_case(d, command) for d in damages]
    for command in ["render", "eval", "export", "emulate", "bench", "data check"]:
        cases += [scale_case(command, s) for s in SCALES]
    for command in ["bundle check", "emulate"]:
        cases += [bundle_case(d, command) for d in BUNDLE_DAMAGES]
    cases += bundle_extra_cases()
    for command in ["eval", "quantize", "export", "split", "finetune", "train --init"]:
        cases += [ckpt_case(d, command) for d in CKPT_DAMAGES]
    for command in OUTPUT_COMMANDS:
        cases += [output_case(command, k) for k in OUTPUT_KINDS]
    cases += [out_is_file_case(c) for c in ["render", "eval --json", "export", "emulate", "data variant",
                                            "quantize", "split --json", "train"]]
    cases += misc_cases()
    cases += fractional_ok_cases()
    cases += more_cases()
    cases += process_cases()
    return cases


OUTCOMES = ["clear", "handled", "traceback", "silent", "leftover", "unclear", "corpus-error"]


def tally(results: list[Result]) -> dict:
    table = {"cases": len(results)}
    for o in OUTCOMES:
        table[o] = sum(r.outcome == o for r in results)
    return table


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="JSON of every case and the tally")
    ap.add_argument("--only", default="", help="run only cases whose name holds this")
    ap.add_argument("--keep", action="store_true", help="keep the temp directory")
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s", stream=_Stderr())
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    root = Path(tempfile.mkdtemp(prefix="mnss_fault_corpus_"))
    start = time.time()
    try:
        ctx = make_context(root)
        cases = [c for c in corpus() if args.only in c.name]
        results = []
        for i, case in enumerate(cases, 1):
            r = run_case(case, ctx, root)
            results.append(r)
            print(f"[{i:3d}/{len(cases)}] {r.outcome:9s} {r.seconds:5.1f}s {case.name}: {r.line[:140]}",
                  file=sys.__stderr__, flush=True)
    finally:
        ro = root / "_inputs" / "readonly"
        if ro.exists():
            ro.chmod(0o755)
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)
    table = tally(results)
    per_command: dict[str, dict] = {}
    for r in results:
        per_command.setdefault(r.command, {o: 0 for o in ["cases", *OUTCOMES]})
        per_command[r.command]["cases"] += 1
        per_command[r.command][r.outcome] += 1
    Path(args.out).write_text(json.dumps({"tally": table, "per_command": per_command,
                                          "seconds": round(time.time() - start, 1),
                                          "cases": [r.__dict__ for r in results]}, indent=1, default=str))
    cols = ["cases", *OUTCOMES]
    print("| command | " + " | ".join(cols) + " |")
    print("|---" * (len(cols) + 1) + "|")
    for command, row in sorted(per_command.items()):
        print(f"| {command} | " + " | ".join(str(row[c]) for c in cols) + " |")
    print("| **total** | " + " | ".join(str(table[c]) for c in cols) + " |")
    print(f"{time.time() - start:.0f} s; JSON: {args.out}")
    for r in results:
        if r.outcome in ("traceback", "silent", "leftover", "unclear", "corpus-error"):
            print(f"  {r.outcome}: {r.name}: {r.line}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
