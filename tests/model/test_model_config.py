"""Model config files: the shipped ladder loads; the model: section is strict, train:/data: are left alone."""

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
    default, _ = load_experiment("ntaau_x2")
    fast, _ = load_experiment("ntaau_x2_fast")
    assert fast.train == default.train and fast.data == default.data
    assert fast.model.width < default.model.width


@pytest.mark.parametrize("text, message", [("base: [1]\n", "base"), ("base: m.yaml\n", "loop"), ("base: nowhere\n", "nowhere")])
def test_bad_bases_are_user_errors(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(UserError, match=message):
        load_model_config(path)
