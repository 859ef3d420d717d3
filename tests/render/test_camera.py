"""Camera matrices, jitter sign and camera-path YAML."""

import numpy as np
import pytest

from mnss_kit.errors import UserError
from mnss_kit.render.camera import CameraPath, KeyframeConfig, jittered, perspective, view_matrix, yaw_pitch_towards


def project(m, p, size):
    c = m @ np.append(p, 1.0)
    ndc = c[:3] / c[3]
    return np.array([(ndc[0] + 1) / 2 * size[0], (1 - ndc[1]) / 2 * size[1]]), (ndc[2] + 1) / 2


def test_look_at_centres_target_and_depth_is_standard():
    yaw, pitch = yaw_pitch_towards((3, 4, 5), (0, 1, -2))
    v = view_matrix((3, 4, 5), yaw, pitch)
    p = perspective(60, 16 / 9, 0.5, 100.0)
    px, d = project(p @ v, np.array([0.0, 1.0, -2.0]), (160, 90))
    np.testing.assert_allclose(px, (80, 45), atol=1e-9)
    z = np.linalg.norm(np.array([3, 4, 5]) - np.array([0, 1, -2]))
    assert d == pytest.approx(100.0 * (z - 0.5) / (z * 99.5))  # d = f (z - n) / (z (f - n))


def test_jitter_moves_sample_point_by_jitter():
    # pixel centre c shows the scene point that projects to c + jitter without jitter (+y down)
    size = (160, 90)
    m = perspective(60, 16 / 9, 0.5, 100.0)
    point = np.array([0.3, -0.2, -5.0])
    plain, _ = project(m, point, size)
    shifted, _ = project(jittered(m, (0.25, -0.4), size), point, size)
    np.testing.assert_allclose(plain - shifted, (0.25, -0.4), atol=1e-9)


def test_path_interpolates_through_keyframes_and_flags_cuts():
    keys = [KeyframeConfig(0.0, (0, 2, 10), look_at=(0, 0, 0)), KeyframeConfig(1.0, (5, 2, 10), yaw=20, pitch=-10, fov=50),
            KeyframeConfig(2.0, (9, 2, 8), yaw=30, pitch=-5), KeyframeConfig(2.5, (-20, 5, 0), yaw=180, pitch=0, cut=True),
            KeyframeConfig(3.0, (-21, 5, 0), yaw=170, pitch=0)]
    path = CameraPath(keys, 60.0)
    s = path.state(1.0)
    np.testing.assert_allclose(s.position, (5, 2, 10))
    assert (s.yaw, s.pitch, s.fov) == pytest.approx((20, -10, 50))
    assert path.state(2.4).position[0] == pytest.approx(9.0)  # clamped to the end of shot 1
    np.testing.assert_allclose(path.state(2.5).position, (-20, 5, 0))
    assert path.is_cut(2.45, 2.5) and not path.is_cut(2.5, 2.55) and not path.is_cut(1.0, 1.1)
    a, b = path.state(0.999).position, path.state(1.001).position
    assert np.linalg.norm(a - b) < 0.02  # continuous across a keyframe


def test_yaw_unwraps_the_short_way():
    path = CameraPath([KeyframeConfig(0.0, (0, 0, 0), yaw=170, pitch=0), KeyframeConfig(1.0, (0, 0, 0), yaw=-170, pitch=0)])
    assert path.state(0.5).yaw == pytest.approx(180.0)


