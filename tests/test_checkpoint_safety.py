"""Checkpoints never run code: a pickle payload given to ``pcnet export`` or as a training
``init_checkpoint`` is refused without executing; bad checkpoints, configs and ONNX weights
end in one line (exit 1) and leave nothing behind; real checkpoints round-trip with
``weights_only=True`` (train, resume, fine-tune, export)."""

from __future__ import annotations

import dataclasses
import json
import re
import zipfile

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import FIXTURES

torch = pytest.importorskip("torch", reason="torch (the [train] extra) not installed")
pytest.importorskip("onnx", reason="onnx (the [train] extra) not installed")

from pcnet.models.datasets import clip_split, load_mocap  # noqa: E402
from pcnet.models.inference import PCNetSession  # noqa: E402
from pcnet.models.train import load_config, train  # noqa: E402
from pcnet.pipeline.cli import main  # noqa: E402
from pcnet.stages.core.errors import InputError  # noqa: E402

# Tiny models run fastest on one thread, and multi-threaded torch stalls on a busy machine.
torch.set_num_threads(1)
POSES = FIXTURES / "yoga_Abhay_Tadasana_f000-099.npy"
TINY_MODEL = "[model]\nhidden = 16\noutput = 24\nfeedforward = 32\nheads = 2\ngcn_layers = 1\ntransformer_layers = 1\n"


class _Payload:
    """Pickles as "call exec(code)": what a crafted checkpoint runs under weights_only=False."""

    def __init__(self, marker):
        self.code = f"open({str(marker)!r}, 'w').close()"

    def __reduce__(self):
        return (exec, (self.code,))


def _evil_checkpoint(path, marker):
    torch.save({"kind": "pcnet", "model": _Payload(marker), "model_config": {}, "epoch": 1}, path)
    return path


def _one_line_failure(res, *needles):
    lines = res.output.strip().splitlines()
    assert res.exit_code == 1, res.output
    assert len(lines) == 1, res.output
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


def _cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def mocap(tmp_path_factory):
    """Two train clips and one val clip (clip_split goes by name), about 100 frames."""
    clips = load_mocap(FIXTURES / "bandai_small.npz")
    val_name = next(f"val_{i}" for i in range(100) if clip_split(f"val_{i}") == "val")
    train_names = [f"train_{i}" for i in range(100) if clip_split(f"train_{i}") == "train"][:2]
    arrays = {train_names[0]: clips[0].joints, train_names[1]: clips[3].joints, val_name: clips[2].joints[:24]}
    path = tmp_path_factory.mktemp("mocap") / "tiny.npz"
    np.savez(path, **arrays)
    return path


def _train_config(tmp_path, mocap, name="cfg.toml", **fields):
    values = {"data": [str(mocap)], "out_dir": str(tmp_path / "run"), "epochs": 1, "batch_size": 64,
              "val_frames": 24, "frame_stride": 2, "threads": 1, "device": "cpu", "views": "wide", **fields}
    text = "".join(f"{k} = {json.dumps(v)}\n" for k, v in values.items() if v is not None)
    path = tmp_path / name
    path.write_text(text + TINY_MODEL)
    return path


def test_the_payload_is_real(tmp_path):
    """The payload does run under weights_only=False, so its absence below means refusal."""
    marker = tmp_path / "ran"
    torch.load(_evil_checkpoint(tmp_path / "evil.pt", marker), weights_only=False)
    assert marker.exists()


def test_export_refuses_a_pickle_payload_without_running_it(tmp_path):
    marker, out = tmp_path / "ran", tmp_path / "x.onnx"
    evil = _evil_checkpoint(tmp_path / "evil.pt", marker)
    line = _one_line_failure(_cli("export", "--checkpoint", evil, "--out", out), "evil.pt: not a pcnet checkpoint (")
    assert "Python object (exec)" in line and "refused" in line
    assert not marker.exists()
    assert not out.exists() and not out.with_suffix(".json").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["evil.pt"]


def test_train_refuses_a_pickle_payload_as_init_checkpoint_and_creates_nothing(tmp_path, mocap):
    marker = tmp_path / "ran"
    evil = _evil_checkpoint(tmp_path / "evil.pt", marker)
    cfg = _train_config(tmp_path, mocap, init_checkpoint=str(evil))
    _one_line_failure(_cli("train", "--config", cfg), "evil.pt: not a pcnet checkpoint (")
    assert not marker.exists()
    assert not (tmp_path / "run").exists()


