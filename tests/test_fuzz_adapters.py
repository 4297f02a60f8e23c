"""Property-based fuzzing of every adapter and pcnet's own array readers.

The property, for any input: the call either returns a result that obeys the conventions
(float32 ``(T, J, 3)``, finite or NaN, never inf, 2D confidence in [0, 1], coordinates
within ``MAX_ABS_COORDINATE`` for their units, a missing 2D joint NaN in all channels), or
raises :class:`pcnet.stages.core.errors.InputError` (``AdapterError`` is one) whose message is
one line. Any other exception, and any numpy warning (run as errors), fails the test.

Inputs: random bytes; truncated and garbled copies of the real fixtures; JSON of random
structure; JSON shaped like each writer's output with hostile values (huge, negative and
textual frame indices, NaN/Infinity, booleans, huge integers); numpy arrays of random
shape, dtype and NaN/inf/huge patterns, as ``.npy`` and inside MediaPipe-like ``.npz``.

Hypothesis runs derandomized (fixed examples, reproducible in CI) with a small example
budget per test; the whole file takes seconds. For a deeper hunt set
``PCNET_FUZZ_EXAMPLES=2000`` (and ``PCNET_FUZZ_RANDOM=1`` for fresh random examples).
"""

from __future__ import annotations

import json
import os
import tempfile
import warnings
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from conftest import FIXTURES
from pcnet.adapters import (
    AdapterError,
    Keypoints2D,
    Poses3D,
    VideoInfo,
    load_alphapose,
    load_ddhpose,
    load_generic,
    load_mediapipe_2d,
    load_mediapipe_3d,
    load_mmpose,
    load_motionbert,
    load_openpose,
    load_videopose3d,
    probe_video,
)
from pcnet.adapters.validate import checked_keypoints, describe_keys, frame_count_for
from pcnet.models.datasets import load_numpy_file
from pcnet.pipeline.io import load_pose_array
from pcnet.stages.core.conventions import MAX_ABS_COORDINATE, get_layout
from pcnet.stages.core.errors import InputError

FUZZ = settings(
    max_examples=int(os.environ.get("PCNET_FUZZ_EXAMPLES", "40")),
    deadline=None,
    derandomize=not os.environ.get("PCNET_FUZZ_RANDOM"),
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
)

ALPHAPOSE = FIXTURES / "alphapose809_f130-159.json"
BOXING_AP = FIXTURES / "boxing_alphapose_f000-059.json"
MEDIAPIPE = FIXTURES / "mediapipe_blazepose33_f000-059.npz"
BOXING_X3D = FIXTURES / "boxing_X3D_f000-059.npy"
YOGA = sorted(FIXTURES.glob("yoga_*.npy"))
CLIP = FIXTURES / "boxing2_f000-009.mp4"


def _load_numpy_file(path: Path) -> Any:
    """``load_numpy_file`` plus reading every member, as its callers do."""
    data = load_numpy_file(Path(path), "fuzz")
    if isinstance(data, np.lib.npyio.NpzFile):
        with data:
            return [data[k] for k in data.files]
    return [data]


# name -> (call on a path, file suffix). Every numpy- and JSON-reading entry point.
JSON_LOADERS: dict[str, Callable[[Path], Any]] = {
    "alphapose": load_alphapose,
    "alphapose+frame_count": lambda p: load_alphapose(p, frame_count=200),
    "mmpose": load_mmpose,
    "mmpose+frame_count": lambda p: load_mmpose(p, frame_count=200, person=0),
}
NPY_LOADERS: dict[str, Callable[[Path], Any]] = {
    "motionbert": load_motionbert,
    "motionbert-pixel": lambda p: load_motionbert(p, pixel=True),
    "ddhpose": load_ddhpose,
    "ddhpose-hyp0": lambda p: load_ddhpose(p, hypothesis=0),
    "videopose3d": load_videopose3d,
    "generic": load_generic,
    "generic-coco-cm": lambda p: load_generic(p, layout="coco17", axes="RUB", units="cm"),
    "generic-flat-px": lambda p: load_generic(p, units="px"),
    "load_pose_array": load_pose_array,
    "load_numpy_file": _load_numpy_file,
}
NPZ_LOADERS: dict[str, Callable[[Path], Any]] = {
    "mediapipe-2d": load_mediapipe_2d,
    "mediapipe-3d": load_mediapipe_3d,
    "generic-npz": lambda p: load_generic(p, key="world_3d", layout="blazepose33"),
    "load_pose_array": lambda p: load_pose_array(p, key="world_3d"),
    "load_numpy_file": _load_numpy_file,
}
CSV_LOADERS: dict[str, Callable[[Path], Any]] = {"generic-csv": load_generic}
VIDEO_LOADERS: dict[str, Callable[[Path], Any]] = {"probe_video": probe_video}
LOADERS_BY_SUFFIX = {".json": JSON_LOADERS, ".npy": NPY_LOADERS, ".npz": NPZ_LOADERS, ".csv": CSV_LOADERS,
                     ".mp4": VIDEO_LOADERS}


