"""scripts/heldout_results.py's documents: the targets name each miss with its numbers, and the
README's mean-PSNR table is replaced between its markers, the text around it kept."""

from __future__ import annotations

from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "heldout_results.py"


def quality(psnr: float, if_ssim: float = 0.99) -> dict:
    return {"psnr": psnr, "ssim": 0.95, "if_ssim": if_ssim, "temporal_error": 0.01, "phase_offset": 0.1}


def results() -> dict:
    per = {"seq_a": {"net": quality(31.0), "fast": quality(30.6), "taau": quality(30.0), "bicubic": quality(29.0)},
           "seq_b": {"net": quality(32.0, 0.98), "fast": quality(31.5), "taau": quality(31.5, 0.985), "bicubic": quality(30.0)}}
    means = {"net": quality(31.5), "fast": quality(31.05), "taau": quality(30.75), "bicubic": quality(29.5)}
    return {"labels": ["net", "fast"], "frames": 4, "sets": {"unseen_x2": {"grid": {"methods": means, "sequences": per}}}}


def test_checks_state_each_target_with_its_numbers(script):
    lines = script.checks(results())
    assert lines[0].startswith("- `unseen_x2` / grid: net 31.50 dB, TAAU 30.75 (+0.75, target +1.0: missed)")
    assert lines[0].endswith("floors missed on seq_b (if_ssim 0.9800 < TAAU 0.9850 - 0.002)")
    assert "over bicubic +2.00 dB (target +4.0: missed)" in lines[1]
    assert "  - fast 31.05 dB against TAAU 30.75 (beats it)" == lines[2]


def test_the_floors_allow_ssim_slack_and_hold_psnr_to_the_better_baseline(script):
    per = {"net": quality(30.2, 0.9985), "taau": quality(30.0, 0.9999), "bicubic": quality(30.5)}
    assert script.floor_breaches("s", per, "net") == ["s (psnr 30.20 < best baseline 30.50 - 0.1)"]
    per["bicubic"] = quality(30.25)
    per["net"]["ssim"] = 0.9479  # TAAU's 0.95 - 0.0021
    assert script.floor_breaches("s", per, "net") == ["s (ssim 0.9479 < TAAU 0.9500 - 0.002)"]


def fake_costs(doc: dict) -> dict:
    return {"net": {"device_ms": {"phone_a": 2.5, "phone_b": 3.25}}, "fast": {"device_ms": {"phone_a": 1.0, "phone_b": 1.5}}}


def test_the_readme_table_is_replaced_between_its_markers(script, tmp_path, monkeypatch):
    readme = tmp_path / "README.md"
    start, end = script.README_BLOCK
    readme.write_text(f"intro\n\n{start}\n| old | table |\n{end}\n\nafter\n")
    monkeypatch.setattr(script, "README", readme)
    monkeypatch.setattr(script, "model_costs", fake_costs)
    script.update_readme(results())
    text = readme.read_text()
    assert "| old | table |" not in text
    assert text.startswith("intro\n\n" + start + "\n| set / inputs | `net` | `fast` | taau | bicubic |")
    assert "| `unseen_x2`, grid | 31.50 | 31.05 | 30.75 | 29.50 |\n| est. ms at 1280x720, phone_a | 2.50 | 1.00 | | |\n" in text
    assert "| est. ms at 1280x720, phone_b | 3.25 | 1.50 | | |\n" + end + "\n\nafter\n" in text


def test_a_readme_without_markers_is_left_alone(script, tmp_path, monkeypatch, capsys):
    readme = tmp_path / "README.md"
    readme.write_text("no block here\n")
    monkeypatch.setattr(script, "README", readme)
    script.update_readme(results())
    assert readme.read_text() == "no block here\n"
    assert "no <!-- heldout-means" in capsys.readouterr().err


def test_results_of_another_checkpoint_under_the_same_name_are_dropped(script, tmp_path, monkeypatch):
    monkeypatch.setattr(script, "RESULTS", tmp_path / "heldout_results.json")
    doc = dict(results(), models=["net", "fast"], digests=["a1", "b1"], frames=script.FRAMES)
    script.atomic_write_json(script.RESULTS, doc)
    assert script.read_results(["net", "fast"], ["a1", "b1"])["sets"] == doc["sets"]
    assert script.read_results(["net", "fast"], ["a2", "b1"])["sets"] == {}


