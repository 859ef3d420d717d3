"""The manifest is complete: its schedule, replayed on Mesa from the bundle's files alone (no model,
no toolkit tables), reproduces the golden frames, which came from the numpy reference and LiteRT."""

from __future__ import annotations

import json

import numpy as np
from bundle_replay import Replay, read_array


def test_schedule_replay_reproduces_golden_frames(bundle):
    from mnss_kit.gpu.mesa import create_context

    manifest = json.loads((bundle / "manifest.json").read_text())
    frames = manifest["golden"]["frames"]
    assert [f["reset"] for f in frames] == [True] + [False] * (len(frames) - 1)  # the history path runs too
    replay = Replay(create_context(), bundle)
    previous = None
    for frame in frames:
        got = replay.run_frame(frame, previous)
        previous = frame
        for key in ("npu_input", "npu_output", "display"):
            want = read_array(bundle, frame["arrays"][key])
            np.testing.assert_array_equal(got[key], want, err_msg=f"frame {frame['index']} {key}")


def test_golden_jitter_follows_the_manifest_table(bundle):
    manifest = json.loads((bundle / "manifest.json").read_text())
    table = manifest["jitter"]["sequence"]
    assert len(table) == manifest["jitter"]["period"]
    for frame in manifest["golden"]["frames"]:
        entry = table[frame["jitter_index"]]
        assert np.float32(entry["offset"]).tolist() == np.float32(frame["jitter"]).tolist()
        assert entry["subpixel"] == frame["subpixel"]