# --------------------------------------------------------------------------- the property


def check_conventions(result: Any) -> None:
    """Assert that an adapter's result obeys the conventions (see the module docstring)."""
    if isinstance(result, Keypoints2D):
        pts = result.points
        n_joints = get_layout(result.layout).num_joints
        assert pts.dtype == np.float32 and pts.ndim == 3 and pts.shape[1:] == (n_joints, 3), pts.shape
        assert pts.shape[0] >= 1
        assert not np.isinf(pts).any(), "inf in 2D keypoints"
        nan = np.isnan(pts)
        assert (nan.all(axis=2) | ~nan.any(axis=2)).all(), "a 2D joint partly NaN"
        conf = pts[..., 2][~nan[..., 2]]
        assert ((conf >= 0) & (conf <= 1)).all(), "confidence outside [0, 1]"
        assert (np.abs(pts[..., :2][~nan[..., :2]]) <= MAX_ABS_COORDINATE["px"]).all(), "x/y beyond 1e5 px"
        assert (~nan).any(), "an all-NaN result"
        assert result.fps is None or (np.isfinite(result.fps) and result.fps > 0)
    elif isinstance(result, Poses3D):
        j = result.joints
        n_joints = get_layout(result.layout).num_joints
        assert j.dtype == np.float32 and j.ndim == 3 and j.shape[1:] == (n_joints, 3) and j.shape[0] >= 1
        assert not np.isinf(j).any(), "inf in 3D joints"
        finite = j[np.isfinite(j)]
        assert finite.size, "an all-NaN result"
        assert (np.abs(finite) <= MAX_ABS_COORDINATE[result.units]).all(), f"beyond the bound for {result.units}"
        assert result.frame == "camera"
        assert result.fps is None or (np.isfinite(result.fps) and result.fps > 0)
    elif isinstance(result, VideoInfo):
        assert result.frame_count >= 1 and np.isfinite(result.fps) and result.fps > 0
        assert result.width > 0 and result.height > 0
    elif isinstance(result, np.ndarray):  # load_pose_array
        assert result.dtype == np.float32 and result.ndim == 3 and result.shape[1:] == (17, 3)
        assert result.shape[0] >= 1 and not np.isinf(result).any()
        finite = result[np.isfinite(result)]
        assert finite.size and (np.abs(finite) <= MAX_ABS_COORDINATE[None]).all()
    elif isinstance(result, list):  # load_numpy_file's members: whatever the file holds
        assert all(isinstance(a, np.ndarray) for a in result)
    else:
        raise AssertionError(f"unexpected result type {type(result).__name__}")


OUTCOMES: dict[tuple[str, str], int] = {}  # (loader, outcome) -> count, for PCNET_FUZZ_STATS


