"""Model config files: the shipped ladder loads; the model: section is strict, train:/data: are left alone."""

from dataclasses import replace

import pytest

from mnss_kit.errors import UserError
from mnss_kit.model.config import config_names, load_model_config
from mnss_kit.model.families import FAMILIES


@pytest.mark.parametrize("name", config_names())
def test_shipped_configs_load(name):
    config = load_model_config(name)
    assert isinstance(config, FAMILIES[config.family].config) and name.startswith(config.family)


def test_ladder_exists():
    assert {"mnss_x2_tiny", "mnss_x2", "mnss_x2_large", "mnss_x3", "mnss_x2_hrnet"} <= set(config_names())


def write(tmp_path, text):
    path = tmp_path / "m.yaml"
    path.write_text(text)
    return path


def test_train_and_data_sections_are_ignored(tmp_path):
    path = write(tmp_path, "schema: 1\nmodel: {scale: 3}\ntrain: {lr: 0.001, anything: [1, 2]}\ndata: {root: x}\n")
    assert load_model_config(path).scale == 3


@pytest.mark.parametrize(
    "text, message",
    [
        ("schema: 1\nmodel: {recon_widht: 8}\n", "recon_widht"),
        ("schema: 1\nmodel: {}\nextra: 1\n", "extra"),
        ("model: {}\n", "schema"),
        ("schema: 2\nmodel: {}\n", "schema"),
        ("schema: 1\n", "model"),
        ("schema: 1\nmodel: {family: nope}\n", "family"),
        ("schema: 1\nmodel: {recon_resolution: mid}\n", "recon_resolution"),
        ("schema: 1\nmodel: {recon_layers: 1}\n", "recon_layers"),
    ],
)
def test_bad_configs_are_user_errors(tmp_path, text, message):
    with pytest.raises(UserError, match=message):
        load_model_config(write(tmp_path, text))


def test_overrides(tmp_path):
    path = write(tmp_path, "schema: 1\nmodel: {recon_width: 8}\n")
    assert load_model_config(path, ["model.recon_width=12", "train.lr=0.1"]).recon_width == 12


def test_unknown_name():
    with pytest.raises(UserError, match="mnss_x2"):
        load_model_config("no_such_config")


def test_a_variant_states_only_how_it_differs_from_its_base(tmp_path):
    write(tmp_path, "schema: 1\nmodel: {family: ntaau, width: 16, layers: 3}\ntrain: {lr: 0.01, seed: 3}\n")
    variant = tmp_path / "v.yaml"
    variant.write_text("base: m.yaml\nmodel: {width: 8}\ntrain: {seed: 4}\n")
    from mnss_kit.train.config import load_experiment
    experiment, _ = load_experiment(variant)
    assert (experiment.model.width, experiment.model.layers) == (8, 3)
    assert (experiment.train.lr, experiment.train.seed) == (0.01, 4)
    assert load_model_config(variant, ["model.layers=2"]).layers == 2


def test_shipped_fast_variant_trains_like_the_default():
    from mnss_kit.train.config import load_experiment
    names = ("ntaau_x2_base", "ntaau_x2", "ntaau_x2_fast_base", "ntaau_x2_fast")
    base, default, fast_base, fast = (load_experiment(name)[0] for name in names)
    assert fast_base.train == base.train and fast_base.data == fast.data == default.data == base.data
    assert replace(fast.train, init=None) == replace(default.train, init=None)
    same_net = lambda m: replace(m, width=default.model.width, layers=default.model.layers)  # noqa: E731
    assert same_net(fast.model) == default.model and same_net(fast_base.model) == base.model
    assert (fast.model.width, fast.model.layers) == (fast_base.model.width, fast_base.model.layers)
    assert fast.model.width < default.model.width
    assert (default.train.init, fast.train.init) == ("runs/ntaau_x2_base/model.pt", "runs/ntaau_x2_fast_base/model.pt")


@pytest.mark.parametrize("name", ["ntaau_x2", "ntaau_x2_fast"])
def test_shipped_ntaau_checkpoints_were_trained_by_their_configs(name):
    """The fine-tune config reproduces the shipped record's train section and model (the recipe has one source)."""
    from mnss_kit.model import checkpoint
    from mnss_kit.model.config import describes
    from mnss_kit.train.config import changed_train_keys, load_experiment
    from mnss_kit.train.run import BOOKKEEPING_KEYS
    experiment, _ = load_experiment(name)
    record, _ = checkpoint.read_record(name)
    differing = changed_train_keys(record["train"], experiment.train, BOOKKEEPING_KEYS | {"init"})
    assert not differing, differing
    assert describes(record["config"], experiment.model)
    base, _ = load_experiment(f"{name}_base")
    assert describes(record["init"]["config"], base.model)


@pytest.mark.parametrize("text, message", [("base: [1]\n", "base"), ("base: m.yaml\n", "loop"), ("base: nowhere\n", "nowhere")])
def test_bad_bases_are_user_errors(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(UserError, match=message):
        load_model_config(path)


def test_a_record_describes_a_config_with_keys_added_since_at_their_defaults():
    from mnss_kit.config import to_dict
    from mnss_kit.model.config import describes
    from mnss_kit.model.ntaau.config import NTAAUConfig
    older = {k: v for k, v in to_dict(NTAAUConfig(width=9)).items() if k != "box_bound"}
    assert describes(older, NTAAUConfig(width=9))
    assert not describes(older, NTAAUConfig(width=9, box_bound=1.0))
    assert not describes(older, NTAAUConfig(width=16))
    assert not describes({"family": "ntaau", "width": "wide"}, NTAAUConfig()) and not describes(None, NTAAUConfig())
