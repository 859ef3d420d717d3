"""Fault injection through the CLI: bad output paths, damaged caches, killed runs' leftovers, odd sizes.

Each case runs ``mnss_kit.cli.main`` in-process and asserts what a user sees:
a non-zero exit, one line on stderr naming the path, no traceback, the
failure before any expensive work, and nothing partial or stale left behind.
"""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pytest
import yaml

from mnss_kit.cli import main

REPO = Path(__file__).resolve().parents[2]
TINY_MODEL = {"family": "mnss", "scale": 2, "recon_width": 8, "recon_layers": 2, "aa_width": 4, "aa_layers": 1}

# (command, kind of output, argv with {out} for the output path and {data}, {ckpt}, {config} for inputs)
OUTPUT_CASES = {
    "render": ["render", "tiny", "--out", "{out}", "--no-progress"],
    "data cache": ["data", "cache", "{data}", "--cache-dir", "{out}"],
    "train --out": ["train", "{config}", "--out", "{out}", "--no-progress"],
    "train log_dir": ["train", "{config}", "--out", "{scratch}/run", "--set", "train.log_dir={out}", "--no-progress"],
    "eval --json": ["eval", "{ckpt}", "--data", "{data}", "--json", "{out}", "--no-progress"],
    "eval --csv": ["eval", "{ckpt}", "--data", "{data}", "--csv", "{out}", "--no-progress"],
    "eval --crops": ["eval", "{ckpt}", "--data", "{data}", "--crops", "{out}", "--no-progress"],
    "quantize --out": ["quantize", "{ckpt}", "--data", "{data}", "--out", "{out}", "--no-progress"],
    "split --json": ["split", "{ckpt}", "--device", "snapdragon_8_gen_1", "--json", "{out}"],
    "export --out": ["export", "{ckpt}", "--out", "{out}", "--resolution", "64x48", "--data", "{data}", "--no-progress"],
    "emulate --out": ["emulate", "{scratch}/bundle", "--data", "{data}", "--out", "{out}", "--no-progress"],
    "emulate --json": ["emulate", "--compare", "{scratch}/a", "{scratch}/b", "--json", "{out}"],
    "demo --out": ["demo", "--out", "{out}", "--no-progress"],
}
# functions that start each command's real work: none may run before the output check
WORK = [
    ("mnss_kit.model.checkpoint", "load"),
    ("mnss_kit.render.run", "render_dataset"),
    ("mnss_kit.dataset.cache", "prepare_caches"),
    ("mnss_kit.train.run", "train"),
    ("mnss_kit.eval.loop", "evaluate"),
    ("mnss_kit.split.plan", "split_model"),
    ("mnss_kit.export.run", "export"),
    ("mnss_kit.emulate.frame_loop", "Emulator"),
    ("mnss_kit.emulate.compare", "compare_paths"),
    ("mnss_kit.demo.Steps", "run"),
]
IMPORTS_WORK = ("mnss_kit.dataset.loader", "mnss_kit.emulate.run")  # bind names of WORK at import time


@pytest.fixture(scope="module")
def tiny_ckpt(tmp_path_factory) -> Path:
    import torch

    from mnss_kit.model import checkpoint
    from mnss_kit.model.config import load_model_config
    from mnss_kit.model.families import build_model, randomise_convs

    torch.manual_seed(0)
    model = randomise_convs(build_model(load_model_config("mnss_x2_tiny")).eval())
    return checkpoint.save(tmp_path_factory.mktemp("faults_model") / "tiny.pt", model, {"jitter_pattern": "grid"})


@pytest.fixture
def data(synthetic_dataset, tmp_path) -> Path:
    return Path(shutil.copytree(synthetic_dataset, tmp_path / "data", ignore=shutil.ignore_patterns(".cache")))


def write_config(path: Path, data: Path, **train) -> Path:
    section = {"train_data": str(data), "window": 3, "batch_size": 1, "crop": 12, "epochs": 1, "steps_per_epoch": 2,
               "gt_history_epochs": 0, "bptt": 2, "threads": 1, "log_every": 1, "checkpoint_every": 1, "val_every": 0,
               "cache_dir": str(path.parent / "cache"), **train}
    path.write_text(yaml.safe_dump({"schema": 1, "model": dict(TINY_MODEL), "train": section}))
    return path


