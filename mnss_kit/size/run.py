"""The size stage's entry, :func:`run_size` (``mnss-kit size``): train (or reuse) every rung of a
model-size ladder on a user's scene and evaluate it on held-out sequences.

Each rung is a model config (``mnss_kit/configs/models/``) trained for the same number of steps on
the same training sequences into ``OUT/runs/<config>/``; with ``seeds`` above 1 also with the
config's seed plus 1, 2, ... into ``OUT/runs/<config>_seed<seed>/``, and judged by the mean over
its seeds (one seed can move a short run by more than the rungs differ).  A rung whose ``model.pt`` was trained
with these settings is reused, a killed rung is resumed from its ``last.pt``, and ``size.json``
is rewritten atomically after every rung, so a killed ``mnss-kit size`` continues where it stopped.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import UserError
from ..fileio import atomic_write_json, check_format, json_safe, portable_path, read_json, sha256_file
from ..finetune.run import DEFAULT_MINUTES as FINETUNE_MINUTES, DETAIL_SHARE
from .choice import FORMAT, VERSION
from .select import Budget, Target, choose

log = logging.getLogger(__name__)
BASELINES = ("bicubic", "taau")
# a rung "CONFIG+detail": CONFIG's rung, then the detail branch of ``finetune --detail`` fitted on the
# training sequences for ``SizeRequest.detail_minutes`` (ntaau_lr, integer scales); "CONFIG+detailN"
# the same with a branch of width N
DETAIL = "+detail"
DETAIL_MINUTES = FINETUNE_MINUTES * DETAIL_SHARE  # the branch's fit in a fine-tune of the default budget


@dataclass
class SizeRequest:
    data: list[Path]  # the user's scene: sequence dirs or dirs of sequences
    targets: list[Target]
    out: Path
    test: list[Path] | None = None  # held-out sequences (default: the last ``held_out`` of ``data``)
    held_out: int = 1
    ladder: list[str] | None = None  # model config names (default: :func:`default_ladder` at the data's scale)
    overrides: list[str] = field(default_factory=list)  # ``--set`` for every rung (train.crop=16)
    steps: int = 2000  # training steps per rung, the same for every rung
    minutes: float | None = None  # wall-time cap per rung (a capped rung says so in its row)
    budget: Budget | None = None
    devices: list[str] | None = None  # device profiles estimated (default: every shipped one)
    output_size: tuple[int, int] = (1280, 720)  # HR size of the device estimates
    max_frames: int | None = None  # per held-out sequence
    scale: int | float | None = None  # a parsed --scale, which the data must be at (default: the data's)
    seeds: int = 1  # training runs per rung, judged by their mean
    detail_minutes: float = DETAIL_MINUTES  # a CONFIG+detail rung's branch fit, recording included
    progress: bool = True


def run_size(request: SizeRequest) -> dict:
    """Train and evaluate the ladder, choose a rung; returns the size document (also in ``OUT/size.json``)."""
    from ..ops.scale import check_data_scale_is
    from ..split.device import device_names

    train_seqs, test_seqs = split_sequences(request.data, request.test, request.held_out)
    scale = _common_scale(train_seqs + test_seqs)
    check_data_scale_is(scale, request.scale, ", ".join(str(d) for d in request.data))
    names = ladder_configs(request.ladder, scale, "--scale" if request.scale else "the data")
    devices = list(request.devices or device_names())
    settings = {
        "data": [portable_path(d) for d in request.data],
        "train_sequences": [portable_path(s) for s in train_seqs],
        "test_sequences": [portable_path(s) for s in test_seqs],
        "scale": scale, "overrides": list(request.overrides), "steps": request.steps, "minutes": request.minutes, "max_frames": request.max_frames,
        "devices": devices, "output_size": list(request.output_size), "seeds": request.seeds,
        "detail_minutes": request.detail_minutes,
    }
    doc = _resume(request.out / "size.json", settings)
    if not doc["baselines"]:
        log.info("evaluating %s on %d held-out sequence(s)", " and ".join(BASELINES), len(test_seqs))
        doc["baselines"] = _baselines(test_seqs, scale, request)
        atomic_write_json(request.out / "size.json", doc)
    runs_done = doc["rows"] if request.seeds == 1 else doc.setdefault("seed_runs", {})  # one run is the row itself
    for i, name in enumerate(names, 1):
        runs = []
        for k in range(request.seeds):
            log.info("rung %d/%d: %s%s", i, len(names), name, f", seed run {k + 1}/{request.seeds}" if request.seeds > 1 else "")
            checkpoint = train_rung(name, train_seqs, scale, request, k)
            digest = sha256_file(checkpoint)
            key = name if request.seeds == 1 else checkpoint.parent.name
            if (runs_done.get(key) or {}).get("checkpoint_sha256") != digest:
                runs_done[key] = evaluate_rung(name, checkpoint, digest, test_seqs, scale, devices, request)
                atomic_write_json(request.out / "size.json", doc)
            runs.append(runs_done[key])
        if request.seeds > 1:
            doc["rows"][name] = seed_mean(runs)
    return decide(doc, request.targets, request.budget, request.out)


SEED_MEANS = ("psnr", "ssim", "if_ssim", "temporal_error", "phase_offset")


def seed_mean(runs: list[dict]) -> dict:
    """One rung's row from its seed runs: the quality means, the best seed's checkpoint (what export
    takes), and each seed's quality under ``seeds``."""
    best = max(runs, key=lambda r: r["psnr"])
    row = {**best, **{k: sum(r[k] for r in runs) / len(runs) for k in SEED_MEANS if all(k in r for r in runs)}}
    row["seeds"] = [{"seed": r["seed"], "checkpoint": r["checkpoint"], **{k: r[k] for k in ("psnr", "ssim", "if_ssim")}}
                    for r in runs]
    return row


