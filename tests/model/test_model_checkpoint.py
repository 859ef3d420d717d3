"""Checkpoints: round trip, names resolve to the zoo, bad files are one-line user errors."""

import pytest
import torch

from model_helpers import TINY, make_frame, randomise
from mnss_kit.errors import UserError
from mnss_kit.model import checkpoint
from mnss_kit.model.mnss.config import MNSSConfig
from mnss_kit.model.families import build_model

RECORD = {"jitter_pattern": "grid", "data_fingerprint": "abc123", "training": {"steps": 10, "loss": 0.5}}


@pytest.fixture
def model():
    return randomise(build_model(MNSSConfig(scale=3, recon_resolution="hr", **TINY))).eval()


@pytest.fixture
def saved(tmp_path, model):
    return checkpoint.save(tmp_path / "m.pt", model, RECORD)


def test_round_trip(saved, model):
    loaded, record = checkpoint.load(saved)
    frame = make_frame()
    assert torch.equal(loaded(frame, None)[0], model(frame, None)[0])
    assert record["format"] == checkpoint.FORMAT_TAG and record["version"] == checkpoint.FORMAT_VERSION
    assert record["family"] == "mnss" and record["scale"] == 3 and record["config"]["recon_resolution"] == "hr"
    assert {k: record[k] for k in RECORD} == RECORD
    assert record["macs_per_pixel"] > 0 and record["params"] == sum(p.numel() for p in model.parameters())
    assert record["code_version"].startswith(__import__("mnss_kit").__version__)
    assert list(saved.parent.iterdir()) == [saved]  # no temporary file left behind


def test_bare_name_resolves_to_the_zoo(tmp_path, monkeypatch, model):
    monkeypatch.setattr(checkpoint, "ZOO_DIR", tmp_path)
    checkpoint.save(tmp_path / "mnss_x9.pt", model, RECORD)
    assert checkpoint.shipped_names() == ["mnss_x9"]
    _, record = checkpoint.load("mnss_x9")
    assert record["data_fingerprint"] == "abc123"
    with pytest.raises(UserError, match="mnss_x9"):
        checkpoint.load("mnss_x8")


def test_record_must_be_plain_data(tmp_path, model):
    with pytest.raises(TypeError, match="plain data"):
        checkpoint.save(tmp_path / "m.pt", model, {"training": {"when": object()}})
    assert not (tmp_path / "m.pt").exists()


def corrupt(path, kind):
    data = path.read_bytes()
    if kind == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif kind == "text":
        path.write_text("hello")
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "foreign":
        torch.save({"weights": torch.zeros(3)}, path)
    elif kind == "newer":
        payload = torch.load(path, weights_only=True)
        payload["record"]["version"] = checkpoint.FORMAT_VERSION + 1
        torch.save(payload, path)
    elif kind == "mismatched":
        payload = torch.load(path, weights_only=True)
        payload["record"]["config"]["recon_width"] = 7
        torch.save(payload, path)


@pytest.mark.parametrize(
    "kind, message",
    [("truncated", "not a readable"), ("text", "not a readable"), ("empty", "not a readable"),
     ("foreign", "not an mnss-kit checkpoint"), ("newer", "upgrade"), ("mismatched", "do not match")],
)
def test_bad_files_are_one_line_user_errors(saved, kind, message):
    corrupt(saved, kind)
    with pytest.raises(UserError, match=message) as err:
        checkpoint.load(saved)
    assert "\n" not in str(err.value)


def test_missing_file(tmp_path):
    with pytest.raises(UserError, match="no checkpoint"):
        checkpoint.load(tmp_path / "nope.pt")


def test_shipped_model_nets_are_alive(tmp_path):
    """Every hidden layer of the shipped AA and reconstruction nets fires on rendered-like frames,
    and both nets change their input: a net whose hidden layer died adds a constant."""
    from mnss_kit.dataset.loader import eval_sequences
    from mnss_kit.dataset.synthetic import write_synthetic_sequence

    model, _ = checkpoint.load("mnss_x2")
    write_synthetic_sequence(tmp_path / "pan", lr_size=(48, 32), frames=6, name="pan")
    (sequence,) = eval_sequences(tmp_path / "pan", progress=False)
    fired: dict[str, torch.Tensor] = {}

    def record(name):
        def hook(module, inputs, output):
            seen = (output > 0).flatten(2).any(dim=2).any(dim=0)
            fired[name] = seen | fired.get(name, torch.zeros_like(seen))
        return hook

    for net_name in ("aa.net", "recon.body"):
        net = model.get_submodule(net_name)
        for i, module in enumerate(net):
            if isinstance(module, torch.nn.ReLU):
                module.register_forward_hook(record(f"{net_name}.{i}"))
    state, changed = None, {"aa": 0.0, "recon": 0.0}
    with torch.no_grad():
        for frame in sequence:
            output, aux, state = model({k: v for k, v in frame.items() if k != "reference"}, state)
            changed["aa"] = max(changed["aa"], float((aux["aa"] - frame["color"].clamp(0, 1)).abs().max()))
            changed["recon"] = max(changed["recon"], float((output - aux["history"]).abs().max()))
    assert len(fired) == 5
    for name, seen in fired.items():
        assert seen.float().mean() >= 0.25, f"{name}: only {seen.float().mean():.0%} of the units ever fire"
    assert min(changed.values()) > 0.01, changed


def test_a_checkpoint_trained_on_several_jitter_patterns_names_each_and_bundles_one():
    several = {"jitter_pattern": "center,halton,grid"}
    assert checkpoint.trained_patterns(several) == ["center", "halton", "grid"]
    assert checkpoint.bundle_pattern(several) == "grid"
    assert checkpoint.bundle_pattern({"jitter_pattern": "center,halton"}) == "center"
    assert checkpoint.trained_patterns({}) == [] and checkpoint.bundle_pattern({}) == "grid"
    # where the grid has no order (a quality mode, x4), Halton in its place
    assert checkpoint.bundle_pattern(several, 1.7) == "halton" and checkpoint.bundle_pattern(several, 2) == "grid"
    assert checkpoint.bundle_pattern({"jitter_pattern": "grid"}, 1.5) == "halton"
    assert checkpoint.bundle_pattern({"jitter_pattern": "center,grid"}, 4) == "center"
    record, _ = checkpoint.read_record("ntaau_x2")  # the shipped default trains on three patterns
    assert set(checkpoint.trained_patterns(record)) == {"center", "halton", "grid"}


def test_a_record_written_before_the_grid_rename_reads_as_grid():
    """The shipped checkpoints say mnss, the grid pattern's earlier name: read as grid, once each."""
    old = {"jitter_pattern": "center,halton,mnss"}
    assert checkpoint.trained_patterns(old) == ["center", "halton", "grid"]
    assert checkpoint.bundle_pattern(old) == "grid"
    assert checkpoint.trained_patterns({"jitter_pattern": "mnss,grid"}) == ["grid"]