def test_a_results_file_from_before_the_grid_rename_still_renders(script, tmp_path, monkeypatch):
    """Results written when the grid jitter variant was called mnss read as grid, for a resumed run
    and for --doc-only alike."""
    monkeypatch.setattr(script, "RESULTS", tmp_path / "heldout_results.json")
    doc = dict(results(), models=["net", "fast"], digests=["a1", "b1"], frames=script.FRAMES)
    old = dict(doc, sets={"unseen_x2": {"mnss": doc["sets"]["unseen_x2"]["grid"]}})
    script.atomic_write_json(script.RESULTS, old)
    assert script.read_results(["net", "fast"], ["a1", "b1"])["sets"] == doc["sets"]
    loaded = script.load_results(script.RESULTS)
    assert loaded["sets"] == doc["sets"]
    assert script.checks(loaded) == script.checks(results())


def test_the_doc_shows_the_reference_steadiness_where_measured(script, monkeypatch):
    doc = results()
    doc["sets"]["unseen_x2"]["grid"]["reference_if_ssim"] = {"seq_a": 0.9971}
    written = {}
    monkeypatch.setattr(script, "atomic_write_text", lambda path, text: written.setdefault("text", text))
    monkeypatch.setattr(script, "shown_crops", lambda doc: {})
    monkeypatch.setattr(script, "cost_section", lambda doc: [])
    script.write_doc(doc)
    text = written["text"]
    assert "| seq_a | 31.00 / 0.9900 | 30.60 / 0.9900 | 30.00 / 0.9900 | 29.00 / 0.9900 | 0.9971 |" in text
    assert "| seq_b | 32.00 / 0.9800 | 31.50 / 0.9900 | 31.50 / 0.9850 | 30.00 / 0.9900 |  |" in text


def test_a_miss_is_not_rounded_up_to_its_target(script):
    assert script._margin(0.9991, 1.0) == "+0.999"
    assert script._margin(1.004, 1.0) == "+1.00"
    assert script._margin(0.75, 1.0) == "+0.75"


def test_the_cost_table_and_chart_come_from_each_models_cost(script, tmp_path, monkeypatch):
    moved = {"phone_a": {"in": 5.75, "out": 8.0}, "phone_b": {"in": 0.0, "out": 0.0}}
    costs = {"net": {"macs_per_pixel": 2871.5, "device_ms": {"phone_a": 6.391, "phone_b": 68.9}, "boundary_bytes_per_pixel": moved},
             "fast": {"macs_per_pixel": 1429.0, "device_ms": {"phone_a": 5.06, "phone_b": 34.3}, "boundary_bytes_per_pixel": moved}}
    monkeypatch.setattr(script, "model_costs", lambda doc: costs)
    monkeypatch.setattr(script, "COST_CHART", tmp_path / "results" / "psnr_vs_macs.png")
    monkeypatch.setattr(script, "DOC", tmp_path / "results.md")
    lines = script.cost_section(results())
    assert "| model | MACs/px | phone_a ms (est.) (B/px in / out) | phone_b ms (est.) (B/px in / out) |" in lines
    assert "| `net` | 2,872 | 6.39 (5.75 / 8) | 68.90 (0 / 0) |" in lines
    assert "![mean PSNR against MACs per pixel](results/psnr_vs_macs.png)" in lines
    assert (tmp_path / "results" / "psnr_vs_macs.png").read_bytes().startswith(b"\x89PNG")


def test_a_models_cost_is_counted_from_its_architecture(script):
    costs = script.model_costs({"models": ["ntaau_x2_fast"], "labels": ["ntaau_x2_fast"]})
    assert round(costs["ntaau_x2_fast"]["macs_per_pixel"]) == 1429
    assert all(ms > 0 for ms in costs["ntaau_x2_fast"]["device_ms"].values())


def test_the_boundary_bytes_are_the_npus_tensors_per_output_pixel(script):
    """ntaau_lr_x2's NPU reads 8 int8 values and writes 6 per LR pixel, a quarter of an HR pixel at
    x2: 2 bytes in and 1.5 out per HR pixel where the NPU runs it, none where the GPU does all."""
    moved = script.model_costs({"models": ["ntaau_lr_x2"], "labels": ["lr"]})["lr"]["boundary_bytes_per_pixel"]
    assert moved["snapdragon_8_gen_1"] == {"in": 2.0, "out": 1.5}
    assert moved["helio_g99"] == {"in": 0.0, "out": 0.0}