def fill(argv: list[str], **values) -> list[str]:
    return [a.format(**values) for a in argv]


def tree(root: Path) -> set[str]:
    return {p.relative_to(root).as_posix() for p in root.rglob("*")}


def one_error_line(capsys, path: Path) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if "error:" in line]
    assert len(lines) == 1, err
    assert str(path) in lines[0], lines[0]
    return lines[0]


@pytest.fixture
def no_work(monkeypatch):
    """Make every command's real work fail the test if it starts."""
    import importlib

    def started(*args, **kwargs):
        raise AssertionError("the command started its work before checking its output path")

    for module in IMPORTS_WORK:  # imported first, so that they keep the real functions after the test
        importlib.import_module(module)
    for module, name in WORK:
        owner, _, attr = f"{module}.{name}".rpartition(".")
        try:
            target = importlib.import_module(owner)
        except ModuleNotFoundError:  # a class attribute: module.Class.method
            mod, _, cls = owner.rpartition(".")
            target = getattr(importlib.import_module(mod), cls)
        monkeypatch.setattr(target, attr, started)


def unwritable(monkeypatch, where: Path, fault: str) -> None:
    """Make directory ``where`` unwritable as root sees it: permission bits (os.access) or a read-only mount."""
    if fault == "no permission":
        real_access = os.access
        monkeypatch.setattr(os, "access", lambda p, mode, **kw: False if Path(p) == where else real_access(p, mode, **kw))
    else:
        real_tempfile = tempfile.TemporaryFile

        def read_only(*args, dir=None, **kwargs):
            if dir is not None and Path(dir) == where:
                raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(dir))
            return real_tempfile(*args, dir=dir, **kwargs)

        monkeypatch.setattr(tempfile, "TemporaryFile", read_only)


@pytest.mark.parametrize("fault", ["parent is a file", "no permission", "read-only mount"])
@pytest.mark.parametrize("case", list(OUTPUT_CASES))
def test_an_unwritable_output_fails_first_with_one_line(case, fault, tmp_path, data, tiny_ckpt, no_work, monkeypatch, capsys):
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    config = write_config(tmp_path / "tiny.yaml", data)
    if fault == "parent is a file":
        blocker = scratch / "file"
        blocker.write_text("a file, not a directory")
        out = blocker / "sub" / "out"
    else:
        blocker = scratch / "locked"
        blocker.mkdir()
        out = blocker / "out"
        unwritable(monkeypatch, blocker, fault)
    before = tree(tmp_path)
    code = main(fill(OUTPUT_CASES[case], out=out, data=data, ckpt=tiny_ckpt, config=config, scratch=scratch))
    assert code == 2
    line = one_error_line(capsys, out)
    assert str(blocker) in line
    assert tree(tmp_path) == before  # nothing partial, no staging left


def test_atomic_writes_report_a_full_disk_as_one_line_and_leave_nothing(tmp_path, monkeypatch):
    from mnss_kit.errors import UserError
    from mnss_kit.fileio import atomic_directory, atomic_write_json

    def disk_full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with monkeypatch.context() as m:
        m.setattr(os, "fsync", disk_full)
        with pytest.raises(UserError, match=rf"cannot write {tmp_path / 'a.json'}: No space left on device"):
            atomic_write_json(tmp_path / "a.json", {"x": 1})
    with pytest.raises(UserError, match=rf"cannot write {tmp_path / 'bundle'}: No space left on device"):
        with atomic_directory(tmp_path / "bundle") as staging:
            (staging / "half").write_bytes(b"x")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    (tmp_path / "a").write_text("a file")
    with pytest.raises(UserError, match=rf"cannot write {tmp_path / 'a' / 'b.json'}: "):
        atomic_write_json(tmp_path / "a" / "b.json", {})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a"]  # no temporary file, no staging directory


# --- leftovers of killed runs -------------------------------------------------------------------