def run(loader: Callable[[Path], Any], path: Path, name: str = "") -> Any:
    """Call ``loader``; return its checked result, or None when it refused with a one-line
    InputError. Anything else propagates and fails the test. Warnings are errors, as under
    ``python -W error``."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            result = loader(path)
    except InputError as err:
        msg = str(err)
        assert msg and "\n" not in msg, repr(msg)
        _count(name or loader.__name__, getattr(err, "field", "InputError"))
        return None
    check_conventions(result)
    _count(name or loader.__name__, "ok")
    return result


def _count(name: str, outcome: str) -> None:
    if os.environ.get("PCNET_FUZZ_STATS"):
        key = (name, outcome.split(" (")[0])
        OUTCOMES[key] = OUTCOMES.get(key, 0) + 1


def run_all(loaders: dict[str, Callable[[Path], Any]], path: Path) -> None:
    for name, loader in loaders.items():
        try:
            run(loader, path, name)
        except BaseException as exc:
            exc.add_note(f"loader {name} on {path.name}")
            raise


def written(folder: Path, name: str, content: bytes) -> Path:
    path = folder / name
    path.write_bytes(content)
    return path


def test_the_property_can_fail():
    """The checks are not tautologies: broken results and foreign exceptions fail them."""
    bad = np.zeros((2, 17, 3), np.float32)
    bad[0, 0, 2] = 1.5
    with pytest.raises(AssertionError, match="confidence"):
        check_conventions(Keypoints2D(bad, "coco17", "x"))
    bad[0, 0] = [np.inf, 1.0, 0.5]
    with pytest.raises(AssertionError, match="inf"):
        check_conventions(Keypoints2D(bad, "coco17", "x"))
    far = np.full((1, 17, 3), 200.0, np.float32)
    with pytest.raises(AssertionError, match="bound"):
        check_conventions(Poses3D(far, "h36m17", units="m"))

    def raises_key_error(_):
        raise KeyError("x")

    with pytest.raises(KeyError):
        run(raises_key_error, Path("x"))

    def warns(_):
        return np.nanmax(np.full(3, np.nan))

    with pytest.raises(RuntimeWarning):
        run(warns, Path("x"))

    def refuses(_):
        raise AdapterError("x", "f", "two\nlines")  # folded to one line by InputError

    assert run(refuses, Path("x")) is None


# --------------------------------------------------------------------------- bytes


_PREFIXES = [b"", b"\x93NUMPY", b"\x93NUMPY\x01\x00", b"\x93NUMPY\x02\x00", b"PK\x03\x04", b"PK\x05\x06",
             b"[", b"{", b'[{"image_id": "1.jpg", "keypoints": [', b"\x00\x00\x00\x18ftypisom"]


@FUZZ
@given(prefix=st.sampled_from(_PREFIXES), body=st.binary(max_size=600))
@example(prefix=b"", body=b"x,y,z\n1,2,3\n")  # a CSV named .npy: "not numpy", not "pickled data"
@example(prefix=b"\x93NUMPY\x01\x00", body=b"v\x00{'descr': '<f4', 'fortran_order': False, 'shape': (10**12, 17, 3), }")
def test_random_bytes(prefix, body):
    with tempfile.TemporaryDirectory() as tmp:
        for suffix, loaders in LOADERS_BY_SUFFIX.items():
            run_all(loaders, written(Path(tmp), f"input{suffix}", prefix + body))


_FIXTURES = [ALPHAPOSE, BOXING_AP, MEDIAPIPE, BOXING_X3D, *YOGA, CLIP]


@FUZZ
@given(fixture=st.sampled_from(_FIXTURES), cut=st.floats(0.0, 1.0))
@example(fixture=CLIP, cut=1.0)  # the whole clip: the video path must succeed too
@example(fixture=CLIP, cut=0.98)
def test_truncated_fixtures(fixture, cut):
    content = fixture.read_bytes()
    with tempfile.TemporaryDirectory() as tmp:
        path = written(Path(tmp), "cut" + fixture.suffix, content[: int(len(content) * cut)])
        run_all(LOADERS_BY_SUFFIX[fixture.suffix], path)


@FUZZ
@given(fixture=st.sampled_from(_FIXTURES),
       edits=st.lists(st.tuples(st.floats(0.0, 1.0, exclude_max=True), st.binary(min_size=1, max_size=8)),
                      min_size=1, max_size=6),
       header_bias=st.booleans())
# Found by this test: a NUL in a .npy header made numpy's header tokenizer raise TokenError;
# four bytes that spell a signalling NaN made later arithmetic warn "invalid value".
@example(fixture=BOXING_X3D, edits=[(0.234375, b"\x00")], header_bias=True)
@example(fixture=BOXING_X3D, edits=[(0.93359375, b"\x00\x00\x00\x81\x7f")], header_bias=True)
def test_garbled_fixtures(fixture, edits, header_bias):
    data = bytearray(fixture.read_bytes())
    for where, new in edits:
        # Half the time aim at the first 256 bytes, where the headers and the zip
        # records that decide the parse live.
        span = min(len(data), 256) if header_bias else len(data)
        at = int(where * span)
        data[at:at + len(new)] = new
    with tempfile.TemporaryDirectory() as tmp:
        run_all(LOADERS_BY_SUFFIX[fixture.suffix], written(Path(tmp), "garbled" + fixture.suffix, bytes(data)))


# --------------------------------------------------------------------------- JSON

_HOSTILE_INTS = st.sampled_from([0, 1, -1, 2**31, 2**63, 2**64, -(2**63) - 1, 10**18, 2_000_000_000, 10**400, 10**4000])
_HOSTILE_FLOATS = st.sampled_from([0.0, 0.5, 1.0, 1.13, 2.5, -1.0, 1e5, 1e5 + 1, 1e39, 1e300, -1e300,
                                   float("nan"), float("inf"), float("-inf"), 5e-324])
_NUMBER = st.one_of(st.floats(-2e3, 2e3), st.integers(-2000, 2000), _HOSTILE_INTS, _HOSTILE_FLOATS)
_NOT_NUMBERS = st.sampled_from([None, True, False, "1.5", "", [1], {"x": 1}])
# Values a valid file may hold: missing data (NaN, +-inf), an undetected 0, an unnormalised score.
_MISSING_OR_ODD = st.sampled_from([float("nan"), float("inf"), float("-inf"), 0.0, 1.13])
_SCALAR = st.one_of(st.none(), st.booleans(), _NUMBER, st.text(max_size=12))
_JSON = st.recursive(_SCALAR, lambda children: st.one_of(
    st.lists(children, max_size=5),
    st.dictionaries(st.sampled_from(["image_id", "keypoints", "score", "idx", "frame_id", "instances",
                                     "instance_info", "keypoint_scores", "people", "pose_keypoints_2d"])
                    | st.text(max_size=6), children, max_size=5)), max_leaves=30)


def _dumps(value: Any) -> bytes:
    return json.dumps(value, allow_nan=True).encode()


@FUZZ
@given(value=_JSON)
def test_json_of_random_structure(value):
    with tempfile.TemporaryDirectory() as tmp:
        run_all(JSON_LOADERS, written(Path(tmp), "random.json", _dumps(value)))
        folder = Path(tmp) / "openpose"
        folder.mkdir()
        written(folder, "v_000000000000_keypoints.json", _dumps(value))
        run(load_openpose, folder)


# Each writer-shaped strategy draws a "hostile" flag first: clean examples (valid structure,
# values with NaN/inf/0 gaps) reach the success paths, hostile ones the refusals.

@st.composite
def _values(draw, n: int, hi: float, hostile: bool) -> list:
    """n keypoint values in [0, hi] with up to three replaced by missing/odd values, or when
    ``hostile`` by hostile numbers and things that are not numbers."""
    values = draw(st.lists(st.floats(0, hi), min_size=n, max_size=n))
    pool = st.one_of(_NUMBER, _NOT_NUMBERS, _MISSING_OR_ODD) if hostile else _MISSING_OR_ODD
    for _ in range(draw(st.integers(0, 3))):
        if values:
            values[draw(st.integers(0, n - 1))] = draw(pool)
    return values


_HOSTILE_IMAGE_ID = st.one_of(
    _HOSTILE_INTS.map(lambda k: f"{k}.jpg"), _HOSTILE_INTS,
    st.sampled_from(["-3.jpg", "3.5", "x.jpg", "0" * 30 + "1.jpg", "9" * 40 + ".png", "", None, True, 3.0, [1]]),
)


@st.composite
def alphapose_detections(draw) -> list[dict]:
    hostile = draw(st.booleans())
    joints = draw(st.sampled_from([17, 26, 20] if hostile else [17, 26]))
    detections = []
    for _ in range(draw(st.integers(1, 6))):
        frame = draw(st.integers(0, 60))
        image_id = draw(st.one_of(st.just(f"{frame}.jpg"), st.just(frame), _HOSTILE_IMAGE_ID) if hostile
                        else st.one_of(st.just(f"{frame}.jpg"), st.just(frame)))
        det = {"image_id": image_id, "category_id": 1, "keypoints": draw(_values(3 * joints, 1000.0, hostile))}
        if draw(st.booleans()):
            det["score"] = draw(st.one_of(st.floats(0, 3), _NUMBER, _NOT_NUMBERS) if hostile else st.floats(0, 3))
        if draw(st.booleans()):
            det["idx"] = draw(st.one_of(st.integers(0, 3), st.lists(st.floats(0, 3), max_size=2), _NUMBER,
                                        _NOT_NUMBERS) if hostile else st.integers(0, 2))
        detections.append(det)
    return detections


@FUZZ
@given(detections=alphapose_detections(),
       frame_count=st.one_of(st.none(), st.integers(1, 100), st.sampled_from([0, -1, True, 2.5])),
       num_frames=st.one_of(st.none(), st.integers(1, 120), st.just(10**12)),
       person=st.one_of(st.none(), st.integers(0, 3), st.just("1")))
@example(detections=[{"image_id": "2000000000.jpg", "keypoints": [1.0] * 51, "category_id": 1}],
         frame_count=None, num_frames=None, person=None)  # 10 kB of JSON once asked for 581 GiB
def test_alphapose_shaped_json(detections, frame_count, num_frames, person):
    with tempfile.TemporaryDirectory() as tmp:
        path = written(Path(tmp), "alphapose-results.json", _dumps(detections))
        run(load_alphapose, path, "alphapose-shaped")
        run(lambda p: load_alphapose(p, person=person, frame_count=frame_count, num_frames=num_frames), path,
            "alphapose-options")


@st.composite
def mmpose_predictions(draw) -> Any:
    hostile = draw(st.booleans())
    wrapped = draw(st.booleans())
    joints = draw(st.sampled_from([17, 26, 133, 5] if hostile else [17, 26, 133]))
    frames = []
    for _ in range(draw(st.integers(1, 5))):
        frame_id = draw(st.integers(int(wrapped), 40))
        if hostile and draw(st.booleans()):
            frame_id = draw(st.one_of(_HOSTILE_INTS, _NOT_NUMBERS, st.just(2.0)))
        instances = []
        for _ in range(draw(st.integers(0, 3))):
            xy = draw(_values(2 * joints, 1000.0, hostile))
            instances.append({
                "keypoints": [xy[i:i + 2] for i in range(0, len(xy), 2)],
                "keypoint_scores": draw(_values(joints, 1.5, hostile)),
                "bbox": [[0, 0, 10, 10]], "bbox_score": 0.9,
            })
        frames.append({"frame_id": frame_id, "instances": instances})
    return {"meta_info": {}, "instance_info": frames} if wrapped else frames


@FUZZ
@given(content=mmpose_predictions(), person=st.one_of(st.none(), st.integers(-1, 2), st.just(True)),
       frame_count=st.one_of(st.none(), st.integers(1, 50)))
def test_mmpose_shaped_json(content, person, frame_count):
    with tempfile.TemporaryDirectory() as tmp:
        path = written(Path(tmp), "predictions.json", _dumps(content))
        run(load_mmpose, path, "mmpose-shaped")
        run(lambda p: load_mmpose(p, person=person, frame_count=frame_count), path, "mmpose-options")


@st.composite
def openpose_frames(draw) -> dict[int, list]:
    hostile = draw(st.booleans())
    joints = draw(st.sampled_from([25, 17, 33, 18] if hostile else [25, 17, 33]))
    frames = {}
    for _ in range(draw(st.integers(1, 4))):
        frame = draw(st.integers(0, 30))
        if hostile and draw(st.booleans()):  # file names stay under the 255-byte limit
            frame = draw(_HOSTILE_INTS.filter(lambda k: 0 <= k < 10**100))
        frames[frame] = [{"person_id": [-1], "pose_keypoints_2d": draw(_values(3 * joints, 1000.0, hostile))}
                         for _ in range(draw(st.integers(0, 2)))]
    return frames


@FUZZ
@given(frames=openpose_frames(), frame_count=st.one_of(st.none(), st.integers(1, 40)))
def test_openpose_shaped_folders(frames, frame_count):
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for frame, people in frames.items():
            written(folder, f"clip_{frame:012d}_keypoints.json", _dumps({"version": 1.3, "people": people}))
        run(load_openpose, folder, "openpose-shaped")
        run(lambda p: load_openpose(p, frame_count=frame_count), folder, "openpose-frame_count")


# --------------------------------------------------------------------------- numpy arrays

_DTYPES = [np.bool_, np.int8, np.int64, np.uint64, np.float16, np.float32, np.float64, np.longdouble,
           np.complex64, "U5", "S3", object]
_T = st.integers(1, 6)
_SHAPES = st.one_of(
    _T.map(lambda t: (t, 17, 3)), _T.map(lambda t: (t, 33, 3)), _T.map(lambda t: (t, 51)),
    _T.map(lambda t: (2, 3, t, 17, 3)), _T.map(lambda t: (3, t, 17, 3)),
    st.sampled_from([(0, 17, 3), (2, 17, 3, 1), (), (5,), (4, 17), (1, 16, 3)]),
)
_SPECIAL = st.sampled_from([np.nan, np.inf, -np.inf, 1e5 + 1, -2e3, 1e39, 1e300, 0.0])


@st.composite
def arrays(draw, joints: int | None = None) -> np.ndarray:
    """An array of random shape and dtype, values near a pose's scale with NaN/inf/huge
    entries sprinkled in, whole frames or the whole array missing now and then.
    ``joints`` asks for a well-formed float ``(T, joints, 3)`` (values still hostile)."""
    if joints is None:
        shape = draw(_SHAPES)
        dtype = draw(st.sampled_from(_DTYPES))
    else:
        shape = (draw(_T), joints, 3)
        dtype = draw(st.sampled_from([np.float32, np.float64, np.float16, np.int64]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    scale = draw(st.sampled_from([0.5, 1.0, 3.0, 500.0]))
    values = np.asarray(rng.normal(0.0, scale, shape))
    for _ in range(draw(st.integers(0, 4))):
        if values.size:
            values.flat[draw(st.integers(0, values.size - 1))] = draw(_SPECIAL)
    pattern = draw(st.sampled_from(["plain", "plain", "nan-frame", "all-nan", "all-inf"]))
    if pattern == "nan-frame" and values.ndim and values.shape[0]:
        values[0] = np.nan
    elif pattern == "all-nan":
        values[...] = np.nan
    elif pattern == "all-inf":
        values[...] = np.inf
    if dtype is object:
        return values.astype(object)
    with np.errstate(all="ignore"):
        return values.astype(dtype)


def _save(path: Path, arr: np.ndarray) -> Path:
    np.save(path, arr, allow_pickle=arr.dtype.hasobject)
    return path


@FUZZ
@given(arr=st.one_of(arrays(), arrays(joints=17)))
def test_npy_arrays(arr):
    with tempfile.TemporaryDirectory() as tmp:
        path = _save(Path(tmp) / "poses.npy", arr)
        run_all(NPY_LOADERS, path)
        # Pass-through readers: a finite input value never turns into a missing one. VideoPose3D
        # exports are root-relative (a pelvis off the origin is refused): read one with its root zeroed.
        rooted = arr
        if isinstance(arr, np.ndarray) and arr.ndim == 3 and arr.shape[1:] == (17, 3) and arr.dtype.kind in "iuf":
            rooted = arr.copy()
            rooted[:, 0] = 0
        for loader, src_arr in ((load_videopose3d, rooted), (load_generic, arr)):
            out = run(loader, _save(Path(tmp) / f"{loader.__name__}.npy", src_arr))
            if out is not None:
                src = np.asarray(src_arr, np.float64).reshape(out.joints.shape)
                assert (np.isnan(out.joints) == ~np.isfinite(src)).all(), loader.__name__


_FPS = st.one_of(st.floats(1, 240), st.integers(1, 120), st.floats(allow_nan=True, allow_infinity=True),
                 st.sampled_from([0, -5, [30.0, 25.0], "30", True]))


@FUZZ
@given(kp2d=st.one_of(arrays(joints=33), arrays(joints=33), arrays(), st.none()),
       world=st.one_of(arrays(joints=33), arrays(joints=33), arrays(), st.none()),
       fps=st.one_of(st.none(), _FPS), layout=st.sampled_from([None, "blazepose33", "blazepose33", "coco17", 33]),
       compressed=st.booleans())
def test_mediapipe_npz(kp2d, world, fps, layout, compressed):
    members = {"keypoints_2d": kp2d, "world_3d": world, "fps": fps, "layout": layout}
    members = {k: np.asarray(v) for k, v in members.items() if v is not None}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "mediapipe.npz"
        if any(v.dtype.hasobject for v in members.values()):
            np.savez(path, **members)  # savez pickles object arrays: they must still be refused
        else:
            (np.savez_compressed if compressed else np.savez)(path, **members)
        run_all(NPZ_LOADERS, path)
        for loader in (load_mediapipe_2d, load_mediapipe_3d):
            out = run(loader, path)
            if out is not None:
                assert out.fps == (None if fps is None else float(fps))


_ODD_CELLS = st.sampled_from(["", "nan", "inf", "-Infinity", "1e400", "-1e400", "1e39", "250", "1_0", "x", "0x10",
                              " 1.5 ", "True", "\x00"])


@st.composite
def _csv_row(draw) -> list[str]:
    """51 cells: numbers in metres' range with up to three odd cells (missing, inf, a literal
    beyond float range, beyond the bound, text)."""
    cells = [f"{v:.4f}" for v in draw(st.lists(st.floats(-3, 3), min_size=51, max_size=51))]
    for _ in range(draw(st.integers(0, 3))):
        cells[draw(st.integers(0, 50))] = draw(_ODD_CELLS)
    return cells


@FUZZ
@given(rows=st.lists(_csv_row(), min_size=1, max_size=4), header=st.booleans(),
       drop=st.sampled_from([0, 0, 0, 1, 3]), delimiter=st.sampled_from([",", ",", ";", "\t"]))
def test_csv_tables(rows, header, drop, delimiter):
    lines = [delimiter.join(f"c{i}" for i in range(51))] if header else []
    lines += [delimiter.join(r[: len(r) - drop] if i == 0 else r) for i, r in enumerate(rows)]
    with tempfile.TemporaryDirectory() as tmp:
        path = written(Path(tmp), "poses.csv", ("\n".join(lines) + "\n").encode())
        out = run(lambda p: load_generic(p, delimiter=delimiter), path, "generic-csv")
        if out is not None:  # the header is the only row ever skipped
            assert out.num_frames == len(rows)
        run(lambda p: load_generic(p, units="cm", axes="LUF"), path, "generic-csv-cm")


# --------------------------------------------------------------------------- fixed cases


def _numpy_readers() -> dict[str, Callable[[Path], Any]]:
    return {**NPY_LOADERS, "mediapipe-2d": load_mediapipe_2d, "mediapipe-3d": load_mediapipe_3d}


def test_pickled_object_arrays_are_refused_everywhere(tmp_path):
    """allow_pickle stays False: a pickled object array is refused, as .npy and inside .npz,
    by every numpy reader, with the project's error type and a message that says so."""
    npy = tmp_path / "objects.npy"
    np.save(npy, np.array([{"joints": 1}, None], dtype=object), allow_pickle=True)
    npz = tmp_path / "objects.npz"
    np.savez(npz, keypoints_2d=np.array([None], dtype=object), world_3d=np.array([{}], dtype=object))
    for name, loader in _numpy_readers().items():
        for path in (npy, npz):
            if path is npz and name in ("motionbert", "motionbert-pixel", "ddhpose", "ddhpose-hyp0", "videopose3d",
                                        "generic", "generic-coco-cm", "generic-flat-px", "load_pose_array"):
                continue  # these need key= for a two-array npz; covered below
            with pytest.raises(InputError, match="pickled") as err:
                loader(path)
            assert "\n" not in str(err.value), name
    for call in (lambda: load_generic(npz, key="world_3d"), lambda: load_pose_array(npz, key="world_3d")):
        with pytest.raises(InputError, match="pickled"):
            call()