def _write_junk(kind, path):
    if kind == "random bytes":
        path.write_bytes(np.random.default_rng(0).bytes(512))
    elif kind == "text":
        path.write_text("not a checkpoint\n")
    elif kind == "hello":  # a text starting with a byte that is no pickle opcode (KeyError in torch)
        path.write_text("hello\n")
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "foreign zip":
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("notes.txt", "hello")
    elif kind == "a list":
        torch.save([1, 2, 3], path)
    elif kind == "no model":
        torch.save({"epoch": 3}, path)
    elif kind == "model not tensors":
        torch.save({"model": {"w": "nope"}, "model_config": {}}, path)
    elif kind == "unknown kind":
        torch.save({"kind": "other", "model": {}}, path)
    elif kind == "bad config":
        torch.save({"kind": "pcnet", "model": {}, "model_config": {"hidden": "wide"}}, path)
    elif kind == "weights of another net":
        torch.save({"kind": "pcnet", "model": {"w": torch.zeros(2)}, "model_config": {}}, path)
    elif kind != "missing":
        raise AssertionError(kind)
    return path


JUNK = ["random bytes", "text", "hello", "empty", "foreign zip", "a list", "no model", "model not tensors", "unknown kind",
        "bad config", "weights of another net", "missing"]


@pytest.mark.parametrize("kind", JUNK)
def test_anything_but_a_checkpoint_is_one_input_error(tmp_path, kind):
    from pcnet.models.export import export_checkpoint

    junk = _write_junk(kind, tmp_path / "junk.pt")
    out = tmp_path / "x.onnx"
    with pytest.raises(InputError) as info:
        export_checkpoint(junk, out)
    message = str(info.value)
    assert message.startswith(f"{junk}: not a pcnet checkpoint (") and message.endswith(")")
    assert "\n" not in message and len(message) < 400, message
    assert "KeyError" not in message and "Error:" not in message, message  # words, not an exception's name
    assert not out.exists()


def test_random_bytes_through_the_command_line(tmp_path):
    junk = _write_junk("random bytes", tmp_path / "junk.pt")
    out = tmp_path / "x.onnx"
    _one_line_failure(_cli("export", "--checkpoint", junk, "--out", out), "junk.pt: not a pcnet checkpoint (")
    assert not out.exists()


def test_a_wrongly_typed_config_fails_in_one_line_before_creating_anything(tmp_path, mocap):
    cfg = _train_config(tmp_path, mocap, epochs="many")
    _one_line_failure(_cli("train", "--config", cfg), "cfg.toml", "'epochs'", "expected int")
    assert not (tmp_path / "run").exists()


def test_bad_data_or_no_val_split_creates_no_run_folder(tmp_path, mocap):
    cfg = _train_config(tmp_path, mocap, data=[str(tmp_path / "nope.npz")])
    _one_line_failure(_cli("train", "--config", cfg), "nope.npz")
    cfg = _train_config(tmp_path, mocap, data=[str(FIXTURES / "bandai_small.npz")])
    _one_line_failure(_cli("train", "--config", cfg), "no clips in the val split")
    assert not (tmp_path / "run").exists()


def test_lean_balanced_epochs_keep_their_length_and_a_finite_loss(tmp_path, mocap):
    """With lean_balance_cap the epoch draws from every frame, yet the batches cover only the
    draws: none is empty (an empty batch's loss is NaN)."""
    for cap in (0.0, 10.0):
        cfg = load_config(_train_config(tmp_path, mocap, name=f"cap{cap}.toml", lean_balance_cap=cap,
                                        out_dir=str(tmp_path / f"run{cap}")))
        train(cfg, progress=False)
        record = json.loads((tmp_path / f"run{cap}" / "metrics.jsonl").read_text())
        assert np.isfinite(record["train_total"]) and np.isfinite(record["val_rotation_deg"]), record
        assert cfg.lean_balance_cap == cap


