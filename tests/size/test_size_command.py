"""``mnss-kit size`` end to end on a tiny synthetic scene: a two-rung ladder trained for a few
steps, reused on a rerun, its choice taken by ``export``; and the user mistakes it refuses."""

from __future__ import annotations

import shutil

import pytest
import yaml

from mnss_kit.cli import main
from mnss_kit.dataset.synthetic import write_synthetic_sequence
from mnss_kit.fileio import read_json
from mnss_kit.model.checkpoint import read_record, resolve
from mnss_kit.size.run import ladder_configs

FAST = ["--steps", "3", "--set", "train.crop=16", "--set", "train.burn_in=2", "--set", "train.window=2",
        "--set", "train.batch_size=2", "--ladder", "mnss_x2_tiny", "mnss_x2_small", "--max-frames", "4", "--no-progress"]


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    root = tmp_path_factory.mktemp("size_scene")
    for name, cut in (("a", None), ("b", 5), ("held", None)):
        write_synthetic_sequence(root / "data" / name, name=name, lr_size=(32, 24), scale=2, frames=8, cut_at=cut)
    return root


@pytest.fixture(scope="module")
def sized(scene):
    out = scene / "size"
    assert main(["size", "--data", str(scene / "data"), "--target", "within:100", "--out", str(out), *FAST]) == 0
    return out


def test_size_trains_every_rung_and_writes_the_choice(sized, capsys):
    doc = read_json(sized / "size.json")
    assert doc["format"] == "mnss-kit-size" and doc["version"] == 1
    assert [r["config"] for r in doc["rows"].values()] == ["mnss_x2_tiny", "mnss_x2_small"]
    assert [s.split("/")[-1] for s in doc["settings"]["test_sequences"]] == ["held"]  # the last sequence is held out
    assert [s.split("/")[-1] for s in doc["settings"]["train_sequences"]] == ["a", "b"]
    for row in doc["rows"].values():
        assert row["steps"] == 3 and row["misses"] == []
        assert set(row["device_ms"]) and all(v > 0 for v in row["device_ms"].values())
        assert (sized / row["checkpoint"]).is_file()
    assert set(doc["baselines"]) == {"bicubic", "taau"}
    assert doc["choice"]["config"] == "mnss_x2_tiny"  # a loose target: the smallest rung
    assert (sized / "size.md").read_text().startswith("Chosen: **mnss_x2_tiny**")
    assert (sized / "size.png").stat().st_size > 0
    assert resolve(sized / "size.json") == sized / "runs" / "mnss_x2_tiny" / "model.pt"  # what export takes


def test_rerun_reuses_the_trained_rungs_and_applies_new_targets(scene, sized, tmp_path, capsys):
    out = tmp_path / "size"
    shutil.copytree(sized, out)
    stamps = {p: p.stat().st_mtime_ns for p in (out / "runs").glob("*/model.pt")}
    code = main(["size", "--data", str(scene / "data"), "--target", "psnr:99", "--out", str(out), *FAST])
    assert code == 1  # nothing meets 99 dB
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps  # reused, not retrained
    doc = read_json(out / "size.json")
    assert doc["choice"] is None and all(r["misses"] for r in doc["rows"].values())
    assert "no rung meets the targets" in capsys.readouterr().out
    with pytest.raises(Exception, match="no rung met the size targets"):
        resolve(out / "size.json")


def test_a_rung_trained_with_other_settings_is_not_taken_for_this_ladder(scene, sized, tmp_path, capsys):
    out = tmp_path / "size"
    shutil.copytree(sized, out)
    (out / "runs" / "mnss_x2_tiny" / "last.pt").unlink()
    args = ["size", "--data", str(scene / "data"), "--target", "within:1", "--out", str(out), *FAST]
    args[args.index("3")] = "4"  # another step count
    assert main(args) == 2
    assert "was trained with other settings" in capsys.readouterr().err


def test_seeds_train_each_rung_again_and_judge_it_by_the_mean(scene, sized, tmp_path, capsys):
    """--seeds 2 reuses each rung's first run, trains one more with the next seed, and takes the mean."""
    out = tmp_path / "size"
    shutil.copytree(sized, out)
    first = read_json(sized / "size.json")["rows"]
    stamps = {p: p.stat().st_mtime_ns for p in (out / "runs").glob("*/model.pt")}
    assert main(["size", "--data", str(scene / "data"), "--target", "within:100", "--out", str(out), "--seeds", "2", *FAST]) == 0
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps  # the first seed's runs are reused
    doc = read_json(out / "size.json")
    for name, row in doc["rows"].items():
        seeds = row["seeds"]
        assert [x["seed"] for x in seeds] == [0, 1]
        assert seeds[0]["psnr"] == pytest.approx(first[name]["psnr"])
        assert read_record(out / seeds[1]["checkpoint"])[0]["train"]["seed"] == 1
        assert row["psnr"] == pytest.approx((seeds[0]["psnr"] + seeds[1]["psnr"]) / 2)
        assert row["checkpoint"] == max(seeds, key=lambda x: x["psnr"])["checkpoint"]  # export takes the best seed
    assert "Each rung trained with 2 seeds" in (out / "size.md").read_text()