def test_not_numpy_is_called_that(tmp_path):
    csv = tmp_path / "poses.npy"
    csv.write_text("x,y,z\n1,2,3\n")
    junk = tmp_path / "junk.npz"
    junk.write_bytes(bytes(range(256)))
    for name, loader in _numpy_readers().items():
        for path in (csv, junk):
            with pytest.raises(InputError) as err:
                loader(path)
            msg = str(err.value)
            assert "not numpy" in msg and "pickled" not in msg, (name, msg)


def test_many_keys_are_listed_briefly(tmp_path):
    path = tmp_path / "many.npz"
    np.savez(path, **{f"clip_{i:04d}": np.zeros(1) for i in range(2000)})
    for call in (lambda: load_generic(path), lambda: load_pose_array(path), lambda: load_generic(path, key="nope")):
        with pytest.raises(InputError) as err:
            call()
        msg = str(err.value)
        assert "2000 arrays" in msg and msg.count("clip_") == 10 and len(msg) < 400, msg
    assert describe_keys(["a"]) == "1 array: 'a'"


def test_inf_is_missing_and_not_taken_for_pixels(tmp_path):
    x3d = np.load(BOXING_X3D)
    x3d[7, 3] = [np.inf, -np.inf, 0.1]
    path = tmp_path / "X3D.npy"
    np.save(path, x3d)
    out = load_motionbert(path)  # was: "looks like pixels; use pixel=True"
    assert np.isnan(out.joints[7, 3, :2]).all() and out.joints[7, 3, 2] == np.float32(0.1)
    assert out.units == "normalised" and not np.isinf(out.joints).any()


