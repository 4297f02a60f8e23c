"""The ablation benchmarks' evidence cache (benchmarks/ablation.py ``save_records`` /
``load_records``): a list of dicts round-trips through an ``.npz`` read with
``allow_pickle=False`` (no file is ever loaded in a way that can execute code)."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from conftest import ROOT

if str(ROOT) not in sys.path:  # benchmarks/ is a package of the repository, not of the installed pcnet
    sys.path.append(str(ROOT))
from benchmarks.ablation import load_records, save_records  # noqa: E402


def _records() -> list[dict]:
    """Two records with the value kinds the builders cache (``extract`` and the set builders)."""
    rng = np.random.default_rng(0)
    return [
        {"fps": 30.0, "J": rng.normal(size=(5, 17, 3)).astype(np.float32), "R_body": rng.normal(size=(5, 3, 3)),
         "valid": np.array([True, False, True, True, False]), "turns": np.array([0, 1, 0, -1, 2], np.int64),
         "weight": np.array([0.1, np.nan, 0.5, 1.0, 0.0]), "real_mode": "sequence", "real_posture": None,
         "ground_plane_used": False, "name": "clip_01", "roll": -90, "Q": np.eye(3),
         "meta": {"source": "bandai", "scale": np.float32(0.5), "nested": {"n": 3, "none": None}, "empty": {}},
         "small": np.array([1, 2], np.uint8), "scalar_array": np.array(2.5), "text": np.array(["a", "bc"]),
         "empty_array": np.zeros((0, 3), np.float16), "unicode": "Padmasana \u00e9", "blank": ""},
        {"fps": 15.0, "J": np.zeros((2, 17, 3), np.float32), "real_posture": "lying", "ground_plane_used": True,
         "name": "export_x_Shavasana.npy", "asana": "Shavasana"},
        {},
    ]


def _assert_same(a, b, where="") -> None:
    assert type(a) is type(b), (where, type(a), type(b))
    if isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            _assert_same(a[k], b[k], f"{where}/{k}")
    elif isinstance(a, (np.ndarray, np.generic)):
        assert a.dtype == b.dtype and np.shape(a) == np.shape(b), where
        np.testing.assert_array_equal(a, b, err_msg=where)
    elif isinstance(a, float) and np.isnan(a):
        assert np.isnan(b), where
    else:
        assert a == b, where


def test_records_round_trip(tmp_path):
    records = _records()
    path = tmp_path / "evidence.npz"
    save_records(path, records)
    back = load_records(path)
    assert len(back) == len(records)
    for i, (a, b) in enumerate(zip(records, back)):
        _assert_same(a, b, str(i))
    assert [p.name for p in tmp_path.iterdir()] == ["evidence.npz"]  # no temporary file left
    with np.load(path, allow_pickle=False) as z:  # plain arrays only: readable without pickle
        for key in z.files:
            assert not z[key].dtype.hasobject, key
    save_records(tmp_path / "none.npz", [])
    assert load_records(tmp_path / "none.npz") == []


@pytest.mark.parametrize("bad", [[{"x": [1, 2]}], [{"x": np.array([None, 1], dtype=object)}], [{"a/b": 1}],
                                 ({"x": 1},)])
def test_records_refuse_what_needs_pickle(tmp_path, bad):
    with pytest.raises((TypeError, ValueError)):
        save_records(tmp_path / "bad.npz", bad)
    assert not list(tmp_path.iterdir())


def test_pickled_file_refused(tmp_path):
    path = tmp_path / "pickled.npz"
    np.savez(path, **{"__count__": np.asarray(1), "__manifest__": np.array([["0/x", "array"]]),
                      "0/x": np.array([object()], dtype=object)})
    with pytest.raises(ValueError):
        load_records(path)
