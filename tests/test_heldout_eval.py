"""Held-out evaluation: motion-style and subject splits, lifter-like noise, and scoring
(invalid frames, --max-frames) of ``pcnet evaluate``."""

from __future__ import annotations

import json
import zlib
from collections import Counter

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import FIXTURES, shared

from pcnet.models import lifter_noise as ln
from pcnet.models.datasets import (CMU_HOLDOUT_SUBJECTS, HELDOUT_STYLE_COUNT, HELDOUT_TEST_STYLES, SPLIT_SCHEMES,
                                   Clip, Noise, apply_noise, clip_split_of, group_key, load_mocap, make_pairs,
                                   parse_bandai_name, select_split)
from pcnet.stages.core.errors import InputError
from pcnet.stages.core.metrics import mpjpe_mm

BANDAI_FIXTURES = ("bandai_small.npz", "bandai_test_clips.npz", "mocap_small.npz")
TEST_CLIPS = FIXTURES / "bandai_test_clips.npz"


def _clips(names, subjects=None) -> list[Clip]:
    subjects = subjects or {}
    return [Clip(n, np.zeros((1, 17, 3), np.float32), 30.0, subjects.get(n)) for n in names]


def _fixture_names() -> list[str]:
    """Every Bandai name in the fixtures, each with 40 more takes of its group: a group has many
    takes in the full data, and the split must keep all of them together."""
    names = {n for f in BANDAI_FIXTURES for n in np.load(FIXTURES / f).files}
    more = {f"{n.rsplit('_', 1)[0]}_{k:03d}" for n in names for k in range(1, 41)}
    return sorted(names | more)


def _bandai_names(full: bool) -> list[str]:
    if full:
        return sorted(json.loads(shared("mocap", "bandai_h36m17.json").read_text()))
    return _fixture_names()


def test_bandai_name_parse():
    assert parse_bandai_name("dataset-1_bow_active_001") == ("dataset-1", "bow", "active", 1)
    assert parse_bandai_name("dataset-2_raise-up-left-hand_not-confident_034") == (
        "dataset-2", "raise-up-left-hand", "not-confident", 34)
    for bad in ("dataset-1_bow_active", "dataset-1_bow_active_001.bvh", "humanoid3d_walk.txt", "008_01",
                "dataset-1_bow_very_active_001", "dataset_bow_active_001", "Dataset-1_bow_active_001"):
        assert parse_bandai_name(bad) is None, bad
    for name in _fixture_names():
        assert parse_bandai_name(name) is not None, name


def test_every_shared_bandai_name_parses():
    names = _bandai_names(full=True)
    assert len(names) == 3076
    parsed = [parse_bandai_name(n) for n in names]
    assert all(p is not None for p in parsed)
    assert len({p[:3] for p in parsed}) == 226
    # the parse round-trips: nothing of a name is lost or merged
    assert all(f"{d}_{m}_{s}_{t:03d}" == n for n, (d, m, s, t) in zip(names, parsed))


@pytest.mark.parametrize("full", [False, True], ids=["fixture-names", "shared-json"])
def test_motion_style_split_keeps_groups_and_held_out_styles_whole(full):
    clips = _clips(_bandai_names(full))
    groups = {s: {group_key(c) for c in select_split(clips, s, "motion-style")} for s in ("train", "val", "test")}
    assert not groups["train"] & groups["test"]
    assert not groups["train"] & groups["val"]
    assert not groups["val"] & groups["test"]
    assert sum(len(select_split(clips, s, "motion-style")) for s in ("train", "val", "test")) == len(clips)
    held = {(d, s) for d, styles in HELDOUT_TEST_STYLES.items() for s in styles}
    style_of = {s: {parse_bandai_name(c.name)[0::2][:2] for c in select_split(clips, s, "motion-style")}
                for s in ("train", "val", "test")}
    assert not held & (style_of["train"] | style_of["val"])
    if full:
        assert held <= style_of["test"]  # every held-out style really is in test
        # the old scheme splits takes of one group: what the new one exists to prevent
        old = {s: {group_key(c) for c in select_split(clips, s, "clip")} for s in ("train", "test")}
        assert len(old["train"] & old["test"]) == 75


def test_split_counts_are_pinned():
    """Counts stay put across processes and versions (a stable hash, not Python's)."""
    meta = json.loads(shared("mocap", "bandai_h36m17.json").read_text())
    clips = _clips(sorted(meta))
    counts = {(scheme, s): len(select_split(clips, s, scheme)) for scheme in SPLIT_SCHEMES
              for s in ("train", "val", "test")}
    assert counts == {("clip", "train"): 2475, ("clip", "val"): 293, ("clip", "test"): 308,
                      ("motion-style", "train"): 1971, ("motion-style", "val"): 195,
                      ("motion-style", "test"): 910}
    assert select_split(clips, "test") == select_split(clips, "test", "clip")  # trainers' default unchanged


def test_held_out_styles_follow_the_documented_rule():
    meta = json.loads(shared("mocap", "bandai_h36m17.json").read_text())
    styles: dict[str, set] = {}
    for name in meta:
        d, _, s, _ = parse_bandai_name(name)
        styles.setdefault(d, set()).add(s)
    for d, found in styles.items():
        ranked = sorted(found, key=lambda s: zlib.crc32(f"{d}/{s}".encode()))
        assert HELDOUT_TEST_STYLES[d] == tuple(ranked[: HELDOUT_STYLE_COUNT[d]])


def test_cmu_split_is_subject_wise():
    # names alone (<subject>_<trial>) ...
    names = [f"{s:03d}_{t:02d}" for s in (8, 9, 10, 11, 12, 13, 14, 60, 61) for t in range(1, 6)]
    by_split = {s: {int(c.name[:3]) for c in select_split(_clips(names), s, "motion-style")}
                for s in ("train", "val", "test")}
    assert by_split["val"] == set(CMU_HOLDOUT_SUBJECTS["val"])
    assert by_split["test"] == set(CMU_HOLDOUT_SUBJECTS["test"])
    assert not by_split["train"] & (by_split["val"] | by_split["test"])
    # ... and the json's subject wins over the name
    assert clip_split_of(_clips(["x"], {"x": 14})[0], "motion-style") == "test"