def test_values_beyond_the_bound_name_frame_and_joint(tmp_path):
    poses = np.load(YOGA[0]).astype(np.float64)
    poses[4, 13, 1] = 1e300  # would overflow float32 to inf and pass as missing
    path = tmp_path / "far.npy"
    np.save(path, poses)
    with pytest.raises(AdapterError, match=r"1e\+300"):
        load_videopose3d(path)
    poses[4, 13, 1] = 250.0  # 250 m
    np.save(path, poses)
    for loader in (load_videopose3d, load_ddhpose, load_generic):
        with pytest.raises(AdapterError, match=r"100 m.*at frame 4, joint left_wrist") as err:
            loader(path)
        assert "\n" not in str(err.value)
    entries = json.loads(BOXING_AP.read_text())
    entries[2]["keypoints"][3 * 9] = 5e6  # frame 2, left_wrist x
    ap = tmp_path / "ap.json"
    ap.write_text(json.dumps(entries))
    with pytest.raises(AdapterError, match=r"frame 2, joint left_wrist.*100000 px"):
        load_alphapose(ap)
    points = np.zeros((3, 25, 3))
    points[1, 22, 0] = 1e39  # beyond float32 (hypothesis's find): refused, not an overflow in the cast
    with warnings.catch_warnings(), pytest.raises(AdapterError, match=r"frame 1, joint .*1e\+39"):
        warnings.simplefilter("error")
        checked_keypoints(ap, "keypoints", points, "body25")