KILLED_WRITER = {  # a real atomic write of OUT, killed (SIGKILL) half way: what a killed command leaves
    "directory": "with atomic_directory(out) as staging:\n    (staging / 'half.bin').write_bytes(b'x' * 1000)\n    kill()",
    "merge": "with atomic_directory(out, merge=True) as staging:\n    (staging / 'half.png').write_bytes(b'x')\n    kill()",
    "file": "with atomic_output_path(out) as tmp:\n    tmp.write_bytes(b'partial')\n    kill()",
}


def killed_run_leftover(out: Path, writer: str) -> Path:
    """Run a toolkit writer of ``out`` in a process that is killed mid-write; returns what it left."""
    script = textwrap.dedent("""
        import os, signal, sys
        from pathlib import Path
        from mnss_kit.fileio import atomic_directory, atomic_output_path
        out = Path(sys.argv[1])
        def kill():
            os.kill(os.getpid(), signal.SIGKILL)
    """) + KILLED_WRITER[writer] + "\n"
    before = set(out.parent.iterdir()) if out.parent.exists() else set()
    proc = subprocess.run([sys.executable, "-c", script, str(out)], env={**os.environ, "PYTHONPATH": str(REPO)})
    assert proc.returncode == -9
    (left,) = set(out.parent.iterdir()) - before
    assert left.name.startswith(f".{out.name}.")
    return left


def live_run_leftover(out: Path) -> Path:
    """A staging directory named as a run that is still going on (this process) would name it."""
    path = out.parent / f".{out.name}.staging.{os.getpid()}.abcd1234"
    path.mkdir(parents=True)
    return path


STOPPED = ("export", "emulate", "quantize")  # these reruns only have to start: stopped at their first real step
LEFTOVER_CASES = {  # command -> (argv, output, how it was written)
    "export": (["export", "{ckpt}", "--out", "{out}", "--resolution", "64x48", "--data", "{data}"], "bundle", "directory"),
    "emulate": (["emulate", "{scratch}/bundle", "--data", "{data}", "--out", "{out}"], "emulated", "directory"),
    "quantize": (["quantize", "{ckpt}", "--data", "{data}", "--out", "{out}"], "int8", "directory"),
    "eval --crops": (["eval", "none", "--data", "{data}", "--crops", "{out}", "--max-frames", "3"], "crops", "merge"),
    "eval --json": (["eval", "none", "--data", "{data}", "--json", "{out}", "--max-frames", "3"], "eval.json", "file"),
    "train": (["train", "{config}", "--out", "{scratch}/run"], "run/last.pt", "file"),
}


@pytest.mark.parametrize("case", list(LEFTOVER_CASES))
def test_the_next_run_removes_a_killed_runs_leftovers(case, tmp_path, data, tiny_ckpt, monkeypatch, caplog):
    argv, name, writer = LEFTOVER_CASES[case]
    scratch = tmp_path / "scratch"
    out = scratch / name
    killed = killed_run_leftover(out, writer)
    running = live_run_leftover(out)
    config = write_config(tmp_path / "tiny.yaml", data)
    if case in STOPPED:
        from mnss_kit.errors import UserError

        def stop(*args, **kwargs):
            raise UserError("stopped after the output check")

        monkeypatch.setattr("mnss_kit.model.checkpoint.load", stop)
        monkeypatch.setattr("mnss_kit.emulate.frame_loop.Emulator", stop)
    with caplog.at_level("INFO", logger="mnss_kit.fileio"):
        code = main(fill(argv, out=out, data=data, ckpt=tiny_ckpt, scratch=scratch, config=config) + ["--no-progress"])
    assert code == (2 if case in STOPPED else 0)
    assert not killed.exists()
    assert running.exists()  # a concurrent run's staging is left alone
    (line,) = [r.getMessage() for r in caplog.records if "leftover" in r.getMessage()]
    assert killed.name in line and running.name not in line
    if case == "eval --crops":
        assert list(out.glob("*.png")) and not list(out.glob(".*"))