def test_cmu_split_on_the_shared_file():
    meta = json.loads(shared("mocap", "cmu_train_h36m17.json").read_text())
    clips = _clips(sorted(meta), {n: v["subject"] for n, v in meta.items()})
    subjects = {s: {c.subject for c in select_split(clips, s, "motion-style")} for s in ("train", "val", "test")}
    assert subjects["val"] == set(CMU_HOLDOUT_SUBJECTS["val"]) and subjects["test"] == set(CMU_HOLDOUT_SUBJECTS["test"])
    assert not subjects["train"] & (subjects["val"] | subjects["test"])
    assert all(int(c.name.split("_")[0]) == c.subject for c in clips)


def test_load_mocap_reads_subject(tmp_path):
    with np.load(TEST_CLIPS) as real:
        np.savez(tmp_path / "m.npz", a=real[real.files[0]][:3])
    (tmp_path / "m.json").write_text(json.dumps({"a": {"fps": 25.0, "subject": 12}}))
    (clip,) = load_mocap(tmp_path / "m.npz")
    assert clip.subject == 12 and clip.fps == 25.0
    assert clip_split_of(clip, "motion-style") == "val"
    # a clip name the npz does not hold (a typo) would silently leave its clip at 30 fps
    (tmp_path / "m.json").write_text(json.dumps({"a": {"fps": 25.0}, "b_typo": {"fps": 120.0}}))
    with pytest.raises(InputError, match="m.json: expected clip names of m.npz, got 1 it does not hold: b_typo"):
        load_mocap(tmp_path / "m.npz")


def test_motion_style_refuses_clips_it_cannot_place():
    clips = load_mocap(FIXTURES / "deepmimic_small.npz")
    with pytest.raises(InputError, match="humanoid3d.*split 'all'"):
        select_split(clips, "test", "motion-style")
    assert len(select_split(clips, "all", "motion-style")) == len(clips)
    with pytest.raises(InputError, match="split scheme"):
        select_split(clips, "test", "take")


# ---------------------------------------------------------------- lifter-like noise


def test_lifter_noise_is_deterministic():
    clips = load_mocap(TEST_CLIPS)
    a = make_pairs(clips, seed=4, camera="per-clip", noise=ln.LifterNoise())
    b = make_pairs(clips, seed=4, camera="per-clip", noise=ln.LifterNoise())
    c = make_pairs(clips, seed=5, camera="per-clip", noise=ln.LifterNoise())
    np.testing.assert_array_equal(a.inputs, b.inputs)
    assert not np.allclose(a.inputs, c.inputs)
    e1 = ln.sample_lifter_errors(90, 30.0, np.random.default_rng(1))
    e2 = ln.sample_lifter_errors(90, 30.0, np.random.default_rng(1))
    np.testing.assert_array_equal(e1.offsets, e2.offsets)
    assert e1.lean_deg == e2.lean_deg


def _autocorr(x: np.ndarray, lag: int) -> float:
    x = x.reshape(len(x), -1)
    x = x - x.mean(0)
    return float((x[lag:] * x[:-lag]).sum() / np.sqrt((x[lag:] ** 2).sum() * (x[:-lag] ** 2).sum()))


def test_lifter_offsets_are_temporally_correlated():
    fps = 30.0
    e = ln.sample_lifter_errors(int(600 * fps), fps, np.random.default_rng(0))
    lag = int(0.5 * fps)
    r = _autocorr(e.offsets[:, 1:], lag)
    assert r > 0.5, r
    assert abs(r - np.exp(-0.5 / ln.OFFSET_TIME_CONSTANT_S)) < 0.05
    assert abs(_autocorr(e.jitter[:, 1:], lag)) < 0.1  # the fast part is white
    # the frame noise it replaces is not correlated at all
    X = np.zeros((int(60 * fps), 17, 3))
    frame = apply_noise(X, Noise(drop_prob=0.0), np.random.default_rng(0), np.zeros(len(X), int))
    assert abs(_autocorr(frame[:, 1:], lag)) < 0.1
    # the offsets scale as documented: std per axis at a weight-1 joint
    sd = e.offsets[:, 12].std(0)  # left elbow, weight 1
    np.testing.assert_allclose(sd, [ln.OFFSET_SIGMA_XY_M, ln.OFFSET_SIGMA_XY_M, ln.OFFSET_SIGMA_Z_M], rtol=0.25)
    # the events happen at about their rates
    assert 0.5 * ln.BURST_RATE_HZ * 0.4 < e.burst.mean() < 2 * ln.BURST_RATE_HZ * 0.4
    assert 0 < (e.swap >= 0).mean() < 0.03


# Every component switched off; a test turns one back on.
ONLY = {"offset_sigma_xy_m": 0.0, "offset_sigma_z_m": 0.0, "bone_scale_sigma": 0.0, "lean_sigma_deg": 0.0,
        "depth_scale_sigma": 0.0, "jitter_m": 0.0, "burst_jitter_m": 0.0, "swap_rate_hz": 0.0}


def _camera_clip() -> np.ndarray:
    clips = load_mocap(TEST_CLIPS)[:1]
    return make_pairs(clips, seed=0, camera="per-clip").inputs.astype(np.float64)