def test_coco_joint_names_in_bound_errors(tmp_path):
    """Joint names come from the adapter's layout (validate_poses alone would say H36M's)."""
    poses = np.load(YOGA[0]).astype(np.float64)
    poses[1, 13, 0] = 1e3
    path = tmp_path / "coco.npy"
    np.save(path, poses)
    with pytest.raises(AdapterError, match=r"frame 1, joint left_knee"):
        load_generic(path, layout="coco17")


def test_inf_in_2d_is_a_missing_joint(tmp_path):
    entries = json.loads(BOXING_AP.read_text())
    entries[5]["keypoints"][2] = float("inf")  # confidence of joint 0 in frame 5
    entries[6]["keypoints"][0] = float("-inf")
    path = tmp_path / "ap.json"
    path.write_text(json.dumps(entries))
    kp = load_alphapose(path)
    assert np.isnan(kp.points[5, 0]).all() and np.isnan(kp.points[6, 0]).all()
    assert np.isfinite(kp.points[5, 1]).all()


def test_frame_index_bounds(tmp_path):
    entries = json.loads(BOXING_AP.read_text())
    entries[-1]["image_id"] = "2000000000.jpg"
    path = tmp_path / "ap.json"
    path.write_text(json.dumps(entries))
    with pytest.raises(AdapterError, match=r"implausible|plausible for a file of 60 records") as err:
        load_alphapose(path)
    assert "2000000000" in str(err.value) and "frame_count" in str(err.value)
    with pytest.raises(AdapterError, match=r"frame_count=301.*2000000000"):
        load_alphapose(path, frame_count=301)
    assert load_alphapose(BOXING_AP, frame_count=60).num_frames == 60
    with pytest.raises(AdapterError, match=r"frame_count=59.*frame index 59"):
        load_alphapose(BOXING_AP, frame_count=59)
    # A sparse but real file: allowed once the video's frame count vouches for it.
    sparse = [dict(entries[0], image_id="20000.jpg")]
    path.write_text(json.dumps(sparse))
    with pytest.raises(AdapterError, match="frame_count"):
        load_alphapose(path)
    assert load_alphapose(path, frame_count=20001).num_frames == 20001
    assert frame_count_for("f", "x", 10, 1) == 11
    with pytest.raises(AdapterError, match="frame_count"):
        frame_count_for("f", "x", 10, 1, frame_count=True)