def test_train_seed_and_out_dir_override_the_config(tmp_path, mocap):
    """Several runs of one recipe: ``--seed`` and ``--out-dir`` replace the config's values;
    a seed outside [0, 2**31 - 1] is one line, exit 1, and nothing is created."""
    cfg = _train_config(tmp_path, mocap, seed=5)
    res = _cli("train", "--config", cfg, "--seed", "12", "--out-dir", tmp_path / "seed12")
    assert res.exit_code == 0, res.output
    assert json.loads((tmp_path / "seed12" / "config.json").read_text())["seed"] == 12
    assert not (tmp_path / "run").exists()  # the config's out_dir was not used
    _one_line_failure(_cli("train", "--config", cfg, "--seed", "-1", "--out-dir", tmp_path / "bad"), "--seed")
    assert not (tmp_path / "bad").exists()


def test_a_real_checkpoint_round_trips_resumes_fine_tunes_and_exports(tmp_path, mocap, monkeypatch):
    cfg = load_config(_train_config(tmp_path, mocap))
    best = train(cfg, progress=False)
    for name in ("best.pt", "last.pt"):
        ck = torch.load(best.parent / name, map_location="cpu", weights_only=True)
        assert ck["kind"] == "pcnet" and ck["model_config"]["hidden"] == 16
    out = tmp_path / "tiny.onnx"
    res = _cli("export", "--checkpoint", best, "--out", out)
    assert res.exit_code == 0, res.output
    assert json.loads(out.with_suffix(".json").read_text())["model_config"]["hidden"] == 16
    # what the data files held, beside the weights: evaluation tells a training file from a decoy of its name
    from pcnet.stages.core.digest import sha256_file

    assert json.loads(out.with_suffix(".json").read_text())["training_config"]["data_sha256"] == [sha256_file(mocap)]
    # a run with weights whose record is not beside them says what it cannot know (pcnet evaluate
    # warned of it; a run said nothing to an ML trial)
    from pcnet.pipeline.config import RunConfig
    from pcnet.pipeline.runner import _assumed_inputs

    bare = tmp_path / "bare" / "tiny.onnx"
    bare.parent.mkdir()
    bare.write_bytes(out.read_bytes())
    config = dict(lifter="videopose3d", lifter_output=str(POSES), fps=30.0)
    assert _assumed_inputs(RunConfig(**config, weights=str(bare))) == [
        "--weights tiny.onnx: no training record beside them (the .json pcnet export writes), so what they trained on "
        "is unknown"]
    assert _assumed_inputs(RunConfig(**config, weights=str(out))) == []
    R, _, valid = PCNetSession(out).predict(np.load(POSES)[:8])
    assert valid.all() and np.allclose(R @ np.swapaxes(R, 1, 2), np.eye(3), atol=1e-5)

    # a run interrupted after its first epoch resumes from last.pt and runs only the epoch left
    from pcnet.models import train as training

    data = tmp_path / "lab.npz"  # the run's own copy: rewritten below
    data.write_bytes(mocap.read_bytes())
    two = dataclasses.replace(cfg, epochs=2, out_dir=str(tmp_path / "interrupted"), data=[str(data)])
    validate, calls = training.validate, []

    def interrupt_the_second_epoch(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return validate(*args, **kwargs)

    monkeypatch.setattr(training, "validate", interrupt_the_second_epoch)
    with pytest.raises(KeyboardInterrupt):
        train(two, progress=False)
    monkeypatch.undo()
    train(two, progress=False)
    folder = tmp_path / "interrupted"
    assert [json.loads(line)["epoch"] for line in (folder / "metrics.jsonl").read_text().splitlines()] == [1, 2]
    assert torch.load(folder / "last.pt", weights_only=True)["epoch"] == 1
    # resuming over data rewritten since would train on two data sets under one record (an ML
    # trial's resume went on without a word): refused, naming the file
    with np.load(data) as arrays:
        other = {name: arrays[name][::-1].copy() for name in arrays.files}
    np.savez(data, **other)
    with pytest.raises(InputError, match=rf"last\.pt: expected to resume over the data its run began with, got "
                                         rf"{re.escape(str(data))} changed since \(sha256 "):
        train(two, progress=False)
    np.savez(data, **{name: other[name][::-1].copy() for name in other})  # its first content again
    # resuming under another config would mix two runs (and restart the cosine schedule's
    # decay midway): refused; --no-resume starts the new config afresh, its metrics alone
    with pytest.raises(InputError, match=r"last\.pt: expected to resume the run of the same config, got changes "
                                         r"\(epochs 2 -> 3; seed 0 -> 4\)"):
        train(dataclasses.replace(two, epochs=3, seed=4), progress=False)
    train(dataclasses.replace(two, epochs=1, seed=4), resume=False, progress=False)
    assert [json.loads(line)["epoch"] for line in (folder / "metrics.jsonl").read_text().splitlines()] == [1]

    # fine-tuning from best.pt; a checkpoint of another architecture is one line
    tuned = train(dataclasses.replace(cfg, out_dir=str(tmp_path / "tuned"), init_checkpoint=str(best)),
                  progress=False)
    assert tuned.is_file()
    other = dataclasses.replace(cfg, out_dir=str(tmp_path / "other"), init_checkpoint=str(best),
                                model=dataclasses.replace(cfg.model, hidden=8))
    with pytest.raises(InputError, match=r"best\.pt: not a pcnet checkpoint \('model' does not fit"):
        train(other, progress=False)
    assert not (tmp_path / "other").exists()


def test_exported_weights_name_the_clips_of_a_file_trained_on_whole(tmp_path, mocap):
    """A file trained on whole (train_whole) has no split that evaluation could recompute, so
    its clip names travel with the weights (evaluation counts them where they are tested)."""
    whole = FIXTURES / "deepmimic_small.npz"
    cfg = load_config(_train_config(tmp_path, mocap, data=[str(mocap), str(whole)], train_whole=[False, True]))
    best = train(cfg, progress=False)
    out = tmp_path / "tiny.onnx"
    assert _cli("export", "--checkpoint", best, "--out", out).exit_code == 0
    record = json.loads(out.with_suffix(".json").read_text())["training_config"]
    assert record["train_whole"] == [False, True]
    assert record["whole_clips"] == sorted(np.load(whole).files)


def test_fine_tuned_weights_keep_the_earlier_runs_training_record(tmp_path, mocap):
    """A user trial fine-tuned from its own best.pt and exported: the .json named only the last
    run's epoch and data. The record now follows init_checkpoint back, and evaluation warns that
    the earlier run's data trained the weights too."""
    from pcnet.pipeline.evaluate import _fine_tuned_warning

    cfg = load_config(_train_config(tmp_path, mocap))
    best = train(cfg, progress=False)
    whole = FIXTURES / "deepmimic_small.npz"
    tuned = train(dataclasses.replace(cfg, out_dir=str(tmp_path / "tuned"), init_checkpoint=str(best),
                                      data=[str(mocap), str(whole)], train_whole=[False, True]), progress=False)
    out = tmp_path / "tuned.onnx"
    assert _cli("export", "--checkpoint", tuned, "--out", out).exit_code == 0
    record = json.loads(out.with_suffix(".json").read_text())["training_config"]
    assert record["data"] == [str(mocap), str(whole)] and record["init_checkpoint"] == str(best)
    assert record["init_training_config"]["data"] == [str(mocap)] and "init_checkpoint" not in record["init_training_config"]
    # every setting that shaped the weights (a review found the learning rate and the posture sigmas missing)
    for name in ("lr", "batch_size", "weight_decay", "trunk_sagittal_sigma_deg", "loss", "val_frames"):
        assert record[name] == dataclasses.asdict(cfg)[name], name
    assert not {"out_dir", "threads", "device", "model"} & set(record)
    assert _fine_tuned_warning(record) == (f"the weights were fine-tuned from {best} ({mocap.name}): the earlier runs' "
                                           f"data trained them too, and any overlap counted here is the last run's "
                                           f"data's alone")
    assert _fine_tuned_warning(record["init_training_config"]) is None


def test_weights_that_are_not_3dpcnet_onnx_fail_in_one_line(tmp_path):
    text = tmp_path / "weights.onnx"
    text.write_text("these are not weights\n")
    out = tmp_path / "out.npz"
    _one_line_failure(_cli("rectify", POSES, "--out", out, "--weights", text), "weights.onnx: not an ONNX model (")
    _one_line_failure(_cli("rectify", POSES, "--out", out, "--weights", tmp_path / "gone.onnx"),
                      "gone.onnx: expected an ONNX weights file, got no such file")
    from pcnet.pipeline import rectify  # a folder given in Python (a library user's trial: "no such file")

    with pytest.raises(InputError, match="expected an ONNX weights file, got a folder"):
        rectify(np.load(POSES)[:5], weights=str(tmp_path))
    # a training checkpoint given as weights names the export that turns it into ONNX
    checkpoint = tmp_path / "best.pt"
    torch.save({"kind": "pcnet", "model": {"w": torch.zeros(2)}}, checkpoint)
    _one_line_failure(_cli("rectify", POSES, "--out", out, "--weights", checkpoint),
                      "best.pt: not an ONNX model (", f"a training checkpoint? export it first: pcnet export "
                      f"--checkpoint {checkpoint} --out {tmp_path / 'best.onnx'}")
    # ... named .onnx already: the export it names writes another file (a user trial got its own path back)
    named = tmp_path / "ckpt.onnx"
    named.write_bytes(checkpoint.read_bytes())
    _one_line_failure(_cli("rectify", POSES, "--out", out, "--weights", named),
                      f"--checkpoint {named} --out {tmp_path / 'ckpt_exported.onnx'}")
    # a real ONNX model of another network (input 'features')
    other = tmp_path / "other.onnx"
    torch.onnx.export(torch.nn.Linear(51, 2), (torch.zeros(4, 51),), str(other), input_names=["features"],
                      output_names=["up"], dynamic_axes={"features": {0: "batch"}, "up": {0: "batch"}},
                      opset_version=18, dynamo=False)
    _one_line_failure(_cli("rectify", POSES, "--out", out, "--weights", other),
                      "other.onnx: not 3DPCNet weights", "features")
    assert not out.exists()


def test_no_code_path_loads_checkpoints_with_pickle():
    """Every torch.load in the package passes weights_only=True (a new call site must too)."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    calls = []
    for folder in ("adapters", "models", "pipeline", "stages"):
        for path in (root / folder).rglob("*.py"):
            calls += [(path.name, m.group(0)) for m in re.finditer(r"torch\.load\([^)]*\)", path.read_text())]
    assert calls, "no torch.load found: the check lost its target"
    assert all("weights_only=True" in call for _, call in calls), calls


# Type-correct but absurd values: refused right after loading, in one line naming the file
# and the field, before anything (out_dir, runs/) is created. Values are TOML literals.
TRAIN_BASE = {"epochs": "1", "batch_size": "64", "val_frames": "24", "frame_stride": "2", "threads": "1",
              "device": '"cpu"', "views": '"wide"', "out_dir": '"run"'}
TRAIN_MODEL = {"hidden": "16", "output": "24", "feedforward": "32", "heads": "2", "gcn_layers": "1",
               "transformer_layers": "1"}
BAD_TRAIN = [  # (field named in the message, top-level overrides, [model] overrides, [loss] overrides)
    ("epochs", {"epochs": "0"}, {}, {}),
    ("epochs", {"epochs": "-3"}, {}, {}),
    ("batch_size", {"batch_size": "0"}, {}, {}),
    ("lr", {"lr": "nan"}, {}, {}),
    ("lr", {"lr": "inf"}, {}, {}),
    ("lr", {"lr": "10"}, {}, {}),
    ("lr", {"lr": "0.0"}, {}, {}),
    ("lr", {"lr": "-1e-3"}, {}, {}),
    ("weight_decay", {"weight_decay": "50"}, {}, {}),
    ("weight_decay", {"weight_decay": "-0.1"}, {}, {}),
    ("frame_stride", {"frame_stride": "0"}, {}, {}),
    ("threads", {"threads": "-1"}, {}, {}),
    ("seed", {"seed": "-1"}, {}, {}),
    ("noise_fraction", {"noise_fraction": "20"}, {}, {}),
    ("noise_fraction", {"noise_fraction": "-0.5"}, {}, {}),
    ("noise_fraction", {"noise_fraction": "nan"}, {}, {}),
    ("val_frames", {"val_frames": "0"}, {}, {}),
    ("lean_balance_cap", {"lean_balance_cap": "0.5"}, {}, {}),  # a cap below 1 would down-weight upright poses
    ("lean_balance_cap", {"lean_balance_cap": "-1"}, {}, {}),
    ("views", {"views": '"bogus"'}, {}, {}),
    ("device", {"device": '"gpu"'}, {}, {}),
    ("device", {"device": '"cuda:x"'}, {}, {}),
    ("data", {"data": "[]"}, {}, {}),
    ("data", {"data": '[""]'}, {}, {}),
    ("out_dir", {"out_dir": '""'}, {}, {}),
    ("hidden", {}, {"hidden": "0"}, {}),
    ("heads", {}, {"heads": "3"}, {}),  # not a divisor of hidden 16
    ("heads", {}, {"heads": "-2"}, {}),
    ("dropout", {}, {"dropout": "1.0"}, {}),
    ("dropout", {}, {"dropout": "nan"}, {}),
    ("gcn_layers", {}, {"gcn_layers": "-1"}, {}),
    ("rot", {}, {}, {"rot": "-1.0"}),
    ("pose", {}, {}, {"pose": "inf"}),
]


def _toml(top, **tables):
    text = "".join(f"{k} = {v}\n" for k, v in top.items())
    for name, values in tables.items():
        text += f"[{name}]\n" + "".join(f"{k} = {v}\n" for k, v in values.items())
    return text


def _assert_refused_cleanly(res, tmp_path, config, field):
    lines = res.output.strip().splitlines()
    assert res.exit_code == 1, res.output
    assert isinstance(res.exception, SystemExit), res.exc_info  # no traceback: an InputError
    assert len(lines) == 1 and lines[0].startswith("Error: "), res.output
    assert config.name in lines[0] and f"'{field}'" in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == [config.name]  # no out_dir, no runs/


@pytest.mark.parametrize("field, top, model, loss", BAD_TRAIN,
                         ids=[f"{f}={next(iter({**t, **m, **l}.values()))}" for f, t, m, l in BAD_TRAIN])
def test_train_refuses_out_of_range_values_before_creating_anything(tmp_path, monkeypatch, mocap, field, top, model,
                                                                    loss):
    monkeypatch.chdir(tmp_path)
    config = tmp_path / "bad.toml"
    tables = {"model": {**TRAIN_MODEL, **model}} | ({"loss": loss} if loss else {})
    config.write_text(_toml({"data": json.dumps([str(mocap)]), **TRAIN_BASE, **top}, **tables))
    _assert_refused_cleanly(CliRunner().invoke(main, ["train", "--config", config.name]), tmp_path, config, field)


def test_the_ends_of_the_ranges_are_accepted(tmp_path, mocap):
    from pcnet.models.train import DEVICES, TRAIN_RANGES

    config = tmp_path / "edge.toml"
    config.write_text(_toml({"data": json.dumps([str(mocap)]), **TRAIN_BASE, "lr": "1.0", "weight_decay": "0",
                             "noise_fraction": "0.0", "seed": "0", "threads": "0", "device": '"cuda:0"'},
                            model={**TRAIN_MODEL, "dropout": "0.0", "gcn_layers": "0"}, loss={"reg": "0"}))
    cfg = load_config(config)
    assert cfg.lr == 1.0 and cfg.noise_fraction == 0.0 and cfg.model.gcn_layers == 0 and cfg.loss.reg == 0
    assert "cuda:<n>" in DEVICES and (0 in TRAIN_RANGES["lr"]) is False and 1 in TRAIN_RANGES["lr"]


def test_every_shipped_config_is_in_range():
    from pathlib import Path

    configs = sorted((Path(__file__).resolve().parents[1] / "configs").glob("*.toml"))
    assert configs
    for path in configs:
        load_config(path)


@pytest.mark.parametrize("out_dir, theirs", [(".", None), ("proj", ["config.json", "metrics.jsonl"]),
                                             ("proj", ["notes.txt"])])
def test_training_never_writes_into_a_folder_of_the_users(tmp_path, monkeypatch, out_dir, theirs):
    """A user's config.json / metrics.jsonl must not be taken for a run's (no last.pt)."""
    from pcnet.models.checkpoint import check_run_folder

    monkeypatch.chdir(tmp_path)
    for name in theirs or ():
        (tmp_path / out_dir).mkdir(exist_ok=True)
        (tmp_path / out_dir / name).write_text("mine\n")
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    with pytest.raises(ValueError, match="out_dir"):
        check_run_folder(out_dir)
    (tmp_path / "cfg.toml").write_text(f'data = ["{FIXTURES / "mocap_small.npz"}"]\nout_dir = "{out_dir}"\nepochs = 1\n')
    res = CliRunner().invoke(main, ["train", "--config", "cfg.toml"])
    assert res.exit_code == 1 and "out_dir" in res.output and "Traceback" not in res.output, res.output
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file() and p.name != "cfg.toml"} == before