def test_lifter_noise_has_its_per_clip_biases():
    X = _camera_clip()
    rng = np.random.default_rng(7)
    # depth: z relative to the pelvis scaled by one factor for the whole clip, x and y kept
    p = ln.LifterNoise(**{**ONLY, "depth_scale_sigma": ln.DEPTH_SCALE_SIGMA})
    e = ln.sample_lifter_errors(len(X), 30.0, rng, p)
    Y = ln.apply_lifter_errors(X, e)
    np.testing.assert_allclose(Y[..., 2], X[..., 2] * e.depth_scale, atol=1e-12)
    np.testing.assert_allclose(Y[..., :2], X[..., :2], atol=1e-12)
    # lean: every frame turned by the same angle about the camera x axis, top toward the camera
    p = ln.LifterNoise(**{**ONLY, "lean_sigma_deg": 5.0})
    e = ln.sample_lifter_errors(len(X), 30.0, np.random.default_rng(3), p)
    e = ln.LifterErrors(e.offsets, e.jitter, e.burst, e.swap, e.bone_scale, 4.0, e.depth_scale)
    Y = ln.apply_lifter_errors(X, e)
    head_before, head_after = X[:, 10, 1:], Y[:, 10, 1:]
    turn = np.degrees(np.arctan2(head_after[:, 1], head_after[:, 0]) - np.arctan2(head_before[:, 1], head_before[:, 0]))
    np.testing.assert_allclose((turn + 180) % 360 - 180, 4.0, atol=1e-6)  # +4 deg in the y-z plane
    assert (Y[:, 10, 2] < X[:, 10, 2]).all()
    np.testing.assert_allclose(Y[..., 0], X[..., 0], atol=1e-12)
    # bones: each bone length times its per-clip factor, left = right
    p = ln.LifterNoise(**{**ONLY, "bone_scale_sigma": ln.BONE_SCALE_SIGMA})
    e = ln.sample_lifter_errors(len(X), 30.0, np.random.default_rng(5), p)
    Y = ln.apply_lifter_errors(X, e)
    from pcnet.stages.core.conventions import H36M_PARENTS

    for child, parent in enumerate(H36M_PARENTS):
        if parent >= 0:
            ratio = np.linalg.norm(Y[:, child] - Y[:, parent], axis=-1) / np.linalg.norm(X[:, child] - X[:, parent], axis=-1)
            np.testing.assert_allclose(ratio, e.bone_scale[child], rtol=1e-9)
    assert e.bone_scale[1] == e.bone_scale[4] and e.bone_scale[13] == e.bone_scale[16]
    # over many clips the biases have their documented spread
    draws = [ln.sample_lifter_errors(10, 30.0, np.random.default_rng(s)) for s in range(600)]
    assert abs(np.std([d.lean_deg for d in draws]) / ln.LEAN_SIGMA_DEG - 1) < 0.15
    assert abs(np.std([d.depth_scale for d in draws]) / ln.DEPTH_SCALE_SIGMA - 1) < 0.15
    assert max(abs(d.lean_deg) for d in draws) <= ln.LEAN_CLIP_DEG


def test_lifter_noise_swaps_sides():
    X = _camera_clip()
    p = ln.LifterNoise(**{**ONLY, "swap_rate_hz": 2.0})
    e = ln.sample_lifter_errors(len(X), 30.0, np.random.default_rng(2), p)
    Y = ln.apply_lifter_errors(X, e)
    legs = np.flatnonzero(e.swap == ln.SWAP_PARTS.index("legs"))
    assert len(legs) and np.allclose(Y[legs, 1], X[legs, 4]) and np.allclose(Y[legs, 14], X[legs, 14])
    np.testing.assert_allclose(Y[e.swap < 0], X[e.swap < 0] - X[e.swap < 0, :1], atol=1e-12)


def test_lifter_noise_mpjpe_is_a_lifters():
    clips = load_mocap(TEST_CLIPS)
    errors = []
    for seed in range(10):
        clean = make_pairs(clips, seed=seed, camera="per-clip")
        noisy = make_pairs(clips, seed=seed, camera="per-clip", noise=ln.LifterNoise())
        errors.append(mpjpe_mm(noisy.inputs, clean.inputs).mean())
    lo, hi = ln.MPJPE_RANGE_MM
    assert lo <= np.mean(errors) <= hi, errors
    assert abs(np.mean(errors) - ln.EXPECTED_MPJPE_MM) < 3.0


def test_lifter_noise_per_frame_cameras_keep_the_temporal_errors():
    """With a new camera every frame the errors are drawn in one reference camera per clip:
    the error in the canonical frame then changes slowly, not frame to frame."""
    clips = load_mocap(TEST_CLIPS)[:3]
    clean = make_pairs(clips, seed=1, camera="per-frame")
    noisy = make_pairs(clips, seed=1, camera="per-frame", noise=ln.LifterNoise(jitter_m=0.0, burst_jitter_m=0.0,
                                                                              swap_rate_hz=0.0))
    np.testing.assert_allclose(noisy.R, clean.R)
    err = np.einsum("nkj,nji->nki", noisy.inputs.astype(np.float64), clean.R) - clean.canonical
    step = np.abs(np.diff(err, axis=0))[np.diff(noisy.clip) == 0].mean()
    assert step < 0.2 * np.abs(err).mean()


def test_lifter_noise_of_a_frame_does_not_depend_on_subsampling():
    clips = load_mocap(TEST_CLIPS)
    full = make_pairs(clips, seed=2, camera="per-clip", noise=ln.LifterNoise())
    # the same frames at stride 3: the same per-clip cameras and the same errors on them
    strided = make_pairs(clips, seed=2, camera="per-clip", noise=ln.LifterNoise(), frame_stride=3)
    pos = {(c, f): i for i, (c, f) in enumerate(zip(full.clip, full.frame))}
    rows = [pos[(c, f)] for c, f in zip(strided.clip, strided.frame)]
    np.testing.assert_allclose(strided.inputs, full.inputs[rows], atol=1e-6)


# ---------------------------------------------------------------- pcnet evaluate


def test_the_table_says_what_auto_mode_chose_per_clip():
    """`pcnet evaluate --mode auto` gave the static or moving choice only in the JSON (a user
    trial): the table's header counts the clips of each mode."""
    import re

    from pcnet.pipeline.evaluate import evaluate, format_table

    result = evaluate("pcnet", TEST_CLIPS, "all", camera="per-clip", noise="lifter", mode="auto")
    header = format_table(result).splitlines()[0]
    counts = dict(re.findall(r"(sequence|smooth):(\d+)", header.split("seed=")[0].split("(clips ")[-1]))
    assert sum(map(int, counts.values())) == result["clips"] == 12, header
    assert counts == {k: str(v) for k, v in result["clip_modes"].items()}