def test_yaml_errors(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("keyframes:\n  - {time: 0, position: [0, 0, 0]}\n")
    with pytest.raises(UserError, match="look_at or both yaw and pitch"):
        CameraPath.load(bad)
    bad.write_text("keyframes:\n  - {time: 1, position: [0, 0, 0], yaw: 0, pitch: 0}\n  - {time: 0, position: [1, 0, 0], yaw: 0, pitch: 0}\n")
    with pytest.raises(UserError, match="increase"):
        CameraPath.load(bad)
    bad.write_text("keyframes:\n  - {time: 0, position: [0, 0, 0], yaw: 0, pitch: 0, zoom: 2}\n")
    with pytest.raises(UserError, match="unknown key"):
        CameraPath.load(bad)


def test_each_cut_resets_exactly_one_frame():
    from mnss_kit.render.config import SequenceConfig
    from mnss_kit.render.scene import Scene
    from mnss_kit.render.run import sequence_meta

    seq = SequenceConfig(name="s", scene="arena", frames=64, fps=30.0)
    for cut in (1.6, 48 / 30, 1.6 + 1e-12, 1.61):  # on a frame time (with rounding either way) and between frames
        path = CameraPath([KeyframeConfig(0.0, (0, 1, 0), yaw=0, pitch=0), KeyframeConfig(cut, (5, 1, 0), yaw=90, pitch=0, cut=True)])
        meta = sequence_meta(seq, Scene("s", [], [], path))
        resets = [f.index for f in meta.frames if f.reset]
        assert len(resets) == 2 and resets[0] == 0 and resets[1] in (48, 49)
        first_new = resets[1]
        assert path.state(meta.frames[first_new].time).yaw == 90 and path.state(meta.frames[first_new - 1].time).yaw == 0


def test_view_jumped_when_the_point_looked_at_leaves_the_previous_view():
    from mnss_kit.render.camera import CameraState, view_jumped

    def state(yaw, position=(0.0, 2.0, 0.0), inverse_focus=0.0):
        return CameraState(np.array(position), yaw, -10.0, 0.0, 70.0, inverse_focus)

    aspect = 16 / 9  # half the horizontal field of view: atan(tan(35) * 16 / 9) = 51 degrees
    assert not view_jumped(state(0), state(45), aspect)
    assert view_jumped(state(0), state(55), aspect) and view_jumped(state(0), state(-55), aspect)
    assert view_jumped(state(0), state(180), aspect)  # looking back: behind the previous camera
    # a pan without a turn: the point 5 m ahead moves off the previous image only when the camera moves far
    assert not view_jumped(state(0, inverse_focus=0.2), state(0, (1.0, 2.0, 0.0), 0.2), aspect)
    assert view_jumped(state(0, inverse_focus=0.2), state(0, (8.0, 2.0, 0.0), 0.2), aspect)


def test_view_jumped_when_most_of_the_image_moves_more_than_half_of_it():
    """A turn that keeps the point looked at in view but moves most pixels by more than half the
    image is a jump: data check refuses such motion, so the renderer must flag the frame a reset."""
    from mnss_kit.render.camera import CameraState, perspective, view_jumped

    def state(yaw, pitch):
        return CameraState(np.array((0.0, 2.0, 0.0)), yaw, pitch, 0.0, 70.0)

    aspect = 16 / 9
    before, after = state(0, -10.0), state(45, 15.0)
    looked_at = perspective(70.0, aspect, 1.0, 2.0) @ before.view() @ np.append(-after.view()[2, :3], 0.0)
    assert max(abs(looked_at[0]), abs(looked_at[1])) < looked_at[3]  # still inside the previous view
    assert view_jumped(before, after, aspect)
    assert not view_jumped(before, state(45, -10.0), aspect)  # the same turn without looking up: 42% moved


def test_a_squeezed_pan_is_flagged_where_data_check_would_refuse_it():
    """unseen_x2's factory_u2 at 16 frames pans up so fast that frame 4 moves 54% of its pixels by more
    than half the image after the reset on frame 3; frame 4 is a reset too."""
    from mnss_kit.render.config import load_render_config
    from mnss_kit.render.run import sequence_meta
    from mnss_kit.render.scenes import build_scene

    cfg = load_render_config("unseen_x2", ["frames=16"])
    seq = next(s for s in cfg.sequences if s.name == "factory_u2")
    resets = [f.index for f in sequence_meta(seq, build_scene(seq, cfg)).frames if f.reset]
    assert resets == [0, 3, 4, 10]


def test_look_at_keyframes_give_the_focus_distance_and_a_whip_pan_breaks_history():
    keys = [KeyframeConfig(0.0, (0, 2, 10), look_at=(0, 2, 0)), KeyframeConfig(1.0, (0, 2, 10), look_at=(0, 2, 5)),
            KeyframeConfig(1.1, (0, 2, 10), look_at=(-10, 2, 10))]
    path = CameraPath(keys, 60.0)
    assert path.state(0.0).inverse_focus == pytest.approx(0.1) and path.state(1.0).inverse_focus == pytest.approx(0.2)
    assert not path.breaks_history(0.0, 0.033, 16 / 9)
    assert path.breaks_history(1.0, 1.1, 16 / 9)  # 90 degrees in 0.1 s