def test_a_killed_cache_build_leaves_nothing_after_the_next_build(data, tmp_path, caplog):
    from mnss_kit.dataset.cache import SequenceCache

    entry = SequenceCache(data / "pan", tmp_path / "cache")
    entry.dir.mkdir(parents=True)
    killed = killed_run_leftover(entry.path("lr", "motion"), "file")
    with caplog.at_level("INFO", logger="mnss_kit.fileio"):
        assert main(["data", "cache", str(data / "pan"), "--cache-dir", str(tmp_path / "cache")]) == 0
    assert not killed.exists()
    assert not [p for p in entry.dir.iterdir() if p.name.startswith(".")]
    assert any(killed.name in r.getMessage() for r in caplog.records)


def test_crops_of_a_failed_eval_are_not_left(data, tmp_path, monkeypatch):
    from mnss_kit.eval import loop as eval_loop

    real = eval_loop._run_sequence
    calls = []

    def fail_on_second(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(eval_loop, "_run_sequence", fail_on_second)
    assert main(["eval", "none", "--data", str(data), "--crops", str(tmp_path / "crops"), "--no-progress"]) == 130
    assert not (tmp_path / "crops").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".crops")]


# --- a damaged dataset cache ----------------------------------------------------------------------

def test_training_rebuilds_a_truncated_cache_file(data, tmp_path, capsys, caplog):
    config = write_config(tmp_path / "tiny.yaml", data)
    assert main(["data", "cache", str(data), "--cache-dir", str(tmp_path / "cache")]) == 0
    (color,) = [p for p in (tmp_path / "cache").rglob("lr_color.npy") if "pan-" in str(p) and "pan_cut" not in str(p)]
    good = color.stat().st_size
    with open(color, "r+b") as f:
        f.truncate(good // 3)
    with caplog.at_level("WARNING", logger="mnss_kit.dataset.cache"):
        assert main(["train", str(config), "--out", str(tmp_path / "run"), "--no-progress"]) == 0
    assert "Traceback" not in capsys.readouterr().err
    assert color.stat().st_size == good
    (line,) = [r.getMessage() for r in caplog.records if "damaged" in r.getMessage()]
    assert str(color) in line


# --- smaller ones -----------------------------------------------------------------------------------

def test_split_and_export_refuse_a_size_that_does_not_divide_by_the_scale_with_one_message(tiny_ckpt, tmp_path, capsys):
    assert main(["split", str(tiny_ckpt), "--device", "snapdragon_8_gen_1", "--resolution", "7x5"]) == 2
    split_line = capsys.readouterr().err.strip()
    assert main(["export", str(tiny_ckpt), "--out", str(tmp_path / "b"), "--resolution", "7x5", "--no-progress"]) == 2
    export_line = capsys.readouterr().err.strip()
    assert split_line.split("error: ")[1] == export_line.split("error: ")[1]
    assert "7x5 is not a multiple of the model's scale 2" in split_line
    assert not (tmp_path / "b").exists()


def test_a_fresh_run_starts_with_clean_events_and_a_resumed_run_keeps_them(data, tmp_path, caplog):
    config = write_config(tmp_path / "tiny.yaml", data)
    logs = tmp_path / "run" / "logs"
    logs.mkdir(parents=True)
    killed = logs / "events.out.tfevents.1.host.killed"
    killed.write_bytes(b"events of a killed run")
    with caplog.at_level("INFO", logger="mnss_kit.train.summaries"):
        assert main(["train", str(config), "--out", str(tmp_path / "run"), "--no-progress"]) == 0
    assert not killed.exists()
    assert any("removed 1 TensorBoard event file" in r.getMessage() for r in caplog.records)
    first = set(logs.glob("events.out.tfevents.*"))
    assert first
    assert main(["train", str(config), "--out", str(tmp_path / "run"), "--resume", "--no-progress"]) == 0
    assert first < set(logs.glob("events.out.tfevents.*"))


def test_more_threads_than_cores_are_warned_about(caplog):
    from mnss_kit.train.distributed import World, cpu_threads

    cores = os.cpu_count() or 1
    with caplog.at_level("WARNING", logger="mnss_kit.train.distributed"):
        assert cpu_threads(World(), cores) == cores
        assert not caplog.records
        assert cpu_threads(World(), 999) == 999
    (record,) = caplog.records
    assert "train.threads=999" in record.getMessage() and f"{cores} CPU core" in record.getMessage()
