"""Small readers of the pipeline room: pcnet's own array files, and a lifter adapter's output
as ``pcnet run`` takes it."""

from __future__ import annotations

import difflib
import os
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

from pcnet.adapters.types import Poses3D
from pcnet.adapters.validate import NumpyArchive, describe_keys, nonfinite_frames
from pcnet.models.datasets import load_numpy_file
from pcnet.stages.core.conventions import H36M_JOINTS, validate_poses
from pcnet.stages.core.errors import InputError
from pcnet.stages.remap import remap_to_h36m


class PoseArray(NamedTuple):
    """What :func:`read_pose_array` read: the poses, and per H36M-17 joint the number of
    frames in which the file held a non-finite value (``inf``, NaN) for it (``nonfinite``) or
    a writer's placeholder for a joint not found (``placeholders``: zeros, or a frame on one
    point; :func:`pcnet.stages.core.conventions.placeholder_joints`), each read as missing (only
    joints with one; :func:`pcnet.adapters.validate.nonfinite_line` words them)."""

    joints: np.ndarray
    nonfinite: dict[str, int]
    placeholders: dict[str, int]


def load_pose_array(path: str | Path, key: str | None = None) -> np.ndarray:
    """Read ``(T, 17, 3)`` H36M-17 camera-frame poses from ``.npy`` or ``.npz`` (``key``
    names the array; optional when the npz holds exactly one): :func:`read_pose_array`'s
    ``joints``."""
    return read_pose_array(path, key).joints


def read_pose_array(path: str | Path, key: str | None = None) -> PoseArray:
    """Read ``(T, 17, 3)`` H36M-17 camera-frame poses from ``.npy`` or ``.npz`` (``key``
    names the array; optional when the npz holds exactly one), with the count of the
    file's non-finite values per joint.

    The array goes through :func:`pcnet.stages.core.conventions.validate_poses`, the check the
    API applies too: real numbers only, ``inf`` becomes NaN (missing), no unit is assumed
    so coordinates beyond 1e5 are refused.

    Returns:
        :class:`PoseArray`: float32 ``(T, 17, 3)`` joints; per joint, the frames in which
        the file held ``inf``/NaN (every NaN of ``joints`` is one: nothing else is missing yet).

    Raises:
        FileNotFoundError: missing file.
        InputError: not a numpy file (a CSV or random bytes is called that, not "pickled
            data"), a pickled object array, a damaged file, a missing/ambiguous key (at
            most 10 names listed), bool/complex/text values, wrong shape, no finite value,
            or a coordinate beyond the bound; one line naming the file.
    """
    path = Path(path)
    data = load_numpy_file(path, ".npy/.npz pose")
    if isinstance(data, NumpyArchive):
        with data:
            if key is None:
                if len(data.files) != 1:
                    raise InputError(f"file '{path}': field 'key': expected one array or --key naming one, got "
                                     f"{describe_keys(data.files)}")
                key = data.files[0]
            if key not in data.files:
                raise InputError(f"file '{path}': field 'key': expected an array named {key!r}, got "
                                 f"{describe_keys(data.files)}")
            arr = data[key]
    else:
        if key is not None:  # a key that would be silently ignored is a mistake
            raise InputError(f"{path}: --key {key!r}: expected no key for a single-array .npy file, got one")
        arr = data
    joints = validate_poses(arr, source=f"{path}{f' [{key}]' if key else ''}", units=None)
    # counted on the file's values: validation turned its placeholders into NaN too (a trial's
    # wrists written as zeros were called inf/NaN)
    held = np.isfinite(np.asarray(arr)).reshape(joints.shape).all(axis=2)  # no cast: any real dtype validation let in
    blanked = np.isnan(joints).any(axis=2) & held
    placeholders = {name: int(n) for name, n in zip(H36M_JOINTS, blanked.sum(axis=0)) if n}
    return PoseArray(joints, nonfinite_frames(np.where(held[..., None], 0.0, np.nan), H36M_JOINTS), placeholders)


def lifter_joints(poses: Poses3D, source: str, in_place: bool = False) -> np.ndarray:
    """H36M-17 camera-frame joints from a 3D adapter's output, as ``pcnet run`` reads every
    lifter: remapped from the adapter's layout (:func:`pcnet.stages.remap.remap_to_h36m`),
    then :func:`pcnet.stages.core.conventions.validate_poses` with the adapter's units.

    Args:
        poses: what a registered 3D adapter's ``load`` returned.
        source: the file named in errors.
        in_place: an H36M-17 float32 ``poses.joints`` is validated in place (a long
            recording is not copied; its placeholders become NaN there): for arrays the
            caller owns, as ``pcnet run`` owns what it loaded. Default: a new array, the
            input untouched.

    Returns:
        float32 ``(T, 17, 3)``, camera frame (OpenCV axes), the adapter's units; NaN = missing.

    Raises:
        InputError: see :func:`pcnet.stages.core.conventions.validate_poses`.
    """
    joints = poses.joints if poses.layout == "h36m17" else remap_to_h36m(poses.joints, poses.layout)
    return validate_poses(joints, source, poses.units, in_place=in_place and joints is poses.joints)


#: Files of a folder read to suggest a close name for a missing one (a folder of more is not listed).
CLOSE_FILE_LISTING = 10_000


def _numbers_unpadded(name: str) -> str:
    return re.sub(r"\d+", lambda m: str(int(m.group())), name)


def close_file(path: Path) -> str:
    """``"; a close name there: X"`` for the file of ``path``'s folder whose name is closest to
    its name (difflib's ratio >= 0.8, a typo's distance), ``""`` when none is or the folder is
    unreadable or too large to list (a batch trial's misspelt recording got no suggestion while
    a misspelt column did)."""
    try:
        with os.scandir(path.parent) as entries:
            names = [e.name for _, e in zip(range(CLOSE_FILE_LISTING + 1), entries) if e.is_file()]
    except OSError:
        return ""
    if len(names) > CLOSE_FILE_LISTING:
        return ""
    # the same numbers written with other leading zeros first (a trial's a7_s1_t1.npz got a17_s1_t1.npz,
    # one character away as a07_s1_t1.npz is)
    wanted = _numbers_unpadded(path.name)
    same = [n for n in names if _numbers_unpadded(n) == wanted]
    match = same or difflib.get_close_matches(path.name, names, n=1, cutoff=0.8)
    return f"; a close name there: {match[0]}" if match else ""