@pytest.mark.slow
def test_max_frames_keeps_the_per_clip_decisions():
    """--max-frames scores a subset of whole rectified clips: same heading source and modes
    per clip, same errors on the kept frames. (It used to subsample before
    rectifying: 60-frame clips kept 8 frames, fewer than `auto` needs, and switched to the
    predicted heading.)"""
    from pcnet.pipeline.evaluate import evaluate

    for kw in ({"camera": "per-frame", "noise": "none", "mode": "frame"},
               {"camera": "per-clip", "noise": "lifter", "mode": "sequence"}):
        full = evaluate("pcnet", TEST_CLIPS, "all", details=True, **kw)
        sub = evaluate("pcnet", TEST_CLIPS, "all", max_frames=100, details=True, **kw)
        assert sub["frames"] == 100 and full["frames"] == sub["total_frames"] == 720
        decisions = ("name", "heading_source", "mode")
        assert [[c[k] for k in decisions] for c in sub["per_clip"]] == [[c[k] for k in decisions] for c in full["per_clip"]]
        assert sub["clip_heading_sources"] == full["clip_heading_sources"]
        assert sub.get("clip_modes") == full.get("clip_modes")
        pos = {(c, f): i for i, (c, f) in enumerate(zip(full["per_frame"]["clip"], full["per_frame"]["frame"]))}
        rows = [pos[(c, f)] for c, f in zip(sub["per_frame"]["clip"], sub["per_frame"]["frame"])]
        for name in ("rotation_deg", "tilt_deg", "heading_deg", "mpjpe_mm"):
            np.testing.assert_allclose(sub["per_frame"][name], full["per_frame"][name][rows], atol=1e-9)
    assert full["clip_heading_sources"] == {"predicted": 12}  # noisy: the network's heading
    clean = evaluate("pcnet", TEST_CLIPS, "all", max_frames=100)
    assert clean["clip_heading_sources"] == {"hips": 12}  # clean mocap: the hip line, on every clip


def test_invalid_frames_are_counted_and_excluded():
    from pcnet.pipeline.evaluate import evaluate
    from pcnet.stages.core.metrics import summarize

    res = evaluate("geometric", TEST_CLIPS, "all", noise="frame", details=True)  # dropped joints
    pf = res["per_frame"]
    assert res["invalid_frames"] == int((~pf["valid"]).sum()) > 0
    assert res["valid_frames"] + res["invalid_frames"] == res["frames"]
    for name in ("rotation_deg", "mpjpe_mm"):
        assert np.isnan(pf[name][~pf["valid"]]).all()
        assert res[name] == summarize(pf[name][pf["valid"]])
    other = evaluate("pcnet", TEST_CLIPS, "all", noise="frame")
    assert other["frame_set"] == res["frame_set"]  # both methods scored on the same frames
    # each clip's scores (a user trial found none to tell which clips err): its valid frames' means
    assert [c["name"] for c in res["per_clip"]] == [c["name"] for c in other["per_clip"]] and len(res["per_clip"]) == 12
    for i, clip in enumerate(res["per_clip"]):
        mine = (pf["clip"] == i) & pf["valid"]
        assert (clip["frames"], clip["valid"]) == (int((pf["clip"] == i).sum()), int(mine.sum()))
        assert clip["tilt_deg"] == pytest.approx(np.mean(pf["tilt_deg"][mine]), abs=1e-4)


def test_frames_marked_invalid_never_count_even_with_a_rotation(monkeypatch):
    """A method may return a finite rotation for a frame it marks invalid: still excluded."""
    import pcnet.pipeline.evaluate as ev

    from pcnet.stages.rectify import FrameEstimate, GeometricEstimator

    class Flagging(GeometricEstimator):
        def __call__(self, X, fps=30.0):
            estimate = super().__call__(X, fps)
            valid = estimate.valid.copy()
            valid[::7] = False  # keep R: a finite but disowned prediction (every 7th frame of each clip)
            R = estimate.rotation.copy()
            R[::7] = np.eye(3)
            return FrameEstimate(R, estimate.residual, valid)

    monkeypatch.setattr(ev, "make_estimator", lambda method, weights: Flagging())
    res = ev.evaluate("geometric", TEST_CLIPS, "all", details=True)
    disowned = np.concatenate([np.arange(len(c.joints)) % 7 == 0 for c in load_mocap(TEST_CLIPS)])
    assert res["invalid_frames"] == disowned.sum() > 0
    assert np.isnan(res["per_frame"]["rotation_deg"][disowned]).all()
    assert res["rotation_deg"]["p95"] < 60  # the identity frames (errors up to 180 deg) left out


def test_evaluate_cli_noise_and_scheme_options(tmp_path):
    from pcnet.pipeline.cli import evaluate as cli_evaluate
    from pcnet.pipeline.cli import main
    from pcnet.pipeline.evaluate import NOISE_KINDS

    choices = {p.name: p.type.choices for p in cli_evaluate.params if hasattr(p.type, "choices")}
    assert tuple(choices["noise"]) == NOISE_KINDS
    assert set(choices["split_scheme"]) == set(SPLIT_SCHEMES) == set(choices["unseen_by"])
    base = ["evaluate", "--method", "geometric", "--data", str(TEST_CLIPS), "--split", "all"]
    seen = {}
    for extra, kind in (([], "none"), (["--noise"], "frame"), (["--noise", "lifter"], "lifter"),
                        (["--noise", "none"], "none"), (["--noise", "frame", "--mode", "frame"], "frame")):
        out = tmp_path / "r.json"
        res = CliRunner().invoke(main, base + extra + ["--json", str(out), "--overwrite"])
        assert res.exit_code == 0, res.output
        result = json.loads(out.read_text())
        assert result["noise"] == kind, extra
        seen.setdefault(kind, result["mpjpe_mm"])
        assert seen[kind] == result["mpjpe_mm"]  # deterministic
        # a rigid method's PA-MPJPE is 0 on clean input: said, as a trial read the zeros as a fault
        assert ("pa_mpjpe_mm is 0 for a rigid method on clean input" in res.output) == (kind == "none")
        assert (result["pa_mpjpe_mm"]["mean"] < 1e-3) == (kind == "none")
    assert len({json.dumps(v) for v in seen.values()}) == 3
    res = CliRunner().invoke(main, base[:-2] + ["--split", "test"])  # default scheme motion-style
    assert res.exit_code == 0, res.output
    assert "scheme=motion-style" in res.output
    res = CliRunner().invoke(main, ["evaluate", "--method", "geometric", "--data",
                                    str(FIXTURES / "deepmimic_small.npz")])
    assert res.exit_code == 1 and "split 'all'" in res.output and "Traceback" not in res.output


