"""The training configs shipped in configs/ load, and a stage's init_checkpoint is written by
another shipped config (so the documented chains run in order)."""

import json
from dataclasses import asdict
from pathlib import Path

import pytest

pytest.importorskip("torch", reason="the training configs load with pcnet.models.train, which needs torch (the [train] extra)")
from pcnet.models.train import load_config  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = sorted((ROOT / "configs").glob("*.toml"))


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
    ('data = ["a.npz"]\ntrain_whole = [true, false]\n', "train_whole"),
    ('train_whole = [1]\n', "train_whole"),
    ('split_scheme = "hash"\n', "split_scheme"),
    ('noise_model = "gaussian"\n', "noise_model"),
    ('[model]\ninput_frame = "world"\n', "input_frame"),
])
def test_generalisation_fields_are_checked(tmp_path, text, field):
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(ValueError, match=rf"bad\.toml.*{field}"):
        load_config(bad)


SHIPPED = {"pcnet_camera": "pcnet_camera_floor4.toml", "pcnet_body": "pcnet_body_posture.toml"}


def test_shipped_default_trains_on_the_motion_style_split_with_cmu():
    """The shipped weights' configs keep held-out motions, styles and CMU subjects out of training."""
    for name, config in SHIPPED.items():
        cfg = load_config(ROOT / "configs" / config)
        assert cfg.split_scheme == "motion-style" and cfg.noise_model == "lifter" and any("cmu" in d for d in cfg.data)
        assert cfg.trunk_sagittal_sigma_deg > 0 and cfg.model.input_frame == name.split("_")[1]


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_shipped_weights_were_trained_with_the_config_that_says_so(name):
    """Every training field the exported weights record equals the shipped config's."""
    recorded = json.loads((ROOT / "models" / "weights" / f"{name}.json").read_text())
    cfg = asdict(load_config(ROOT / "configs" / SHIPPED[name]))
    # whole_clips is derived from the data (the clip names of files trained on whole), not a field
    fields = {k: v for k, v in recorded["training_config"].items() if k != "whole_clips"}
    assert fields and {k: cfg[k] for k in fields} == fields
    assert bool(recorded["training_config"].get("whole_clips")) == any(cfg["train_whole"])
    assert {k: cfg["model"][k] for k in recorded["model_config"]} == recorded["model_config"]


def test_a_file_trained_whole_trains_every_clip_and_validates_none():
    """configs/pcnet_body_floor.toml's DeepMimic subset: its clips are not Bandai or CMU (the
    motion-style scheme cannot place them) and all of them train, repeated, none validates."""
    import numpy as np

    from pcnet.models.datasets import Clip
    from pcnet.models.train import training_clips

    pose = np.zeros((4, 17, 3), np.float32)
    cmu = [Clip(f"{s:03d}_01", pose, 30.0) for s in (8, 12, 10)]  # train, val, test subjects
    floor = [Clip("humanoid3d_crawl.txt", pose, 60.0), Clip("humanoid3d_getup_faceup.txt", pose, 60.0)]
    train, val = training_clips([cmu, floor], [2, 3], [False, True], "motion-style")
    assert [c.name for c in train] == ["008_01"] * 2 + ["humanoid3d_crawl.txt", "humanoid3d_getup_faceup.txt"] * 3
    assert [c.name for c in val] == ["012_01"]
    with pytest.raises(ValueError, match="motion-style"):
        training_clips([cmu, floor], [1, 1], [], "motion-style")
