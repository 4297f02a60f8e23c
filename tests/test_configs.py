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