def test_unseen_by_keeps_groups_the_weights_never_saw():
    from pcnet.models.datasets import load_mocap, select_split
    from pcnet.pipeline.evaluate import _training_overlap, _unknown_file_warning, evaluate

    data = shared("mocap", "bandai_h36m17.npz")
    res = evaluate("geometric", data, "all", split_scheme="clip", unseen_by="clip", max_frames=200)
    assert res["clips"] == res["groups"] == 31
    assert res["training_overlap"] is None  # the baseline trained on nothing
    clips = load_mocap(data)
    unseen_names = {c.name for c in select_split(clips, "all")} - {c.name for c in select_split(clips, "train", "clip")}
    clip_record = {"data": ["x/bandai_h36m17.npz"], "split_scheme": "clip"}
    test = evaluate("geometric", data, "test", max_frames=200)
    assert (test["clips"], test["groups"]) == (910, 49)
    chosen = select_split(clips, "test", "motion-style")
    assert _training_overlap(data, clips, chosen, clip_record)["groups_with_a_trained_take"] == 47
    style_record = {"data": ["../shared/data/mocap/bandai_h36m17.npz"], "split_scheme": "motion-style"}
    overlap = _training_overlap(data, clips, chosen, style_record)
    assert overlap["clips_trained_on"] == overlap["groups_with_a_trained_take"] == 0
    assert _training_overlap(data, clips, chosen, {"data": ["cmu_train_h36m17.npz"]}) is None
    # a file the record does not name: clip names of the same form say nothing (new CMU subjects
    # have them too), so the overlap is unknown and said so, not claimed from the split
    assert _training_overlap("my_copy.npz", clips, chosen, clip_record) is None
    assert "my_copy.npz is not among the files the weights trained on (bandai_h36m17.npz): whether its clips " \
           "overlap their training data is unknown" in _unknown_file_warning("my_copy.npz", clip_record, None)
    assert _unknown_file_warning(data, clip_record, {"clips": 1}) is None and _unknown_file_warning(data, {}, None) \
        is None
    # a split of such a file chose its clips by names that mean nothing for it (a lab's trial: 1 of 4 clips scored)
    assert _unknown_file_warning("my_copy.npz", clip_record, None, split="test", scored=(1, 4)).endswith(
        "; --split test chose 1 of its 4 clips by their names, as the training files are split, which means nothing "
        "for this file: --split all takes every clip")
    assert "--split" not in _unknown_file_warning("my_copy.npz", clip_record, None, split="all", scored=(4, 4))
    assert unseen_names  # clips outside the clip-scheme train split exist
    assert Counter(test["clip_heading_sources"]) == Counter({"predicted": 910})


def test_clips_of_a_file_trained_on_whole_are_counted_where_they_are_tested():
    """A DeepMimic subset moved into training (train_whole) leaves the rest of DeepMimic a
    cross-dataset test: evaluation on DeepMimic names the trained clips, and says nothing for
    weights that trained on no DeepMimic clip."""
    from pcnet.models.datasets import load_mocap
    from pcnet.pipeline.evaluate import _training_overlap, format_table
    from pcnet.stages.core.metrics import METRICS

    data = FIXTURES / "deepmimic_small.npz"
    clips = load_mocap(data)
    record = {"data": ["bandai_h36m17.npz", "runs/deepmimic_floor_train.npz"], "split_scheme": "motion-style",
              "train_whole": [False, True], "whole_clips": ["humanoid3d_crawl.txt", "humanoid3d_roll_not_here.txt"]}
    overlap = _training_overlap(data, clips, clips, record)
    assert (overlap["clips"], overlap["clips_trained_on"], overlap["clips_trained_whole"]) == (3, 1, 1)
    assert overlap["groups_with_a_trained_take"] == 1 and overlap["matched_by"] == "clip names"
    assert not overlap["split_trained"]
    assert _training_overlap(data, clips, [c for c in clips if "crawl" not in c.name], record) is None
    assert _training_overlap(data, clips, clips, {**record, "whole_clips": []}) is None
    # the file trained on whole, evaluated itself (also from a record without whole_clips)
    own = {**record, "data": ["bandai_h36m17.npz", str(data)]}
    for rec in (own, {k: v for k, v in own.items() if k != "whole_clips"}):
        itself = _training_overlap(data, clips, clips, rec)
        assert (itself["clips_trained_on"], itself["clips_trained_whole"], itself["matched_by"]) == (3, 3, "file name")
        assert itself["groups_with_a_trained_take"] == 3 and not itself["split_trained"]
    result = {"method": "pcnet", "views": "paper", "split": "all", "camera": "per-frame", "noise": "none",
              "mode": "frame", "seed": 0, "clips": 3, "groups": 3, "frames": 1, "invalid_frames": 0,
              "training_overlap": overlap, **{m: {"mean": 0, "median": 0, "p95": 0} for m in METRICS}}
    line = format_table(result)
    assert "trained on at least 1 of these 3 clips" in line and "(1 of these clips from a file trained on whole;" in line
    assert "recognised by their clip names; the others' overlap unknown" in line
    assert "train split" not in line