def decide(doc: dict, targets: list[Target], budget: Budget | None, out: Path) -> dict:
    """Record the targets, each rung's misses and the choice in ``doc`` and ``OUT/size.json``."""
    rows = sorted(doc["rows"].values(), key=lambda r: r["macs_per_pixel"])
    chosen, misses = choose(rows, targets, budget, doc["baselines"])
    for row in rows:
        row["misses"] = misses[row["config"]]
    doc["rows"] = {r["config"]: r for r in rows}
    doc["targets"] = [str(t) for t in targets]
    doc["budget"] = str(budget) if budget else None
    doc["choice"] = None if chosen is None else {k: chosen[k] for k in ("config", "checkpoint", "macs_per_pixel", "psnr", "if_ssim")}
    atomic_write_json(out / "size.json", doc)
    return doc


def split_sequences(data: list[Path], test: list[Path] | None, held_out: int) -> tuple[list[Path], list[Path]]:
    """``(training sequences, held-out sequences)``; the held-out ones are never trained on."""
    from ..dataset import format as fmt

    seqs = fmt.find_sequences(list(data))
    if test:
        tests = fmt.find_sequences(list(test))
        shared = {s.resolve() for s in seqs} & {t.resolve() for t in tests}
        if shared:
            raise UserError(f"{sorted(shared)[0]} is both in --data and in --test: held-out sequences must not be trained on")
        return seqs, tests
    if held_out < 1 or len(seqs) <= held_out:
        raise UserError(f"--data has {len(seqs)} sequence(s): holding out {held_out} leaves none to train on "
                        "(add sequences, lower --held-out or give --test)")
    return seqs[:-held_out], seqs[-held_out:]


def ladder_configs(names: list[str] | None, scale: int | float, what: str = "the data") -> list[str]:
    """The rungs' config names, by increasing MACs per pixel, each able to run at ``scale``: a config
    at it, or one of a family whose models run at any scale (trained at ``scale``,
    :func:`rung_experiment`); any other is refused in one line, ``what`` naming where the scale came from."""
    from ..model.run import config_rows

    rows = {r["name"]: r for r in config_rows()}
    names = names or default_ladder(rows, scale)
    unknown = [n for n in names if base_config(n) not in rows]
    if unknown:
        raise UserError(f"unknown model config '{base_config(unknown[0])}' (shipped: {', '.join(sorted(rows))}; "
                        f"CONFIG{DETAIL} adds a detail branch, CONFIG{DETAIL}N one of width N)")
    for name in (n for n in names if detail_width(n) is not None):
        if detail_width(name) < 1:
            raise UserError(f"rung '{name}': a detail branch needs a width of at least 1")
    for name in (n for n in names if rows[base_config(n)]["scale"] != scale):
        _check_runs_at(base_config(name), scale, what)
    macs = {n: rows[n]["macs_per_pixel"] if n in rows else _detail_rung_macs(n, scale) for n in names}
    if len(names) < 2:
        raise UserError(f"a ladder needs at least two model configs at x{scale}, got {len(names)}")
    return sorted(names, key=macs.get)