@pytest.mark.parametrize("extra, message", [
    (["--target", "within"], "expected within:DB"),
    (["--target", "within:1", "--budget-ms", "3"], "--budget-ms and --device go together"),
    (["--target", "within:1", "--budget-ms", "3", "--device", "no_such_phone"], "no_such_phone"),
    (["--target", "within:1", "--held-out", "3"], "leaves none to train on"),
    (["--target", "within:1", "--ladder", "mnss_x2_tiny"], "at least two model configs"),
    (["--target", "within:1", "--ladder", "mnss_x2_tiny", "mnss_x3"], "model config 'mnss_x3': the data is x2 but the model is x3"),
    (["--target", "within:1", "--ladder", "mnss_x2_tiny", "nope"], "unknown model config 'nope'"),
    (["--target", "within:1", "--ladder", "mnss_x2_tiny", "mnss_x2_small+detail"],
     "rung 'mnss_x2_small+detail': mnss_x2_small is a mnss model; only ntaau_lr models take a detail branch"),
    (["--target", "within:1", "--detail-minutes", "0"], "--detail-minutes must be positive"),
    (["--target", "within:1", "--ladder", "ntaau_lr_x2_tiny", "ntaau_lr_x2_tiny+detail0"],
     "rung 'ntaau_lr_x2_tiny+detail0': a detail branch needs a width of at least 1"),
    (["--target", "within:1", "--ladder", "ntaau_lr_x2_tiny", "ntaau_lr_x2_tiny+detailx"],
     "unknown model config 'ntaau_lr_x2_tiny+detailx'"),
])
def test_user_mistakes_are_one_line_errors(scene, tmp_path, capsys, extra, message):
    code = main(["size", "--data", str(scene / "data"), "--out", str(tmp_path / "o"), "--no-progress", *extra])
    err = capsys.readouterr().err
    assert code == 2 and message in err and "Traceback" not in err
    assert not (tmp_path / "o" / "size.json").exists()


def test_held_out_sequences_may_not_be_trained_on(scene, tmp_path, capsys):
    code = main(["size", "--data", str(scene / "data"), "--test", str(scene / "data" / "held"), "--target", "within:1",
                 "--out", str(tmp_path / "o"), "--no-progress"])
    assert code == 2 and "both in --data and in --test" in capsys.readouterr().err


def test_a_detail_rung_fits_a_branch_on_its_base_rung_and_is_reused(scene, tmp_path):
    """CONFIG+detail: CONFIG's rung trained once, then finetune --detail's branch fitted on the
    training sequences; it counts the branch's MACs, and a rerun reuses both."""
    from mnss_kit.fileio import sha256_file
    from mnss_kit.finetune.detail import BRANCH

    out = tmp_path / "size"
    ladder = ["--ladder", "ntaau_lr_x2_tiny", "ntaau_lr_x2_tiny+detail"]
    args = ["size", "--data", str(scene / "data"), "--target", "within:100", "--out", str(out), "--detail-minutes", "0.02",
            *FAST[:FAST.index("--ladder")], *ladder, *FAST[FAST.index("--max-frames"):]]
    assert main(args) == 0
    doc = read_json(out / "size.json")
    plain, detail = doc["rows"]["ntaau_lr_x2_tiny"], doc["rows"]["ntaau_lr_x2_tiny+detail"]
    record = read_record(out / detail["checkpoint"])[0]
    assert record["config"]["detail"] and record["config"]["detail_width"] == BRANCH["detail_width"]
    assert record["detail_fit"]["base_sha256"] == sha256_file(out / plain["checkpoint"]) and record["detail_fit"]["steps"] > 0
    assert detail["macs_per_pixel"] > plain["macs_per_pixel"] and detail["steps"] == plain["steps"] == 3
    assert doc["choice"]["config"] == "ntaau_lr_x2_tiny"
    gain = detail["psnr"] - plain["psnr"]
    assert f"its gain over CONFIG, seed by seed: ntaau_lr_x2_tiny+detail {gain:+.2f} dB" in (out / "size.md").read_text()
    stamps = {p: p.stat().st_mtime_ns for p in (out / "runs").glob("*/model.pt")}
    assert len(stamps) == 2 and main(args) == 0
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps


# -- --scale ----------------------------------------------------------------------------------------
FAST_1_5 = [*FAST[:FAST.index("--ladder")], "--ladder", "ntaau_lr_x2_tiny", "ntaau_lr_x2_small", *FAST[FAST.index("--max-frames"):]]


@pytest.fixture(scope="module")
def scene_1_5(tmp_path_factory):
    """Three tiny sequences of a scene rendered at 1.5 (32x18 -> 48x27)."""
    root = tmp_path_factory.mktemp("size_scene_x1.5")
    config = root / "scene.yaml"
    config.write_text(yaml.safe_dump({"version": 1, "defaults": {"scene": "arena", "frames": 6, "lr_size": [32, 18],
                                                                  "scale": 1.5, "jitter": "halton", "hr_samples": 1},
                                      "sequences": [{"name": n, "seed": s} for n, s in (("a", 1), ("b", 2), ("held", 3))]}))
    assert main(["render", str(config), "--out", str(root / "data"), "--no-progress"]) == 0
    return root


@pytest.mark.parametrize("value, message", [("0.5", "--scale 0.5 is outside"), ("1.0", "--scale 1 is outside"),
                                            ("nan", "finite"), ("9", "--scale 9 is outside")])
def test_bad_scales_are_refused_in_one_line(scene, tmp_path, capsys, value, message):
    code = main(["size", "--data", str(scene / "data"), "--target", "within:1", "--out", str(tmp_path / "o"),
                 "--scale", value, "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err and "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("extra, message", [
    (["--scale", "2"], "data is x1.5 but --scale is 2"),
    (["--ladder", "mnss_x2_tiny", "ntaau_lr_x2_tiny"],
     "model config 'mnss_x2_tiny': the data is x1.5, a fractional scale, and the mnss family takes integer scales only"),
    (["--scale", "1.5", "--ladder", "ntaau_lr_x2_tiny", "fusesr_x4_l"], "model config 'fusesr_x4_l': --scale is x1.5"),
])
def test_data_at_another_scale_and_rungs_that_cannot_run_at_it_are_refused_before_training(scene_1_5, tmp_path, capsys,
                                                                                             extra, message):
    code = main(["size", "--data", str(scene_1_5 / "data"), "--target", "within:1", "--out", str(tmp_path / "o"),
                 "--no-progress", *extra])
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err and "\n" not in err
    assert not (tmp_path / "o" / "runs").exists()


def test_the_default_ladder_at_a_quality_mode_is_the_family_that_runs_at_any_scale():
    assert ladder_configs(None, 1.5) == ["ntaau_lr_x2_tiny", "ntaau_lr_x2_small", "ntaau_lr_x2", "ntaau_lr_modes",
                                         "ntaau_lr_x2_large"]
    assert all(n.startswith("mnss_x2") for n in ladder_configs(["mnss_x2_tiny", "mnss_x2_small"], 2))


def test_a_ladder_at_1_5_trains_its_rungs_at_1_5_and_says_so(scene_1_5, tmp_path):
    out = tmp_path / "size"
    assert main(["size", "--data", str(scene_1_5 / "data"), "--scale", "1.5", "--target", "within:100", "--out", str(out),
                 *FAST_1_5]) == 0
    doc = read_json(out / "size.json")
    assert doc["settings"]["scale"] == 1.5 and set(doc["baselines"]) == {"bicubic", "taau"}
    assert list(doc["rows"]) == ["ntaau_lr_x2_tiny", "ntaau_lr_x2_small"]
    assert all(read_record(out / row["checkpoint"])[0]["scale"] == 1.5 for row in doc["rows"].values())
    assert "At x1.5: trained 3 steps per rung" in (out / "size.md").read_text()


def test_detail_rungs_of_several_widths_are_a_ladder_by_their_cost():
    """CONFIG+detailN: a branch of width N, ordered among the rungs by its MACs (CONFIG+detail is BRANCH's width)."""
    from mnss_kit.finetune.detail import BRANCH
    from mnss_kit.size.run import base_config, detail_width

    rungs = ["ntaau_lr_x2+detail", "ntaau_lr_x2+detail8", "ntaau_lr_x2", "ntaau_lr_x2+detail16"]
    assert ladder_configs(rungs, 2) == ["ntaau_lr_x2", "ntaau_lr_x2+detail8", "ntaau_lr_x2+detail16", "ntaau_lr_x2+detail"]
    assert [detail_width(n) for n in rungs] == [BRANCH["detail_width"], 8, None, 16]
    assert {base_config(n) for n in rungs} == {"ntaau_lr_x2"}
