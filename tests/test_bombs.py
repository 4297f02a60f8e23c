"""Bombs (issue 53): inputs whose cost is out of proportion to their size are refused from
what they declare, before the cost is paid, in one line naming the file.

* ``.npz`` members: the zip directory's sizes (a member's expansion, the archive's against
  the file's size, compressed bytes within the file) and the ``.npy`` header's shape against
  the member and the memory available
  (:data:`pcnet.adapters.validate.NPZ_MAX_EXPANSION`, :func:`~pcnet.adapters.validate.available_memory`).
* TOML configs nested (arrays, inline tables, dotted keys) deeper than
  :data:`pcnet.models.toml_config.MAX_TOML_NESTING`; JSON files nested deeper than the
  parser follows.

The bombs are built at test time: a deflate stream of zeros is one compressed chunk repeated
(each ends in a full flush, so it refers to nothing before it), which writes a 1 MB file
declaring 1 GB in a fraction of a second.
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
import time
import tomllib
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from pcnet.adapters import validate
from pcnet.adapters.types import AdapterError
from pcnet.adapters.validate import (NPZ_EXPANSION_FREE_BYTES, NPZ_MAX_EXPANSION, available_memory,
                                     load_array_file, open_numpy)
from pcnet.models.datasets import load_mocap
from pcnet.models.toml_config import MAX_TOML_NESTING, read_toml, toml_nesting
from pcnet.pipeline.cli import main
from pcnet.pipeline.io import load_pose_array
from pcnet.stages.core.errors import InputError

GB = 10**9
_CHUNK = 1 << 24


def _npy_header(shape: tuple, dtype: str = "<f8") -> bytes:
    out = io.BytesIO()
    np.lib.format.write_array_header_1_0(out, {"descr": dtype, "fortran_order": False, "shape": shape})
    return out.getvalue()


def _deflated(data: bytes) -> bytes:
    """Raw deflate blocks of ``data`` ending in a full flush: they can be repeated or followed."""
    co = zlib.compressobj(9, zlib.DEFLATED, -15)
    return co.compress(data) + co.flush(zlib.Z_FULL_FLUSH)


def _member(header: bytes, zeros: int, claim: int | None = None) -> tuple[bytes, int, int]:
    """(deflate stream, crc, declared size) of a ``.npy`` member: ``header`` then ``zeros``
    zero bytes; ``claim`` (default: the true size) is the size its directory entry declares."""
    full, rest = divmod(zeros, _CHUNK)
    chunk = bytes(_CHUNK)
    crc = zlib.crc32(header)
    for _ in range(full):
        crc = zlib.crc32(chunk, crc)
    crc = zlib.crc32(bytes(rest), crc)
    stream = b"".join([_deflated(header), _deflated(chunk) * full, _deflated(bytes(rest)),
                       zlib.compressobj(9, zlib.DEFLATED, -15).flush()])
    return stream, crc, len(header) + zeros if claim is None else claim


def _zero_member(shape: tuple, dtype: str = "<f8", claim: int | None = None) -> tuple[bytes, int, int]:
    """A ``.npy`` member of zeros of ``shape``, its data cut to 1 GB (``claim``: see :func:`_member`)."""
    return _member(_npy_header(shape, dtype), min(int(np.prod(shape)) * np.dtype(dtype).itemsize, GB), claim)


def write_bomb(path: Path, members: dict[str, tuple[bytes, int, int]]) -> Path:
    """An ``.npz`` whose members are deflate ``(stream, crc, declared size)``: each stream is
    written stored, then its directory entry is relabelled deflated with the declared size
    (zipfile reads a member's method and sizes from the central directory)."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED, allowZip64=True) as zf:
        for name, (stream, crc, size) in members.items():
            with zf.open(zipfile.ZipInfo(name + ".npy"), "w", force_zip64=True) as fh:
                fh.write(stream)
            info = zf.getinfo(name + ".npy")
            info.compress_type, info.file_size, info.CRC = zipfile.ZIP_DEFLATED, size, crc
    return path


@pytest.fixture(scope="module")
def gigabyte_bomb(tmp_path_factory) -> Path:
    """1 MB that decompresses to 1 GB: zeros shaped as (T, 17, 3) float64 poses, every size
    it declares true (a valid archive np.load reads)."""
    return write_bomb(tmp_path_factory.mktemp("bomb") / "bomb.npz", {"poses": _zero_member((GB // 408, 17, 3))})


def test_the_bomb_is_a_valid_archive_of_what_it_declares(tmp_path):
    """The builder writes archives numpy reads (small scale): the tests below refuse real bombs."""
    path = write_bomb(tmp_path / "small.npz", {"a": _zero_member((3000, 17, 3)), "b": _zero_member((5,), "<f4")})
    with np.load(path) as data:
        assert data["a"].shape == (3000, 17, 3) and not data["a"].any() and data["b"].shape == (5,)
    with open_numpy(path) as archive:
        assert archive["a"].shape == (3000, 17, 3)


def test_gigabyte_bomb_is_refused_from_its_directory(gigabyte_bomb, monkeypatch):
    """Refused before any member is opened, naming the file, the member, the bound and the sizes."""
    assert gigabyte_bomb.stat().st_size < 2 * 10**6
    info = zipfile.ZipFile(gigabyte_bomb).getinfo("poses.npy")
    assert info.file_size > 0.99 * GB

    def no_decompressing(*args, **kwargs):
        raise AssertionError("a member was opened")

    monkeypatch.setattr(zipfile.ZipFile, "open", no_decompressing)
    start = time.perf_counter()
    with pytest.raises(AdapterError) as err:
        load_array_file(gigabyte_bomb)
    assert time.perf_counter() - start < 2
    msg = str(err.value)
    assert "bomb.npz" in msg and "'poses'" in msg and f"at most {NPZ_MAX_EXPANSION} times" in msg, msg
    assert "1 GB from" in msg and "zip bomb" in msg and "\n" not in msg, msg
    with pytest.raises(InputError, match=r"bomb.npz: not a readable .* file \(member 'poses': expected at most 100 "):
        load_pose_array(gigabyte_bomb)


def test_declared_shape_is_checked_against_the_member(tmp_path):
    """A (10**9, 17, 3) float64 header: refused whether the directory declares the 408 GB too
    (its expansion) or the member's true size (the header asks for more than it holds)."""
    shape = (10**9, 17, 3)
    lying = write_bomb(tmp_path / "lying.npz", {"poses": _zero_member(shape, claim=408 * GB + 128)})
    honest = write_bomb(tmp_path / "honest.npz", {"poses": _member(_npy_header(shape), 408_000)})
    start = time.perf_counter()
    with pytest.raises(AdapterError, match=r"'poses'.*zip bomb"):
        load_array_file(lying)
    with pytest.raises(AdapterError, match=r"'poses'.*408000000000 bytes of data for shape \(1000000000, 17, 3\)"):
        load_array_file(honest)
    assert time.perf_counter() - start < 5


def test_compressed_sizes_must_lie_within_the_file(tmp_path):
    path = write_bomb(tmp_path / "claims.npz", {"poses": _zero_member((100, 17, 3))})
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo("poses.npy")
    # The central directory's compressed size, after its signature and 16 bytes of fields.
    at = data.rindex(b"PK\x01\x02") + 20
    assert int.from_bytes(data[at:at + 4], "little") == info.compress_size
    data[at:at + 4] = (10**9).to_bytes(4, "little")
    path.write_bytes(bytes(data))
    with pytest.raises(AdapterError, match=r"'poses'.*compressed bytes within the file's .*1 GB declared"):
        load_array_file(path)


def test_many_small_members_are_bounded_together(tmp_path):
    """Each member alone is below the free size; together they expand 1000 times the file."""
    member = _zero_member((NPZ_EXPANSION_FREE_BYTES // 10 // 408, 17, 3))
    path = write_bomb(tmp_path / "clips.npz", {f"clip{i:02d}": member for i in range(12)})
    start = time.perf_counter()
    with pytest.raises(InputError, match=r"clips.npz: not a readable mocap .npz file \(expected at most 100 times the "
                                         r"file's size .*zip bomb"):
        load_mocap(path)
    assert time.perf_counter() - start < 2


def test_legitimate_large_and_compressible_arrays_still_load(tmp_path):
    """Stored (np.savez) arrays beyond the free size expand 1 time; compressed zeros below it
    any amount; both load, in C order and across read chunks."""
    big = np.arange(NPZ_EXPANSION_FREE_BYTES // 8 + 3_000_000, dtype=np.float64)  # > 100 MB, several chunks
    np.savez(tmp_path / "stored.npz", poses=big)
    assert np.array_equal(load_array_file(tmp_path / "stored.npz"), big)
    del big
    zeros = np.zeros((50_000, 17, 3), np.float64)  # 20 MB of zeros, about 1000 times compressed
    np.savez_compressed(tmp_path / "zeros.npz", poses=zeros)
    assert np.array_equal(load_array_file(tmp_path / "zeros.npz"), zeros)


@pytest.mark.parametrize("arr", [
    np.arange(24, dtype=">f4").reshape(2, 3, 4), np.asfortranarray(np.arange(24.0).reshape(4, 6)),
    np.array(["hip", "knee"]), np.array([True, False]), np.zeros((0, 17, 3)), np.float64(2.5),
], ids=["big-endian", "fortran", "text", "bool", "empty", "scalar"])
def test_the_chunked_reader_reads_what_numpy_reads(tmp_path, arr):
    np.save(tmp_path / "a.npy", arr)
    np.savez_compressed(tmp_path / "a.npz", a=arr)
    for name in ("a.npy", "a.npz"):
        got = load_array_file(tmp_path / name)
        assert got.dtype == arr.dtype and got.shape == arr.shape and np.array_equal(got, arr)
        assert got.flags.c_contiguous and got.flags.writeable


def test_arrays_beyond_half_the_available_memory_are_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(validate, "available_memory", lambda: 50_000_000)
    np.save(tmp_path / "big.npy", np.zeros((60_000, 17, 3)))  # 24.5 MB: loads
    assert load_array_file(tmp_path / "big.npy").shape == (60_000, 17, 3)
    np.save(tmp_path / "big.npy", np.zeros((70_000, 17, 3)))  # 28.6 MB: more than half of 50 MB
    np.savez(tmp_path / "big.npz", poses=np.zeros((70_000, 17, 3)))
    with pytest.raises(AdapterError, match=r"'content': expected an array of at most 25 MB \(half the 50 MB of memory"):
        load_array_file(tmp_path / "big.npy")
    with pytest.raises(InputError, match=r"big.npz'?: field 'poses': expected an array of at most 25 MB .* got shape "
                                         r"\(70000, 17, 3\) float64, 28.6 MB"):
        load_pose_array(tmp_path / "big.npz")


def test_available_memory_is_this_machines():
    memory = available_memory()
    if memory is None:
        pytest.skip("the system does not say")
    total = next((int(line.split()[1]) * 1024 for line in Path("/proc/meminfo").read_text().splitlines()
                  if line.startswith("MemTotal:")), None) if Path("/proc/meminfo").exists() else None
    assert 0 < memory <= (total or memory)


def _measured(args: list[str], cwd: Path) -> tuple[subprocess.CompletedProcess, float, int]:
    """``pcnet ARGS`` in a child of a child: (result, seconds, peak resident bytes of pcnet
    alone: the middle process's RUSAGE_CHILDREN sees only it)."""
    probe = ("import json, resource, subprocess, sys, time\n"
             "start = time.perf_counter()\n"
             "res = subprocess.run(sys.argv[1:], capture_output=True, text=True)\n"
             "print(json.dumps([res.returncode, res.stdout, res.stderr, time.perf_counter() - start,\n"
             "                  resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss]))\n")
    out = subprocess.run([sys.executable, "-c", probe, sys.executable, "-m", "pcnet.pipeline.entry", *args],
                         capture_output=True, text=True, cwd=cwd, timeout=300, check=True)
    code, stdout, stderr, seconds, peak_kb = json.loads(out.stdout)
    return subprocess.CompletedProcess(args, code, stdout, stderr), seconds, peak_kb * 1024


def _one_line_naming(res, name: str) -> None:
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 1 and len(lines) == 1 and name in lines[0], res.stderr[-2000:]
    assert "Traceback" not in res.stderr + res.stdout


def test_rectify_refuses_the_gigabyte_bomb_in_seconds_and_little_memory(gigabyte_bomb, tmp_path):
    """The real entry point: exit 1, one line naming the file, well under 30 s and 1 GB
    (before the bound: 27-85 s and 2.7-3.7 GB, then a refusal of the zeros as poses)."""
    res, seconds, peak = _measured(["rectify", str(gigabyte_bomb), "--out", str(tmp_path / "o.npz")], tmp_path)
    _one_line_naming(res, "bomb.npz")
    assert "zip bomb" in res.stderr and "'poses'" in res.stderr
    assert seconds < 30 and peak < GB, (seconds, peak)
    assert not (tmp_path / "o.npz").exists()


# --------------------------------------------------------------------------- nesting


def _deep_toml(kind: str, depth: int) -> str:
    if kind == "arrays":
        return "height = " + "[" * depth + "]" * depth + "\n"
    if kind == "inline tables":
        return "height = " + "{a = " * depth + "1" + "}" * depth + "\n"
    if kind == "dotted key":
        return "height" + ".a" * (depth - 1) + " = 1\n"
    return "[model" + ".a" * (depth - 1) + "]\nx = 1\n"  # a table header


@pytest.mark.parametrize("kind", ["arrays", "inline tables", "dotted key", "table header"])
def test_deep_toml_is_refused_before_parsing(tmp_path, kind):
    """100,000 levels: arrays and inline tables would be a RecursionError in tomllib, a dotted
    key of 100,000 parts gigabytes (tomllib keeps every prefix)."""
    path = tmp_path / "deep.toml"
    path.write_text(_deep_toml(kind, 100_000))
    start = time.perf_counter()
    with pytest.raises(InputError) as err:
        read_toml(path)
    assert str(err.value) == f"{path}: not a readable TOML config (nesting deeper than {MAX_TOML_NESTING} levels)"
    assert time.perf_counter() - start < 2
    path.write_text(_deep_toml(kind, MAX_TOML_NESTING))  # the bound itself parses
    assert "height" in read_toml(path) or "model" in read_toml(path)


def test_toml_nesting_reads_past_strings_and_comments():
    text = ('[[runs.one]]\nname = "a.b.c.d.e [[[[ {{{{"  # ]]]] a.b.c.d.e.f.g\n'
            "x = [1.5, 2.5, {y = 1979-05-27T07:32:00.5}]\nz = '''\n[[[[[[.....\n'''\nw = \"\"\"\n\\\"\"\" [[[[[[\n\"\"\"\n")
    assert tomllib.loads(text)["runs"]["one"][0]["w"] == '""" [[[[[[\n'  # valid TOML, brackets only in text
    assert toml_nesting(text) == 2
    assert toml_nesting("x." * 7 + "x = 1") == 8 and toml_nesting("x = " + "[" * 7) == 7


@pytest.mark.parametrize("command", ["run", "train"])
def test_cli_refuses_a_deep_toml_config_in_one_line(tmp_path, command, monkeypatch):
    if command == "train":  # pcnet train checks its torch first (tests/test_safety.py: ..._without_torch_...)
        pytest.importorskip("torch", reason='pcnet train needs torch (pip install "pcnet[train]")')
    monkeypatch.chdir(tmp_path)
    Path("deep.toml").write_text(_deep_toml("arrays", 100_000))
    res = CliRunner().invoke(main, [command, "--config", "deep.toml"])
    assert res.exit_code == 1 and res.output.strip().count("\n") == 0, res.output[-2000:]
    assert "deep.toml: not a readable TOML config (nesting deeper than 100 levels)" in res.output


def test_cli_run_refuses_a_deep_toml_config_by_the_entry_point(tmp_path):
    (tmp_path / "deep.toml").write_text(_deep_toml("dotted key", 100_000))
    res, seconds, peak = _measured(["run", "--config", "deep.toml"], tmp_path)
    _one_line_naming(res, "deep.toml")
    assert seconds < 30 and peak < GB, (seconds, peak)


DEEP_JSON = "[" * 100_000 + "]" * 100_000


def test_deep_mocap_sidecar_json_is_one_line_naming_it(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    np.savez("mocap.npz", clip=np.zeros((3, 17, 3), np.float32))
    Path("mocap.json").write_text(DEEP_JSON)
    res = CliRunner().invoke(main, ["evaluate", "--method", "geometric", "--data", "mocap.npz"])
    assert res.exit_code == 1 and res.output.strip().count("\n") == 0, res.output[-2000:]
    assert "mocap.json: expected the mocap's JSON metadata, got unreadable content" in res.output


def test_deep_json_beside_weights_is_one_line_naming_it(tmp_path, monkeypatch):
    from pcnet.models.inference import DEFAULT_WEIGHTS

    monkeypatch.chdir(tmp_path)
    Path("w.onnx").write_bytes(Path(DEFAULT_WEIGHTS).read_bytes())
    Path("w.json").write_text(DEEP_JSON)
    np.save("poses.npy", np.random.default_rng(0).normal(size=(4, 17, 3)).astype(np.float32))
    res = CliRunner().invoke(main, ["rectify", "poses.npy", "--out", "o.npz", "--weights", "w.onnx"])
    assert res.exit_code == 1 and res.output.strip().count("\n") == 0, res.output[-2000:]
    assert "w.json: not readable JSON beside the weights" in res.output


def test_deep_json_markers_read_as_not_pcnets(tmp_path):
    """Files pcnet only looks at to tell its own outputs: a deep one is not pcnet's, no error
    (the training record beside a checkpoint: the next test, which needs torch)."""
    from pcnet.pipeline.batch_marker import BATCH_MARKER, read_batch_marker
    from pcnet.pipeline.cli import _json_object_with

    (tmp_path / "config.json").write_text(DEEP_JSON)
    (tmp_path / BATCH_MARKER).write_text(DEEP_JSON)
    assert read_batch_marker(tmp_path) == {}
    assert _json_object_with(tmp_path / "config.json", {"method"}) is False


def test_a_deep_training_record_beside_a_checkpoint_reads_as_none(tmp_path):
    """models/export.py reads config.json beside a checkpoint to name what the weights were
    trained on: a deep one reads as no record, no error (export needs torch)."""
    pytest.importorskip("torch", reason='pcnet export needs torch (pip install "pcnet[train]")')
    from pcnet.models.export import training_record

    (tmp_path / "config.json").write_text(DEEP_JSON)
    assert training_record(tmp_path / "best.pt") == {}