def test_weights_trained_on_a_whole_file_without_its_clip_names_warn(tmp_path):
    """Weights exported before whole_clips was recorded (as the seed-13 floor candidate was,
    removed from the tree; in git history before the 2026-11-26 clean-up) cannot say which
    clips they trained on: the evaluation warns instead of implying none; the shipped weights,
    whose record lists the clips of the file they trained on whole, do not warn. The old
    record is the shipped camera-frame network's with ``whole_clips`` taken out."""
    import shutil
    from pathlib import Path

    from pcnet.models.inference import CAMERA_WEIGHTS
    from pcnet.pipeline.evaluate import _unlisted_whole_warning, evaluate

    data = FIXTURES / "deepmimic_small.npz"
    weights = tmp_path / "pcnet_camera_floor.onnx"
    shutil.copyfile(CAMERA_WEIGHTS, weights)
    record = json.loads(Path(CAMERA_WEIGHTS).with_suffix(".json").read_text())
    assert any(record["training_config"]["train_whole"]) and record["training_config"].pop("whole_clips")
    weights.with_suffix(".json").write_text(json.dumps(record))
    old = evaluate("pcnet", data, "all", weights=str(weights), max_frames=20)
    assert any("deepmimic_floor_train.npz, whose clip names their record does not list" in w for w in old["warnings"])
    assert old["training_overlap"] is None
    # the shipped record lists the clip trained on whole; the file's other clips may be anywhere
    # (a user trial: a file mixing such a clip with CMU training takes read as mostly unseen)
    (only,) = evaluate("pcnet", data, "all", max_frames=20)["warnings"]
    assert only.startswith("deepmimic_small.npz is not among the files the weights trained on") and \
        "of the evaluated clips, 1 is recognised by name among the clips they trained on whole" in only, only
    assert "--untrained-only" not in only
    # --untrained-only leaves out the recognised clip and says that it could do no more (a trial
    # read a silent --untrained-only on its own file as "none of these trained on")
    untrained = evaluate("pcnet", data, "all", max_frames=20, untrained_only=True)
    assert untrained["warnings"][-1].endswith("; --untrained-only left out 1 clip recognised by name among the clips "
                                              "they trained on whole (humanoid3d_crawl.txt) and scored every other")
    assert untrained["left_out_trained_clips"] == ["humanoid3d_crawl.txt"]
    assert _unlisted_whole_warning({"data": ["a.npz"], "train_whole": [True], "whole_clips": ["x"]}) is None


def test_weights_without_their_training_record_warn_that_overlap_is_unknown(tmp_path):
    """The shipped camera-frame weights copied without the .json beside them score the same,
    but cannot say which clips they trained on: the evaluation warns instead of implying
    none; with the .json there is no such warning."""
    import shutil

    from pcnet.models.inference import CAMERA_WEIGHTS
    from pcnet.pipeline.evaluate import evaluate

    data = FIXTURES / "deepmimic_small.npz"
    bare = tmp_path / "bare.onnx"
    shutil.copyfile(CAMERA_WEIGHTS, bare)
    result = evaluate("pcnet", data, "all", weights=str(bare), max_frames=20)
    assert any(w.startswith("the weights' training data is unknown (no training_config in "
                            f"{tmp_path / 'bare.json'})") for w in result["warnings"]), result["warnings"]
    with_record = evaluate("pcnet", data, "all", weights=str(CAMERA_WEIGHTS), max_frames=20)
    assert not any(w.startswith("the weights' training data is unknown") for w in with_record["warnings"])
    assert with_record["tilt_deg"] == result["tilt_deg"]
    # the result names the weights it scored (a user trial's own network read "method=pcnet" like the pair)
    from pcnet.pipeline.evaluate import format_table

    assert result["weights"] == str(bare) and f"method=pcnet weights={bare} views=" in format_table(result)
    shipped = evaluate("pcnet", data, "all", max_frames=20)
    assert shipped["weights"] == "shipped" and "method=pcnet weights=shipped views=" in format_table(shipped)


def test_untrained_only_leaves_out_the_clips_the_weights_trained_on(tmp_path):
    """A developer's trial found no way to score DeepMimic without the three floor motions the
    shipped camera-frame weights trained on whole; --untrained-only leaves out what the weights'
    record names, and refuses where no record can say."""
    import shutil

    from pcnet.models.inference import CAMERA_WEIGHTS
    from pcnet.pipeline.evaluate import evaluate, format_table
    from pcnet.stages.core.errors import InputError

    data = FIXTURES / "deepmimic_small.npz"  # cartwheel, walk and crawl (crawl: trained on whole)
    every = evaluate("pcnet", data, "all", max_frames=20)
    assert every["clips"] == 3 and every["training_overlap"]["clips_trained_on"] == 1
    held_out = evaluate("pcnet", data, "all", max_frames=20, untrained_only=True)
    assert held_out["clips"] == 2 and held_out["training_overlap"] is None and held_out["untrained_only"]
    assert " untrained-only " in format_table(held_out)
    with pytest.raises(InputError, match=r"^--untrained-only: expected a method with weights"):
        evaluate("geometric", data, "all", max_frames=20, untrained_only=True)
    bare = tmp_path / "bare.onnx"
    shutil.copyfile(CAMERA_WEIGHTS, bare)
    with pytest.raises(InputError, match=r"^--untrained-only: expected weights with a training record, got none"):
        evaluate("pcnet", data, "all", weights=str(bare), max_frames=20, untrained_only=True)


def test_a_mocap_file_that_is_not_y_up_gets_a_warning(tmp_path):
    """Real walking, running and arm-raising clips pass as +Y up; the same clips stored Z-up
    (a lab frame) or Y-down warn on `pcnet evaluate`; floor motions (crawl, roll, get-up)
    facing various ways do not."""
    from pcnet.models.datasets import world_up_warning
    from pcnet.pipeline.cli import main

    mocap = FIXTURES / "mocap_small.npz"
    clips = load_mocap(mocap)
    assert world_up_warning(clips, mocap) is None
    assert world_up_warning(load_mocap(FIXTURES / "deepmimic_small.npz"), "deepmimic") is None
    z_up = {c.name: c.joints[:, :, [0, 2, 1]] * [1.0, -1.0, 1.0] for c in clips}  # (x, y, z) -> (x, -z, y)
    y_down = {c.name: c.joints * [1.0, -1.0, -1.0] for c in clips}
    for name, arrays, along in (("z_up", z_up, "+Z"), ("y_down", y_down, "-Y")):
        np.savez(tmp_path / f"{name}.npz", **arrays)
        warning = world_up_warning(load_mocap(tmp_path / f"{name}.npz"), tmp_path / f"{name}.npz")
        assert warning and f"point along {along} on average" in warning, warning
    res = CliRunner().invoke(main, ["evaluate", "--method", "geometric", "--data", str(tmp_path / "z_up.npz"),
                                    "--split", "all", "--max-frames", "30"])
    assert res.exit_code == 0, res.output
    assert f"WARNING {tmp_path / 'z_up.npz'}: expected a world frame with +Y up" in res.output