def base_config(name: str) -> str:
    """The model config a rung trains: ``name`` without its :data:`DETAIL` suffix (and width)."""
    head, found, width = name.rpartition(DETAIL)
    return head if found and (width == "" or width.isdigit()) else name


def detail_width(name: str) -> int | None:
    """The detail branch's width of rung ``name``: N for ``CONFIG+detailN``, ``finetune.detail.BRANCH``'s
    for ``CONFIG+detail``, None for a rung without a branch."""
    from ..finetune.detail import branch_settings

    base = base_config(name)
    if base == name:
        return None
    width = name[len(base) + len(DETAIL):]
    return branch_settings(int(width) if width else None)["detail_width"]


def _detail_rung_macs(name: str, scale: int | float) -> float:
    """MACs per pixel of rung ``CONFIG+detail[N]`` (refused in one line when CONFIG cannot take the branch)."""
    from ..config import to_dict
    from ..finetune.detail import branch_config, branch_settings, check_detail
    from ..model.config import load_model_config
    from ..model.families import build_model
    from ..model.macs import count_macs

    config = load_model_config(base_config(name))
    check_detail({"family": config.family, "scale": scale}, base_config(name), what=f"rung '{name}'")
    settings = branch_settings(detail_width(name))
    return count_macs(build_model(branch_config(to_dict(config), settings, source=f"rung '{name}'"))).total


def default_ladder(rows: dict[str, dict], scale: int | float) -> list[str]:
    """Every shipped config at ``scale``; at a scale none is shipped at (a quality mode such as 1.5),
    every shipped config of a family whose models run at any scale."""
    from ..model.config import load_model_config
    from ..train.run import takes_frame_scale

    return [n for n, r in rows.items() if r["scale"] == scale] or [n for n in rows if takes_frame_scale(load_model_config(n))]


def _check_runs_at(name: str, scale: int | float, what: str) -> None:
    """A one-line refusal of config ``name`` unless its models run at ``scale`` (``run_at_scale``'s rule)."""
    from ..model.config import load_model_config
    from ..model.families import build_model, run_at_scale

    run_at_scale(build_model(load_model_config(name)), scale, what=what, where=f"model config '{name}'")


def rung_experiment(name: str, train_seqs: list[Path], scale: int | float, request: SizeRequest):
    """The config ``name`` at ``scale`` set to train ``request.steps`` steps on exactly ``train_seqs``."""
    from ..train.config import load_experiment

    # the config's scale key: a config of a family that runs at any scale trains at the ladder's
    experiment, _ = load_experiment(name, [f"model.scale={scale}", *request.overrides])
    experiment.train.train_data = [str(s) for s in train_seqs]
    experiment.train.val_data = None  # the held-out sequences stay unseen, even as a monitor
    experiment.train.total_steps = request.steps
    experiment.train.time_budget_min = request.minutes
    experiment.data = None  # the user's data: nothing is rendered
    return experiment


def train_rung(name: str, train_seqs: list[Path], scale: int | float, request: SizeRequest, seed_run: int = 0) -> Path:
    """``OUT/runs/<name>/model.pt`` (``<name>_seed<seed>`` for the ``seed_run``-th run past the first):
    trained now, resumed, or reused when trained with these settings.  A ``CONFIG+detail`` rung is
    CONFIG's (trained as its own rung) with a detail branch fitted on ``train_seqs``."""
    from ..model.checkpoint import read_record
    from ..train.run import FINAL, LAST, train

    experiment = rung_experiment(base_config(name), train_seqs, scale, request)
    experiment.train.seed += seed_run
    run_dir = request.out / "runs" / (name if seed_run == 0 else f"{name}_seed{experiment.train.seed}")
    if name != base_config(name):
        return _fit_detail_rung(train_rung(base_config(name), train_seqs, scale, request, seed_run), train_seqs,
                                run_dir, request, experiment.train.threads, detail_width(name))
    final, last = run_dir / FINAL, run_dir / LAST
    if final.is_file():
        record, _ = read_record(final)
        if _finished(record) and _trained_as(record, experiment):
            log.info("reusing %s", final)
            return final
        if _finished(record) and not last.is_file():
            raise UserError(f"{final} was trained with other settings than this ladder's (remove it or choose another --out)")
    resume = last.is_file()
    if resume and not _trained_as(read_record(last)[0], experiment):
        raise UserError(f"{last} is a run with other settings than this ladder's (remove it or choose another --out)")
    return train(experiment, run_dir, resume=resume, progress=request.progress)


