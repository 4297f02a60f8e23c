"""The training configs shipped in configs/ load, and a stage's init_checkpoint is written by
another shipped config (so the documented chains run in order)."""

from pathlib import Path

import pytest

pytest.importorskip("torch")
from pcnet.models.train import load_config  # noqa: E402

CONFIGS = sorted((Path(__file__).resolve().parents[1] / "configs").glob("*.toml"))


@pytest.mark.parametrize("path", CONFIGS, ids=[p.name for p in CONFIGS])
def test_shipped_config_loads(path):
    cfg = load_config(path)
    assert cfg.epochs > 0 and cfg.batch_size > 0 and cfg.lr > 0
    if cfg.init_checkpoint:
        producers = {load_config(p).out_dir for p in CONFIGS if p != path}
        assert str(Path(cfg.init_checkpoint).parent) in producers


def test_config_errors_name_the_file_and_the_key(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("epochs = 2\n[model]\nhiden = 64\n")
    with pytest.raises(ValueError, match=r"bad\.toml.*\[model\].*hiden"):
        load_config(bad)
    bad.write_text("epoch = 2\n")
    with pytest.raises(ValueError, match=r"bad\.toml.*epoch"):
        load_config(bad)


@pytest.mark.parametrize("text,field", [
    ('data = ["a.npz", "b.npz"]\ndata_repeats = [1]\n', "data_repeats"),
    ('data_repeats = [0]\n', "data_repeats"),
    ('data_repeats = ["2"]\n', "data_repeats"),
    ('split_scheme = "hash"\n', "split_scheme"),
    ('noise_model = "gaussian"\n', "noise_model"),
    ('[model]\ninput_frame = "world"\n', "input_frame"),
])
def test_generalisation_fields_are_checked(tmp_path, text, field):
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(ValueError, match=rf"bad\.toml.*{field}"):
        load_config(bad)


def test_shipped_default_trains_on_the_motion_style_split_with_cmu():
    """The shipped weights' config keeps held-out motions, styles and CMU subjects out of training."""
    cfg = load_config(Path(__file__).resolve().parents[1] / "configs" / "pcnet_body.toml")
    assert cfg.split_scheme == "motion-style" and cfg.model.input_frame == "body"
    assert cfg.noise_model == "lifter" and any("cmu" in d for d in cfg.data)