@pytest.mark.parametrize("scale", [100.0, 0.1])
def test_a_mocap_file_not_in_metres_is_refused(tmp_path, scale):
    """Real clips in centimetres (pelvis-centred, so every coordinate stays under the 100 m
    range check) or in decimetres-as-metres: one line naming the file, the clip and the thigh."""
    clips = load_mocap(FIXTURES / "mocap_small.npz")
    np.savez(tmp_path / "cm.npz", **{c.name: (c.joints - c.joints[:, :1]) * scale for c in clips})
    with pytest.raises(InputError, match=r"cm\.npz \[clip .*\]: expected metres .* got a median hip -> knee length of"):
        load_mocap(tmp_path / "cm.npz")


def test_a_lab_files_millimetres_missing_joint_and_stale_sidecar_are_named(tmp_path):
    """A mocap lab's trial: millimetres were told to use pcnet run's --units (evaluate has none),
    a joint missing in every frame of one clip was not named, and a sidecar whose frame counts
    were another version's was read, fps and all."""
    import json

    clips = load_mocap(FIXTURES / "mocap_small.npz")
    np.savez(tmp_path / "mm.npz", **{c.name: c.joints * 1000.0 for c in clips})
    with pytest.raises(InputError, match=r"millimetres or centimetres given as metres\? scale the file to metres\)$"):
        load_mocap(tmp_path / "mm.npz")
    no_ankle = clips[0].joints.copy()
    no_ankle[:, 3] = np.nan
    np.savez(tmp_path / "nan.npz", trial02=no_ankle)
    with pytest.raises(InputError, match=r"nan\.npz \[clip trial02\]: expected at least one frame with all 17 joints, "
                                         r"got none \(right_ankle missing in every frame\)$"):
        load_mocap(tmp_path / "nan.npz")
    np.savez(tmp_path / "lab.npz", trial01=clips[0].joints)
    (tmp_path / "lab.json").write_text(json.dumps({"trial01": {"fps": 60.0, "frames": 999}}))
    with pytest.raises(InputError, match=rf"lab\.json: clip trial01: field 'frames': expected {len(clips[0].joints)} "
                                         r"\(the clip's frames in lab\.npz\), got 999: the sidecar of another version"):
        load_mocap(tmp_path / "lab.npz")
    (tmp_path / "lab.json").write_text(json.dumps({"trial01": {"fps": 60.0, "frames": len(clips[0].joints)}}))
    assert load_mocap(tmp_path / "lab.npz")[0].fps == 60.0


def test_a_file_named_like_a_training_file_is_not_taken_for_it(tmp_path):
    """A user's own clips in a file named cmu_train_h36m17.npz (a trial): evaluate stopped with
    the motion-style split's advice to pass --split all, which was given. Now the name is
    said to tell nothing, and every clip is scored, --untrained-only too."""
    from pcnet.pipeline.evaluate import evaluate

    clips = load_mocap(FIXTURES / "mocap_small.npz")
    folder = tmp_path / "mine"
    folder.mkdir()
    np.savez(folder / "cmu_train_h36m17.npz", **{f"lab_trial_{i}": c.joints for i, c in enumerate(clips)})
    for untrained in (False, True):
        result = evaluate("pcnet", folder / "cmu_train_h36m17.npz", "all", max_frames=30, untrained_only=untrained)
        assert result["clips"] == 3 and result["training_overlap"] is None
        assert any(w.startswith("cmu_train_h36m17.npz bears the name of a file the weights trained on, but its clip "
                                "'lab_trial_0' has no place in that file's motion-style split") for w in result["warnings"])


def test_a_file_with_a_training_files_name_but_other_content_is_not_taken_for_it(tmp_path):
    """An ML trial copied its test clips under its training file's name and read "the weights
    trained on 12 of these 14 clips" (the clip scheme places any name): a record with the
    training files' sha256 (``pcnet train`` writes them) tells the two apart; the same bytes
    under another folder still count."""
    import shutil

    from pcnet.models.datasets import select_split
    from pcnet.pipeline.evaluate import _foreign_file_warning, _training_overlap
    from pcnet.stages.core.digest import sha256_file

    trained = FIXTURES / "mocap_small.npz"
    record = {"data": ["runs/data/mocap_small.npz"], "split_scheme": "clip", "data_sha256": [sha256_file(trained)]}
    (tmp_path / "same").mkdir()
    (tmp_path / "decoy").mkdir()
    same = tmp_path / "same" / "mocap_small.npz"
    shutil.copyfile(trained, same)
    decoy = tmp_path / "decoy" / "mocap_small.npz"
    np.savez(decoy, **{f"lab_trial_{i}": c.joints for i, c in enumerate(load_mocap(trained))})
    for path, known in ((same, True), (decoy, False)):
        clips = load_mocap(path)
        overlap = _training_overlap(path, clips, select_split(clips, "all"), record)
        assert (overlap is not None) is known, (path, overlap)
        warning = _foreign_file_warning(path, record, clips)
        assert (warning is None) is known, warning
    assert warning.startswith("mocap_small.npz bears the name of a file the weights trained on, but not its content")
    # a record from before the digests names the file alone: taken for it, as before
    clips = load_mocap(decoy)
    assert _training_overlap(decoy, clips, select_split(clips, "all"), {**record, "data_sha256": None}) is not None


def test_scored_frames_missing_joints_are_said(tmp_path):
    """Both wrists missing in the first 20 frames of each real clip (a user trial's file was
    scored without a word): evaluate scores the joints present and says so."""
    from pcnet.pipeline.evaluate import evaluate, format_table
    from pcnet.stages.core.conventions import L_WRIST, R_WRIST

    clips = load_mocap(FIXTURES / "mocap_small.npz")
    holed = {}
    for c in clips:
        j = c.joints.copy()
        j[:20, [L_WRIST, R_WRIST]] = np.nan
        holed[c.name] = j
    np.savez(tmp_path / "wrists.npz", **holed)
    result = evaluate("geometric", tmp_path / "wrists.npz", "all")
    assert "60 scored frames miss joints (left_wrist, right_wrist): mpjpe_mm and pa_mpjpe_mm there are over the " \
           "joints present" in format_table(result)
    assert np.isfinite(result["mpjpe_mm"]["mean"])
    assert not any("miss joints" in w for w in evaluate("geometric", FIXTURES / "mocap_small.npz", "all")["warnings"])