def _fit_detail_rung(base: Path, train_seqs: list[Path], run_dir: Path, request: SizeRequest, threads: int,
                     width: int) -> Path:
    """``run_dir/model.pt``: the rung at ``base`` with ``finetune --detail``'s branch, of ``width``,
    fitted on ``train_seqs`` on ``threads`` torch threads (the rungs' ``train.threads``)."""
    from ..finetune.detail import fit_detail
    from ..finetune.run import DEFAULT_WARMUP

    return fit_detail(base, train_seqs, run_dir, request.detail_minutes, DEFAULT_WARMUP, request.progress, threads, width)


def _finished(record: dict) -> bool:
    """Whether the run ended at its steps or its time cap (not by an interrupt, which ``--resume`` continues)."""
    return (record.get("training") or {}).get("stopped") in ("completed", "time_budget")


def _trained_as(record: dict, experiment) -> bool:
    """Whether a checkpoint ``record`` was trained on the same sequences for the same steps (a finished
    run that stopped at its time cap counts as finished)."""
    from ..config import to_dict
    from ..model.config import describes
    from ..train.run import BOOKKEEPING_KEYS

    saved, wanted = record.get("train") or {}, to_dict(experiment.train)
    same = all(saved.get(k) == v for k, v in wanted.items() if k not in BOOKKEEPING_KEYS)
    return same and describes(record.get("config"), experiment.model)


def evaluate_rung(name: str, checkpoint: Path, digest: str, test_seqs: list[Path], scale: int | float, devices: list[str],
                  request: SizeRequest) -> dict:
    """One ladder row: quality on the held-out sequences at ``scale``, cost, and training facts."""
    from ..bench.run import model_cost, quality
    from ..eval.methods import model_method
    from ..eval.loop import evaluate
    from ..model.checkpoint import load
    from ..model.families import family_of, run_at_scale

    model, record = load(checkpoint)
    run_at_scale(model, scale, what="the data", where=str(checkpoint))  # a --set model.scale may have trained it at another
    result = evaluate({"model": model_method(model)}, test_seqs, scale=scale, max_frames=request.max_frames,
                      progress=request.progress)
    training = record.get("training") or {}
    return json_safe({
        "config": name, "family": family_of(model).name, "seed": (record.get("train") or {}).get("seed"),
        **quality(result["methods"]["model"]),
        **model_cost(model, tuple(devices), tuple(request.output_size)),
        "steps": training.get("steps"), "train_s": training.get("wall_time_s"), "stopped": training.get("stopped"),
        "checkpoint": (checkpoint.relative_to(request.out)).as_posix(), "checkpoint_sha256": digest,
    })


def _baselines(test_seqs: list[Path], scale: int | float, request: SizeRequest) -> dict:
    from ..bench.run import quality
    from ..eval.baselines import baseline_methods
    from ..eval.loop import evaluate

    methods = {k: v for k, v in baseline_methods(scale).items() if k in BASELINES}
    result = evaluate(methods, test_seqs, scale=scale, max_frames=request.max_frames, progress=request.progress)
    return json_safe({name: quality(result["methods"][name]) for name in methods})


def _common_scale(seqs: list[Path]) -> int | float:
    from ..dataset import format as fmt

    scales = {fmt.read_meta(s).scale for s in seqs}
    if len(scales) != 1:
        raise UserError(f"the scene's sequences mix scales x{', x'.join(map(str, sorted(scales)))}: size one scale at a time")
    return scales.pop()


def _resume(path: Path, settings: dict) -> dict:
    """The size document at ``path`` when it was made with ``settings``, else a fresh one."""
    fresh = {"format": FORMAT, "version": VERSION, "settings": settings, "baselines": {}, "rows": {}, "choice": None,
             "note": "quality on held-out sequences never trained on; device_ms are estimates from the device profiles"}
    if not path.is_file():
        return fresh
    doc = read_json(path)
    check_format(doc, path, FORMAT, "version", VERSION, "a size file")
    if doc.get("settings") != settings:
        log.info("%s was made with other settings; evaluating afresh", path)
        return fresh
    return doc
