"""Whole-recording arrays on disk (stages/core/framestore.py): what ``pcnet run`` keeps out of
memory for a long recording. Real data: the bundled MotionBERT output of the boxing example
(``tests/fixtures/boxing_X3D_f000-059.npy``, see fixtures/README.md)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import FIXTURES

import pcnet.stages.core.framestore as framestore
from pcnet.stages.core.framestore import FrameArray, FrameStore, column, per_frame
from pcnet.stages.sinks.exports import write_npz


@pytest.fixture(scope="module")
def poses() -> np.ndarray:
    return np.load(FIXTURES / "boxing_X3D_f000-059.npy", allow_pickle=False)


def test_a_stored_array_reads_back_what_was_written_by_blocks_slices_and_columns(tmp_path, poses, monkeypatch):
    monkeypatch.setattr(framestore, "BLOCK_FRAMES", 7)  # many blocks, a column read crossing each edge
    with FrameStore(tmp_path) as store:
        a = store.create("poses", poses.shape, np.float32)
        assert np.isnan(a[:]).all()  # created NaN: missing until written
        for rows in a.blocks():
            a[rows] = poses[rows]
        np.testing.assert_array_equal(a[:], poses)
        np.testing.assert_array_equal(a[13:29], poses[13:29])
        np.testing.assert_array_equal(a[-1], poses[-1])
        np.testing.assert_array_equal(a[:, 3], poses[:, 3])
        np.testing.assert_array_equal(a[:, [1, 4], :2], poses[:, [1, 4], :2])
        lazy = column(a, 16, 1)
        assert lazy.shape == (len(poses),)
        np.testing.assert_array_equal(lazy[5:9], poses[5:9, 16, 1])
        np.testing.assert_array_equal(lazy[3:40], poses[3:40, 16, 1])  # across five block edges
        np.testing.assert_array_equal(np.asarray(lazy), poses[:, 16, 1])
        a.flush()
        np.testing.assert_array_equal(np.load(a.path, allow_pickle=False), poses)  # a plain .npy file
        read_only = FrameArray(a.path, a.shape, a.dtype, a._offset, writable=False)
        np.testing.assert_array_equal(read_only[2:5], poses[2:5])
        with pytest.raises(ValueError, match="read-only"):
            read_only[0:1] = 0.0
        read_only.close()
        folder = store.folder
        assert folder.parent == tmp_path and folder.is_dir()
    assert not folder.exists() and tmp_path.is_dir()  # removes its own folder only


def test_a_column_of_a_long_array_is_read_without_holding_the_array(tmp_path, monkeypatch):
    """Reading one joint of every frame holds one block of frames at a time besides the
    column itself, not the whole array (numpy's allocations, traced by tracemalloc)."""
    import tracemalloc

    monkeypatch.setattr(framestore, "BLOCK_FRAMES", 1000)
    frames = 20000
    with FrameStore(tmp_path) as store:
        a = store.create("world", (frames, 17, 3), np.float64)  # 8.2 MB on disk
        for rows in a.blocks():
            a[rows] = np.arange(rows.start, rows.stop, dtype=float)[:, None, None]
        tracemalloc.start()
        try:
            wrist = a[:, 16]
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        np.testing.assert_array_equal(wrist[:, 0], np.arange(frames))
        assert peak < wrist.nbytes + 3 * 1000 * 17 * 3 * 8, peak  # the column and a block or so, not 8.2 MB


def test_per_frame_results_computed_block_by_block_equal_the_whole(tmp_path, poses, monkeypatch):
    monkeypatch.setattr(framestore, "BLOCK_FRAMES", 7)
    complete = lambda P: np.isfinite(P).all(axis=(1, 2))  # noqa: E731
    with FrameStore(tmp_path) as store:
        a = store.create("poses", poses.shape, np.float32)
        a[0:len(poses) - 3] = poses[:-3]  # the last three frames stay missing
        expected = np.arange(len(poses)) < len(poses) - 3
        np.testing.assert_array_equal(per_frame(complete, a), expected)
        np.testing.assert_array_equal(per_frame(complete, poses), np.ones(len(poses), bool))
        assert per_frame(complete, poses[:0]).shape == (0,)


def test_a_pose_sized_array_on_disk_refuses_a_whole_read_but_a_column_may(tmp_path, poses):
    with FrameStore(tmp_path) as store:
        a = store.create("poses", poses.shape, np.float32)
        with pytest.raises(TypeError, match="block at a time"):
            np.asarray(a)
        with pytest.raises(TypeError, match="contiguous"):
            a[::2]
        b = store.create("valid", (len(poses),), bool, fill=None)
        b[0:10] = True
        assert np.asarray(b).sum() == 10


def test_npz_members_copied_from_disk_load_as_the_in_memory_arrays(tmp_path, poses):
    """canonical.npz takes a long recording's arrays from their .npy files without reading them
    whole; the archive loads like np.savez's, without pickle."""
    with FrameStore(tmp_path) as store:
        a = store.create("joints_camera", poses.shape, np.float32)
        a[0 : len(poses)] = poses
        write_npz(tmp_path / "disk.npz", joints_camera=a, fps=30.0, report={"mode": "sequence"})
    np.savez(tmp_path / "memory.npz", joints_camera=poses, fps=30.0)
    with np.load(tmp_path / "disk.npz", allow_pickle=False) as d, np.load(tmp_path / "memory.npz") as m:
        assert sorted(d.files) == ["fps", "joints_camera", "report"]
        np.testing.assert_array_equal(d["joints_camera"], m["joints_camera"])
        assert d["joints_camera"].dtype == np.float32 and float(d["fps"]) == 30.0