def test_frames_without_a_target_are_counted_and_sequence_modes_need_one_camera_per_clip(tmp_path):
    """Every other frame of real clips made missing: evaluate says how many frames had no
    target; a sequence mode with a new camera every frame is refused, not scored."""
    from pcnet.pipeline.evaluate import evaluate, format_table

    clips = load_mocap(FIXTURES / "mocap_small.npz")
    holes = {c.name: np.where((np.arange(len(c.joints)) % 2 == 1)[:, None, None], np.nan, c.joints) for c in clips}
    np.savez(tmp_path / "holes.npz", **holes)
    result = evaluate("geometric", tmp_path / "holes.npz", "all", max_frames=50)
    assert result["target_undefined_frames"] == sum(len(c.joints) // 2 for c in clips) == 165
    assert "165 frames of the data had no defined target" in format_table(result)
    # clean mocap with the heading from its hip line: the table says that heading is exact (a user trial
    # quoted 0.09 deg as pcnet's heading accuracy)
    clean = evaluate("pcnet", FIXTURES / "mocap_small.npz", "all", max_frames=50)
    assert clean["clip_heading_sources"] == {"hips": len(clips)}
    assert "heading from the input's hip line, exact on clean mocap" in format_table(clean)
    for other in (evaluate("pcnet", FIXTURES / "mocap_small.npz", "all", max_frames=50, heading="predicted"),
                  evaluate("pcnet", FIXTURES / "mocap_small.npz", "all", max_frames=50, noise="lifter",
                           camera="per-clip")):
        assert "exact on clean mocap" not in format_table(other)
    with pytest.raises(InputError, match=r"--mode sequence: expected --camera per-clip or static"):
        evaluate("geometric", FIXTURES / "mocap_small.npz", "all", mode="sequence", camera="per-frame")


def test_a_mocap_file_without_frame_rates_is_read_at_30_fps_with_a_warning(tmp_path):
    """Real clips with their json (30 and 60 fps) keep it; the same clips without a json are
    read at 30 fps, and evaluate warns where seconds matter (lifter noise, sequence modes, the
    networks' frame mode: its view gate's window is in seconds, and an evaluation trial's file
    without rates scored 22.1 deg where it scores 10.9) and not for the geometric method's clean
    per-frame scores, which do not depend on time."""
    from pcnet.models.datasets import DEFAULT_MOCAP_FPS
    from pcnet.pipeline.evaluate import evaluate

    stated = load_mocap(FIXTURES / "deepmimic_small.npz")
    assert all(c.fps_stated for c in stated)
    np.savez(tmp_path / "bare.npz", **{c.name: c.joints for c in stated})
    bare = load_mocap(tmp_path / "bare.npz")
    assert all(not c.fps_stated and c.fps == DEFAULT_MOCAP_FPS for c in bare)
    assert {c.fps for c in stated} != {DEFAULT_MOCAP_FPS}  # the fixture states another rate
    common = dict(method="geometric", data=tmp_path / "bare.npz", split="all", max_frames=20)
    assert evaluate(**common)["warnings"] == []
    noisy = evaluate(**common, noise="lifter", camera="per-clip")["warnings"]
    assert len(noisy) == 1 and "found no such file: read at 30 fps" in noisy[0]  # no json at all (a user trial)
    assert noisy[0].startswith(f"{tmp_path / 'bare.json'}: expected each clip's 'fps'")
    networks = evaluate(**{**common, "method": "pcnet"})["warnings"]
    assert sum("the view gate's are in seconds" in w for w in networks) == 1  # beside the training-overlap one


def test_an_empty_split_of_a_lab_file_points_to_split_all(tmp_path):
    """A lab's own ``subject_trial`` names (001_01, ...) fall in no CMU test subject: the
    default ``--split test`` is empty and the refusal says how to score every clip (a user
    trial: only other name forms had the hint)."""
    from pcnet.pipeline.evaluate import evaluate

    clips = load_mocap(FIXTURES / "deepmimic_small.npz")
    np.savez(tmp_path / "lab.npz", **{f"00{i + 1}_01": c.joints for i, c in enumerate(clips)})
    with pytest.raises(InputError, match=r"split 'test' \(scheme 'motion-style'\) has no clips; --split all scores "
                                         r"every clip"):
        evaluate("geometric", tmp_path / "lab.npz", "test", split_scheme="motion-style", max_frames=20)
    assert evaluate("geometric", tmp_path / "lab.npz", "all", max_frames=20)["clips"] == len(clips)


def test_a_mocap_file_with_left_and_right_exchanged_is_warned_about(tmp_path):
    """A lab's trial: a file whose left and right joints were exchanged scored 9.8 deg mean
    rotation error, against 1.8 correctly labelled, with no warning (``pcnet rectify`` of the
    same poses warned of a mirror image)."""
    from pcnet.pipeline.evaluate import evaluate

    clips = load_mocap(FIXTURES / "bandai_small.npz")
    swap = [0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13]
    np.savez(tmp_path / "lab.npz", **{c.name: c.joints for c in clips})
    np.savez(tmp_path / "lab_swapped.npz", **{c.name: c.joints[:, swap] for c in clips})
    assert not any("mirror" in w for w in evaluate("geometric", tmp_path / "lab.npz", "all")["warnings"])
    (warning,) = [w for w in evaluate("geometric", tmp_path / "lab_swapped.npz", "all")["warnings"] if "mirror" in w]
    assert warning.startswith(f"{len(clips)} of {len(clips)} clips are mirror images of a body (knees bend forward")
    assert "left and right exchanged in the file?" in warning


def test_a_lab_subject_that_is_not_a_cmu_number_is_named_as_such(tmp_path):
    """An evaluation trial's json gave each clip a subject "S01": the motion-style split's
    refusal had said it found no json 'subject' at all."""
    from pcnet.models.datasets import motion_style_split

    clip = load_mocap(FIXTURES / "deepmimic_small.npz")[0]
    np.savez(tmp_path / "lab.npz", S01_walk_01=clip.joints)
    (tmp_path / "lab.json").write_text(json.dumps({"S01_walk_01": {"subject": "S01", "fps": clip.fps}}))
    (lab,) = load_mocap(tmp_path / "lab.npz")
    with pytest.raises(InputError, match=r"a CMU subject number \(name <subject>_<trial> or an integer json "
                                         r"'subject'\), got neither; use split 'all'"):
        motion_style_split(lab)
