"""The figure and foliage scenarios: listed by ``mnss-kit stress``, rendered from the garden, the
foliage strafe cut once, the figure crossing seen from a still camera."""

from mnss_kit.render.camera import CameraPath
from mnss_kit.render.config import load_render_config, resolve_asset
from mnss_kit.stress import command
from mnss_kit.stress.scenarios import DATA_CONFIG, SCENARIOS, scenario

NEW = ("figure_crossing", "foliage_strafe_cut")


def test_the_figure_and_foliage_scenarios_are_listed_and_rendered_from_the_garden():
    cfg = load_render_config(DATA_CONFIG)
    by_name = {s.name: s for s in cfg.sequences}
    for name in NEW:
        assert scenario(name) in SCENARIOS and by_name[name].scene == "garden"
    assert "figures" in command.HELP and "foliage" in command.HELP


def camera(name: str) -> tuple[CameraPath, float]:
    cfg = load_render_config(DATA_CONFIG)
    seq = next(s for s in cfg.sequences if s.name == name)
    return CameraPath.load(resolve_asset(seq.camera, cfg, "camera path")), seq.frames / seq.fps


def test_the_foliage_strafe_cuts_once_mid_sequence_and_the_figure_camera_holds_still():
    path, duration = camera("foliage_strafe_cut")
    assert len(path.cut_times) == 1 and 0.25 * duration < path.cut_times[0] < 0.75 * duration
    still, duration = camera("figure_crossing")
    assert not still.cut_times
    assert (still.state(0.0).position == still.state(duration).position).all()


def test_a_model_below_bicubic_on_disoccluded_pixels_is_named_in_the_table():
    from mnss_kit.stress.verdict import losses_to, markdown

    def stats(psnr, disocclusion):
        return {"psnr": psnr, "ssim": 0.9, "if_ssim": 0.99, "temporal_error": 0.01, "disocclusion_psnr": disocclusion,
                "disocclusion_l1": 0.05, "disoccluded_pixels": 100, "warmup_frames": 1, "frames_to_recover": []}

    methods = {"model": stats(32.6, 22.9), "bicubic": stats(30.1, 25.7), "taau": stats(31.2, 20.3)}
    doc = {"methods": list(methods), "settings": {"recovery_tolerance_db": 0.5}, "not_covered": {},
           "scenarios": {"figure_crossing": {"case": "figures", "methods": methods}}}
    assert losses_to(doc, "model", "taau") == []
    assert losses_to(doc, "model", "bicubic") == ["figure_crossing: disocclusion PSNR 22.90 < 25.70"]
    text = markdown(doc)
    assert "model is below TAAU in: no scenario" in text
    assert "model is below bicubic in: figure_crossing: disocclusion PSNR 22.90 < 25.70" in text
