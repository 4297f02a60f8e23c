"""Small file readers of the pipeline room (pcnet's own array files)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pcnet.models.datasets import load_numpy_file


def load_pose_array(path: str | Path, key: str | None = None) -> np.ndarray:
    """Read ``(T, 17, 3)`` H36M-17 camera-frame poses from ``.npy`` or ``.npz`` (``key``
    names the array; optional when the npz holds exactly one).

    Raises:
        FileNotFoundError: missing file.
        ValueError: unreadable file, missing/ambiguous key, or wrong shape, naming the file.
    """
    path = Path(path)
    data = load_numpy_file(path, ".npy/.npz pose")
    if isinstance(data, np.lib.npyio.NpzFile):
        with data:
            if key is None:
                if len(data.files) != 1:
                    raise ValueError(f"{path}: holds arrays {data.files}; choose one with --key")
                key = data.files[0]
            if key not in data.files:
                raise ValueError(f"{path}: no array {key!r}; it holds {data.files}")
            arr = data[key]
    else:
        arr = data
    if arr.ndim != 3 or arr.shape[1:] != (17, 3):
        raise ValueError(f"{path}{f' [{key}]' if key else ''}: expected (T, 17, 3) H36M-17 poses, got {arr.shape}")
    return arr.astype(np.float32)
