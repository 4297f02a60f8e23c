"""The mirror test (stages/mirror.py): the bend sines' sign convention on a real body, the
discriminant against the two Gaussians it stands for, and the shipped fit's file."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import FIXTURES
from scipy.stats import multivariate_normal

from pcnet.stages.core.errors import InputError
from pcnet.stages.flags import mirrored_skeleton_flag
from pcnet.stages.mirror import MIRROR_ODDS, MIRROR_PATH, limb_bend_sines, load_mirror_model, recording_cues

BOXER = FIXTURES / "boxing_X3D_f000-059.npy"  # real MotionBERT output: a guard, knees and elbows bent


def test_a_real_boxers_knees_and_elbows_bend_as_a_body_s_and_mirroring_negates_them():
    X = np.load(BOXER).astype(np.float64)
    bends = limb_bend_sines(X)
    assert bends.shape == (len(X), 2)
    assert (np.median(bends, axis=0) > 0.2).all()
    np.testing.assert_allclose(limb_bend_sines(X * [1.0, 1.0, -1.0]), -bends, atol=1e-12)
    rotated = X @ np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]).T * 1000.0  # any frame, any units
    np.testing.assert_allclose(limb_bend_sines(rotated), bends, atol=1e-9)


def test_the_log_odds_are_the_ratio_of_the_mirrored_and_the_body_gaussians():
    model = load_mirror_model()
    for m in ([0.4, 0.3], [-0.2, 0.1], [0.0, 0.0], [-0.5, -0.4]):
        m = np.array(m)
        expected = (multivariate_normal(-model.mean, model.cov).logpdf(m)
                    - multivariate_normal(model.mean, model.cov).logpdf(m))
        assert model.log_odds(m) == pytest.approx(expected, abs=1e-9)


def test_straight_limbs_carry_no_chirality_and_missing_limbs_no_answer():
    X = np.load(BOXER).astype(np.float64)
    straight = X.copy()
    for hip, knee, ankle in ((1, 2, 3), (4, 5, 6), (11, 12, 13), (14, 15, 16)):
        straight[:, knee] = (straight[:, hip] + straight[:, ankle]) / 2
    m, counted = recording_cues(straight)
    assert counted == len(X) and np.abs(m).max() < 1e-9
    assert mirrored_skeleton_flag(straight) == [] and mirrored_skeleton_flag(straight * [1.0, 1.0, -1.0]) == []
    legs_only = X.copy()
    legs_only[:, [12, 15]] = np.nan  # no elbows: no recording cue, no flag
    assert recording_cues(legs_only)[1] == 0 and mirrored_skeleton_flag(legs_only * [1.0, 1.0, -1.0]) == []
    one_knee = X.copy()
    one_knee[:, 2] = np.nan  # one knee missing: the other side answers
    assert np.isfinite(limb_bend_sines(one_knee)).all()
    assert mirrored_skeleton_flag(one_knee * [1.0, 1.0, -1.0])


def test_the_shipped_fit_states_its_provenance_and_the_flag_its_odds():
    model = load_mirror_model()
    assert model.provenance["command"].startswith("python -m benchmarks.fit_mirror_flag")
    assert "train" in model.provenance["split"] and model.provenance["recordings"] > 1000
    (flag,) = mirrored_skeleton_flag(np.load(BOXER).astype(np.float64) * [1.0, 1.0, -1.0])
    odds = float(flag.headline.split("odds ")[1].split(":")[0])
    assert odds >= MIRROR_ODDS


@pytest.mark.parametrize("edit, field", [
    (lambda d: d.pop("cov"), "'cov'"),
    (lambda d: d.update(mean=[0.4]), "'mean'"),
    (lambda d: d.update(cov=[[1.0, 2.0], [2.0, 1.0]]), "'cov'"),
    (lambda d: d.update(cues=["elbow", "knee"]), "'cues'"),
])
def test_a_broken_fit_file_is_named_with_its_field(tmp_path, edit, field):
    data = json.loads(MIRROR_PATH.read_text())
    edit(data)
    path = tmp_path / "mirror_flag.json"
    path.write_text(json.dumps(data))
    with pytest.raises(InputError, match=field) as err:
        load_mirror_model(path)
    assert str(path) in str(err.value)