def test_mediapipe_fps_is_read(tmp_path):
    kp = load_mediapipe_2d(MEDIAPIPE)
    assert kp.fps == 30.0 and load_mediapipe_3d(MEDIAPIPE).fps == 30.0
    assert load_alphapose(BOXING_AP).fps is None
    members = dict(np.load(MEDIAPIPE))
    for bad in (0.0, -30.0, np.nan, np.inf, "30", [30.0, 30.0]):
        members["fps"] = np.asarray(bad)
        path = tmp_path / "mp.npz"
        np.savez(path, **members)
        with pytest.raises(AdapterError, match="fps"):
            load_mediapipe_2d(path)
    del members["fps"]
    np.savez(path, **members)
    assert load_mediapipe_3d(path).fps is None


def test_probe_video_on_non_video_files(tmp_path):
    for name in ("poses.npy", "notes.txt", "clip.mp4"):
        path = tmp_path / name
        path.write_bytes(BOXING_X3D.read_bytes()[:2000])
        with pytest.raises(AdapterError, match="video") as err:
            probe_video(path)
        assert "\n" not in str(err.value)


def test_registry_entries_declare_their_options():
    """The pipeline passes frame_count where an adapter's load() names it (inspect.signature),
    so the registry classes must spell their options out and pass them through."""
    import inspect

    from pcnet.adapters import get_2d_adapter, get_3d_adapter

    for name in ("alphapose", "mmpose", "openpose"):
        assert "frame_count" in inspect.signature(get_2d_adapter(name).load).parameters, name
    assert "frame_count" not in inspect.signature(get_2d_adapter("mediapipe").load).parameters
    with pytest.raises(AdapterError, match="frame_count=59"):
        get_2d_adapter("alphapose").load(BOXING_AP, frame_count=59)
    assert get_3d_adapter("ddhpose").load(YOGA[0], hypothesis="mean").num_frames == 100
    assert get_3d_adapter("generic").load(YOGA[0], units="cm").units == "m"


def test_load_numpy_file_keeps_its_contract(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_numpy_file(tmp_path / "missing.npz", "mocap .npz")
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(InputError, match=r"junk.npz: not a readable mocap .npz file \(.*zip"):
        load_numpy_file(junk, "mocap .npz")
    with load_numpy_file(MEDIAPIPE, "mediapipe") as npz:
        assert isinstance(npz, np.lib.npyio.NpzFile)
        np.testing.assert_array_equal(npz["world_3d"], np.load(MEDIAPIPE)["world_3d"])
