"""Validation against truth (issue 51): held-out mocap filmed by a static camera, run through `pcnet run`.

    python -m benchmarks.world_validation --data ../shared/data [--max-clips 6] [--opensim-clips 2]
        [--mode auto|sequence] [--cmu-split test|val|val+test] [--max-seconds 20] [--seed 0]
        [--no-video] [--keep DIR] [--out benchmarks/results/world_validation.txt]

Data (held out from the shipped networks' training): CMU test subjects 10 and 14
(``cmu_train_h36m17.npz``, ``select_split(..., "test", "motion-style")``; ``--cmu-split val``
takes the validation subjects 12 and 60 instead) and DeepMimic (``deepmimic_h36m17.npz``, another
data set, all clips). Mocap: ``(T, 17, 3)`` H36M-17, metres, world +Y up, the ground at y = 0, the
global path kept. Per data set at most ``--max-clips`` clips, evenly spaced over the clips of at
least 2 s (the first ``--max-seconds`` of each kept); a clip the camera cannot keep in view at
``MAX_DISTANCE_M`` is skipped and the next one taken.

Camera, one per clip, static: a pinhole camera of 1920 x 1080 pixels, focal length a phone's
26 mm equivalent (same diagonal angle of view: ``f = 26 / 43.27 * hypot(1920, 1080)`` = 1323.6 px,
71 deg horizontal), principal point at the image centre. Its orientation is one draw of the
"paper" view distribution (docs/CONVENTIONS.md: yaw around the subject, pitch, roll) relative to
the subject's heading at the first frame, as ``make_pairs(camera="static")`` builds it. It looks
at the centre of the pelvis path's horizontal extent at the pelvis's median height from a distance
drawn from U(4, 8) m, moved back in 0.25 m steps (up to ``MAX_DISTANCE_M``) until every joint of
every frame lies at least 1 m in front of it and ``EDGE_MARGIN_PX`` inside the image. (With a
negative pitch the camera looks up and can stand below the floor: the projection does not care.)

Inputs, written as files and read by `pcnet run` as a user's would be (the Python API
``run_pipeline(RunConfig(...))``, the same code as the CLI; no rerun recording):
- 3D: VideoPose3D's export (``--lifter videopose3d``): ``(T, 17, 3)`` ``.npy``, camera frame
  (x right, y down, z forward), metres, root-relative (pelvis at the origin);
  clean = the true joints in the camera frame minus the pelvis; lifter noise = the same with
  ``models/lifter_noise.py``'s errors (``sample_lifter_errors`` + ``apply_lifter_errors``, default
  ``LifterNoise``: per-clip bone lengths, lean and depth scale, slow per-joint offsets, jitter,
  bursts, left/right swaps; about 42 mm MPJPE).
- 2D: an AlphaPose results JSON with the 26 Halpe keypoints (``--keypoints2d-format alphapose``),
  the layout that maps onto H36M-17 without building joints from others: Halpe ``hip`` = pelvis,
  ``neck`` = thorax, ``head`` = head, ``nose`` = neck_nose, and the 12 limb joints; the H36M spine
  is not in the file (pcnet builds it as the mean of neck and hip); the eyes, ears, toes and
  heels, which H36M-17 lacks, are written at the nose / ankle with confidence 0. Confidence 0.9
  elsewhere. Clean = the projection of the true joints. Lifter noise = detector-like 2D errors:
  the image-plane (x, y) part of the same draw's per-joint slow offsets, jitter and bursts, and its
  left/right swaps (what a lifter inherits from its 2D input; slow offsets of 18 mm per image axis
  at a weight-1 joint are about 5 px at 5 m), added to the true joints before projection, the
  pelvis (mid-hip) moved by the mean of its hips' errors. The lifter's own errors (bone lengths,
  lean, depth scale, depth offsets) are in the 3D only: the image shows the true body and the 3D
  does not, so 2D and 3D disagree as a real lifter's do. (A first version projected the noisy 3D
  itself: 2D and 3D then agreed exactly, and a path solved from them came out exact, 1-2 mm.)
- ``--fps`` the clip's; ``--mode`` auto (what a user gets; it may pick smooth, and then there is no
  world frame and the world metrics are empty for that run) or sequence (``--mode sequence``: the
  user says the camera is static); no ``--height`` (the lifter is metric); the focal length is passed where
  the run takes it for this lifter (a RunConfig field ``focal_px`` or an adapter option), else the
  table's header says it was not accepted. The image size comes as a user's would, from the video:
  a black MP4 of the camera's size, frame count and rate (``--video``; OpenCV's mp4v writer; no
  rerun recording, so only its size, rate and length are read); ``--no-video`` leaves it out and
  passes ``--fps`` instead.

Truth: the mocap itself, turned about +Y and shifted horizontally into pcnet's world-frame
convention (+X the subject's forward over the first second, first pelvis at x = z = 0; the ground
stays at y = 0), filtered and differentiated by the same code and cutoff as the run's
(``stages/kinematics.py: compute_kinematics``, the run's ``report["cutoff_hz"]``); OpenSim IK on
the truth = ``stages/opensim_ik.py: scale_and_ik`` (what ``pcnet run --opensim`` calls) on those
true joint centres written as a TRC (``write_trc``), the same model and setup.

Metrics per clip, over the run's valid frames (``valid`` in kinematics.csv) where both values are
finite; the run's values are read by column name from kinematics.csv and canonical.npz:
- tilt: angle between the run's one up (``report["up"]``, sequence mode) and the true up, both in
  the camera frame (deg): a check that the camera above is the one the run saw;
- path: RMS horizontal pelvis error (m) after a 2D rigid alignment (a yaw and a horizontal
  translation, least squares: the world frame's heading and origin are arbitrary), of
  ``pelvis_x_m``/``pelvis_z_m``; "pinned" = the same error for a pelvis held at one point (the
  true path's RMS distance from its centroid);
- speed: median over frames of |``pelvis_speed_m_per_s`` - true pelvis speed| (m/s, 3D);
  "zero" = the median true speed (the error of reporting none);
- floor: where the run's floor (y = 0) lies above the true ground (cm): the median over stance
  frames (the truth's lower ankle slower than 0.25 m/s) of that ankle's true height minus its
  height in the run (``{side}_ankle_y_m``); reported signed and as |.|; also the median
  |``pelvis_y_m`` - true pelvis height| (cm);
- a_y: RMS of ``pelvis_ay_m_per_s2`` - true vertical pelvis acceleration (m/s^2) against the true
  RMS (the error of "assume zero");
- OpenSim (``--opensim-clips`` clips per set, both inputs): mean absolute difference (deg,
  wrapped) between the run's ``ik.mot`` and IK on the truth over the 19 unlocked joint coordinates
  (hip 3 + knee per side, neck 3, shoulder 3 + elbow per side; the pelvis's 6 DOF are the body in
  the world, not joint angles), frames matched by time; also without the five axial rotations
  (hip and arm rotation, neck rotation), which joint centres fix only through the next segment.
  Reference (lifter noise): IK on the same noisy root-relative joints placed in the world by the
  TRUE camera rotation and the true pelvis (what a perfect rectification and path would give): the
  share of the error the input itself carries.
- path source: the run's ``report["root_path"]`` (canonical.npz; "no world frame" when the run
  kept the canonical frame), counted per row.
Summaries over clips: median, mean, 95th percentile. Seeds: ``--seed`` and the clip's name
(crc32) decide the camera and the noise; the clean and noisy runs of a clip share the camera.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import inspect
import json
import math
import shutil
import sys
import tempfile
import time
import zlib
from pathlib import Path

import numpy as np

from benchmarks.report import SHARED_DATA
from pcnet.adapters import get_3d_adapter
from pcnet.models.datasets import load_mocap, select_split
from pcnet.models.lifter_noise import LifterNoise, apply_lifter_errors, sample_lifter_errors
from pcnet.pipeline.config import RunConfig
from pcnet.pipeline.runner import run_pipeline
from pcnet.stages.core.canonical import canonical_rotation
from pcnet.stages.core.conventions import H36M_JOINTS, PELVIS
from pcnet.stages.core.rotations import sample_camera_rotations
from pcnet.stages.kinematics import compute_kinematics

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_DATA = SHARED_DATA
RESULT = ROOT / "benchmarks" / "results" / "world_validation.txt"

WIDTH, HEIGHT = 1920, 1080
FOCAL_35MM = 26.0
FOCAL_PX = FOCAL_35MM / 43.27 * math.hypot(WIDTH, HEIGHT)  # CIPA DC-008: same diagonal angle of view
EDGE_MARGIN_PX = 20.0
MIN_DEPTH_M = 1.0
DISTANCE_RANGE_M = (4.0, 8.0)
MAX_DISTANCE_M = 10.0
DISTANCE_STEP_M = 0.25
MIN_SECONDS = 2.0
CONFIDENCE = 0.9
STANCE_SPEED = 0.25  # m/s: the truth's lower ankle slower than this is on the ground
LIFTER = "videopose3d"

R_HIP, R_KNEE, R_ANKLE, L_HIP, L_KNEE, L_ANKLE = 1, 2, 3, 4, 5, 6
SPINE, THORAX, NECK_NOSE, HEAD = 7, 8, 9, 10
L_SHOULDER, L_ELBOW, L_WRIST, R_SHOULDER, R_ELBOW, R_WRIST = 11, 12, 13, 14, 15, 16
#: Halpe-26 keypoint <- H36M-17 joint (stages/core/conventions.py: HALPE26's recipe read backwards).
HALPE_FROM_H36M = {0: NECK_NOSE, 5: L_SHOULDER, 6: R_SHOULDER, 7: L_ELBOW, 8: R_ELBOW, 9: L_WRIST, 10: R_WRIST,
                   11: L_HIP, 12: R_HIP, 13: L_KNEE, 14: R_KNEE, 15: L_ANKLE, 16: R_ANKLE, 17: HEAD, 18: THORAX,
                   19: PELVIS}
#: Halpe-26 keypoints H36M-17 has no joint for: written at this joint with confidence 0.
HALPE_UNFILLED = {1: NECK_NOSE, 2: NECK_NOSE, 3: NECK_NOSE, 4: NECK_NOSE, 20: L_ANKLE, 21: R_ANKLE,
                  22: L_ANKLE, 23: R_ANKLE, 24: L_ANKLE, 25: R_ANKLE}
JOINT_COORDS = ("hip_flexion_r", "hip_adduction_r", "hip_rotation_r", "knee_angle_r",
                "hip_flexion_l", "hip_adduction_l", "hip_rotation_l", "knee_angle_l",
                "neck_flexion", "neck_bending", "neck_rotation",
                "arm_flex_r", "arm_add_r", "arm_rot_r", "elbow_flex_r",
                "arm_flex_l", "arm_add_l", "arm_rot_l", "elbow_flex_l")
#: Axial rotations: the turn of a segment about its own long axis, which joint centres fix only
#: through the next segment (poorly where the knee or elbow is nearly straight).
AXIAL_COORDS = ("hip_rotation_r", "hip_rotation_l", "neck_rotation", "arm_rot_r", "arm_rot_l")
SETS = {"cmu": ("CMU test subjects 10, 14", "cmu_train_h36m17.npz"),
        "deepmimic": ("DeepMimic (another data set)", "deepmimic_h36m17.npz")}
CONDITIONS = ("clean", "lifter noise")


# --------------------------------------------------------------------------------------------- truth
def truth_world(joints: np.ndarray, fps: float) -> np.ndarray:
    """Mocap ``(T, 17, 3)`` (+Y up, ground y = 0) in pcnet's world-frame convention: +X the
    subject's horizontal forward averaged over the first second, +Z = X x Y, the first pelvis at
    x = z = 0, heights unchanged (the true ground stays at y = 0)."""
    J = np.asarray(joints, np.float64)
    n = max(1, int(round(fps)))
    right = J[:n, R_HIP] - J[:n, L_HIP]
    right[:, 1] = 0.0
    right /= np.linalg.norm(right, axis=1, keepdims=True)
    forward = np.cross([0.0, 1.0, 0.0], right)
    x = np.nanmean(forward, axis=0)
    x[1] = 0.0
    x /= np.linalg.norm(x)
    y = np.array([0.0, 1.0, 0.0])
    rows = np.stack([x, y, np.cross(x, y)])  # world X, Y, Z in mocap coordinates
    shifted = J - np.array([J[0, PELVIS, 0], 0.0, J[0, PELVIS, 2]])
    return shifted @ rows.T


# -------------------------------------------------------------------------------------------- camera
@dataclasses.dataclass
class Camera:
    rotation: np.ndarray  # world -> camera (rows: camera x, y, z in world coordinates)
    centre: np.ndarray  # camera centre, world coordinates (m)
    distance: float  # to the aim point (m)
    K: np.ndarray

    def to_camera(self, X: np.ndarray) -> np.ndarray:
        return (X - self.centre) @ self.rotation.T

    def project(self, Xc: np.ndarray) -> np.ndarray:
        return Xc[..., :2] / Xc[..., 2:3] * self.K[0, 0] + self.K[:2, 2]


def place_camera(world: np.ndarray, rng: np.random.Generator) -> Camera | None:
    """A static camera for ``world`` poses (module docstring), or None where none within
    ``MAX_DISTANCE_M`` keeps every joint in view."""
    R_canon, valid = canonical_rotation(world, (0.0, 1.0, 0.0))
    first = int(np.flatnonzero(valid)[0]) if valid.any() else None
    view = sample_camera_rotations(1, "paper", rng)[0]  # canonical -> camera
    distance = float(rng.uniform(*DISTANCE_RANGE_M))
    if first is None:
        return None
    rotation = view @ R_canon[first].T  # world -> camera, as make_pairs(camera="static")
    pelvis = world[:, PELVIS]
    lo, hi = np.nanmin(pelvis, axis=0), np.nanmax(pelvis, axis=0)
    aim = np.array([(lo[0] + hi[0]) / 2, np.nanmedian(pelvis[:, 1]), (lo[2] + hi[2]) / 2])
    K = np.array([[FOCAL_PX, 0, WIDTH / 2], [0, FOCAL_PX, HEIGHT / 2], [0, 0, 1.0]])
    d = distance
    while d <= MAX_DISTANCE_M + 1e-9:
        cam = Camera(rotation, aim - d * rotation[2], d, K)
        Xc = cam.to_camera(world)
        if np.nanmin(Xc[..., 2]) >= MIN_DEPTH_M:
            px = cam.project(Xc)
            inside = ((px[..., 0] >= EDGE_MARGIN_PX) & (px[..., 0] <= WIDTH - EDGE_MARGIN_PX)
                      & (px[..., 1] >= EDGE_MARGIN_PX) & (px[..., 1] <= HEIGHT - EDGE_MARGIN_PX))
            if inside[np.isfinite(px).all(-1)].all():
                return cam
        d += DISTANCE_STEP_M
    return None


# -------------------------------------------------------------------------------------------- inputs
def make_inputs(world: np.ndarray, cam: Camera, fps: float, noisy: bool, rng: np.random.Generator):
    """``(root-relative camera-frame 3D (T, 17, 3) m, 2D keypoints (T, 17, 2) px)``, clean or with
    lifter-like errors (module docstring)."""
    Xc = cam.to_camera(world)
    root = Xc[:, PELVIS : PELVIS + 1]
    clean = Xc - root
    if not noisy:
        return clean, cam.project(Xc)
    errors = sample_lifter_errors(len(world), fps, rng, LifterNoise())
    rel = apply_lifter_errors(clean, errors)
    # The 2D detector's share: the image-plane (x, y) part of the per-joint offsets, jitter and
    # bursts, and the left/right swaps, which a lifter inherits from its 2D input. The lifter's own
    # errors (bone lengths, lean, depth scale, depth offsets) stay out of the 2D: the image shows the
    # true body, the lifter's 3D does not.
    image_plane = np.array([1.0, 1.0, 0.0])
    detector = dataclasses.replace(errors, offsets=errors.offsets * image_plane, jitter=errors.jitter * image_plane,
                                   bone_scale=np.ones_like(errors.bone_scale), lean_deg=0.0, depth_scale=1.0)
    seen = apply_lifter_errors(clean, detector)
    # the detector's pelvis (mid-hip) carries its hips' error
    seen[:, PELVIS] = (seen[:, [R_HIP, L_HIP]] - clean[:, [R_HIP, L_HIP]]).mean(axis=1)
    return rel, cam.project(root + seen)


def write_alphapose(path: Path, pixels: np.ndarray) -> None:
    """AlphaPose results JSON, one track (idx 0), Halpe-26 keypoints from H36M-17 pixels."""
    T = len(pixels)
    kp = np.zeros((T, 26, 3))
    for h, j in HALPE_FROM_H36M.items():
        kp[:, h, :2], kp[:, h, 2] = pixels[:, j], CONFIDENCE
    for h, j in HALPE_UNFILLED.items():
        kp[:, h, :2], kp[:, h, 2] = pixels[:, j], 0.0
    entries = []
    for t in range(T):
        flat = [round(float(v), 3) for v in kp[t].ravel()]
        xs, ys = kp[t, :, 0], kp[t, :, 1]
        box = [round(float(xs.min()), 1), round(float(ys.min()), 1), round(float(np.ptp(xs)), 1),
               round(float(np.ptp(ys)), 1)]
        entries.append({"image_id": f"{t}.jpg", "category_id": 1, "keypoints": flat, "score": CONFIDENCE,
                        "box": box, "idx": 0})
    path.write_text(json.dumps(entries))


def write_blank_video(path: Path, frames: int, fps: float) -> bool:
    """A black MP4 of the camera's size, ``frames`` long at ``fps``: what gives the run the image size."""
    try:
        import cv2
    except ImportError:
        return False
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (WIDTH, HEIGHT))
    black = np.zeros((HEIGHT, WIDTH, 3), np.uint8)
    for _ in range(frames):
        writer.write(black)
    writer.release()
    return path.is_file()


def focal_route() -> tuple[str, str]:
    """How this pcnet takes the focal length for ``LIFTER``: ``("config", ...)`` (a RunConfig field
    ``focal_px``), ``("option", ...)`` (the adapter's ``focal_px`` option) or ``("none", why)``."""
    if "focal_px" in {f.name for f in dataclasses.fields(RunConfig)}:
        return "config", "given (RunConfig.focal_px, --focal-px)"
    params = inspect.signature(get_3d_adapter(LIFTER).load).parameters
    if "focal_px" in params or any(p.kind is p.VAR_KEYWORD for p in params.values()):
        return "option", f"--focal-px (lifter option of --lifter {LIFTER})"
    return "none", f"--focal-px is not accepted with --lifter {LIFTER} (only --lifter mediapipe takes it): not passed"


# ---------------------------------------------------------------------------------------------- run
def run_pcnet(folder: Path, rel3d: np.ndarray, pixels: np.ndarray, fps: float, opensim: bool, route: str,
              blank_video: bool, mode: str = "auto") -> tuple[Path, str]:
    """Write the inputs into ``folder`` and run the pipeline; returns (output folder, CLI line)."""
    folder.mkdir(parents=True, exist_ok=True)
    npy, kp = folder / "videopose3d.npy", folder / "alphapose-results.json"
    np.save(npy, rel3d.astype(np.float32))
    write_alphapose(kp, pixels)
    out = folder / "out"
    fields = dict(lifter=LIFTER, lifter_output=str(npy), keypoints2d=str(kp), keypoints2d_format="alphapose",
                  out=str(out), recording=False, opensim=opensim, overwrite=True, mode=mode)
    cli = (f"pcnet run --lifter {LIFTER} --lifter-output {npy.name} --keypoints2d {kp.name} "
           f"--keypoints2d-format alphapose --mode {mode} --no-recording" + (" --opensim" if opensim else ""))
    video = folder / "blank.mp4"
    if blank_video and write_blank_video(video, len(rel3d), fps):
        fields["video"] = str(video)
        cli += f" --video {video.name}"
    else:
        fields["fps"] = float(fps)
        cli += f" --fps {fps:g}"
    if route == "config":
        fields["focal_px"] = FOCAL_PX
        cli += f" --focal-px {FOCAL_PX:.1f}"
    elif route == "option":
        fields["lifter_options"] = {"focal_px": FOCAL_PX}
        cli += f" --focal-px {FOCAL_PX:.1f}"
    run_pipeline(RunConfig(**fields), progress=False)
    return out, cli


def read_columns(path: Path) -> dict[str, np.ndarray]:
    """kinematics.csv as ``{column: float array}`` (empty fields NaN)."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = [[float(v) if v.strip() else math.nan for v in row] for row in reader]
    data = np.asarray(rows, np.float64).reshape(len(rows), len(header))
    return {name: data[:, i] for i, name in enumerate(header)}


def column(cols: dict[str, np.ndarray], name: str, T: int) -> np.ndarray:
    return cols[name] if name in cols else np.full(T, np.nan)


def read_mot(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """An OpenSim ``.mot``: (time, {column: values})."""
    lines = path.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip().lower() == "endheader") + 1
    names = lines[start].split("\t")
    data = np.array([[float(v) for v in line.split("\t")] for line in lines[start + 1:] if line.strip()])
    cols = {n.strip(): data[:, i] for i, n in enumerate(names)}
    return cols["time"], cols


# ------------------------------------------------------------------------------------------ metrics
def rigid_2d(est: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``est`` (N, 2) turned and shifted onto ``ref`` by least squares (no scale, no mirror)."""
    me, mr = est.mean(0), ref.mean(0)
    U, _, Vt = np.linalg.svd((est - me).T @ (ref - mr))
    R = Vt.T @ U.T
    if np.linalg.det(R) < 0:
        Vt[-1] *= -1
        R = Vt.T @ U.T
    return (est - me) @ R.T + mr


def clip_metrics(out: Path, truth, T: int, true_up_camera: np.ndarray) -> dict:
    """The run's world-frame quantities against the truth's ``Kinematics`` (module docstring);
    ``true_up_camera``: the true up in the camera frame (for the tilt error)."""
    cols = read_columns(out / "kinematics.csv")
    with np.load(out / "canonical.npz", allow_pickle=False) as npz:
        report = json.loads(str(npz["report"]))
        notes = [str(n) for n in npz["notes"]] if "notes" in npz.files else []
    valid = column(cols, "valid", T) > 0.5
    m = {"root_path": report.get("root_path", "no world frame"), "mode": report.get("mode", "-"),
         "frame": report.get("kinematics_frame", "-"), "valid": float(valid.mean()),
         "focal_note": any("focal" in n.lower() for n in notes)}
    up = np.asarray(report.get("up") or [math.nan] * 3, float)  # sequence mode: the recording's one up
    m["tilt_deg"] = float(np.degrees(np.arccos(np.clip(up @ true_up_camera / np.linalg.norm(up), -1, 1))))
    world = report.get("kinematics_frame") == "world"
    tp, tv, ta = truth.positions[:, PELVIS], truth.speed[:, PELVIS], truth.acceleration[:, PELVIS, 1]
    # path
    est_xz = np.stack([column(cols, "pelvis_x_m", T), column(cols, "pelvis_z_m", T)], -1)
    ok = valid & np.isfinite(est_xz).all(1) & np.isfinite(tp[:, [0, 2]]).all(1)
    ref = tp[valid & np.isfinite(tp).all(1)][:, [0, 2]]
    m["pinned_m"] = float(np.sqrt(np.mean(np.sum((ref - ref.mean(0)) ** 2, 1)))) if len(ref) else math.nan
    if world and ok.sum() >= 10:
        aligned = rigid_2d(est_xz[ok], tp[ok][:, [0, 2]])
        m["path_m"] = float(np.sqrt(np.mean(np.sum((aligned - tp[ok][:, [0, 2]]) ** 2, 1))))
    else:
        m["path_m"] = math.nan
    # speed
    est_speed = column(cols, "pelvis_speed_m_per_s", T)
    ok = valid & np.isfinite(est_speed) & np.isfinite(tv)
    m["speed_ms"] = float(np.median(np.abs(est_speed[ok] - tv[ok]))) if world and ok.any() else math.nan
    tv_ok = tv[valid & np.isfinite(tv)]
    m["zero_speed_ms"] = float(np.median(tv_ok)) if len(tv_ok) else math.nan
    # floor: stance frames of the truth's lower ankle
    ankles = (R_ANKLE, L_ANKLE)
    true_h = truth.positions[:, ankles, 1]
    est_h = np.stack([column(cols, f"{H36M_JOINTS[j]}_y_m", T) for j in ankles], -1)
    lower = np.argmin(np.where(np.isfinite(true_h), true_h, np.inf), axis=1)
    rows = np.arange(T)
    stance = truth.speed[rows, np.array(ankles)[lower]] < STANCE_SPEED
    diff = true_h[rows, lower] - est_h[rows, lower]
    ok = valid & stance & np.isfinite(diff)
    m["floor_cm"] = float(100 * np.median(diff[ok])) if world and ok.any() else math.nan
    m["stance_frames"] = int(ok.sum())
    est_py = column(cols, "pelvis_y_m", T)
    ok = valid & np.isfinite(est_py) & np.isfinite(tp[:, 1])
    m["pelvis_h_cm"] = float(100 * np.median(np.abs(est_py[ok] - tp[ok, 1]))) if world and ok.any() else math.nan
    # vertical acceleration
    est_ay = column(cols, "pelvis_ay_m_per_s2", T)
    ok = valid & np.isfinite(est_ay) & np.isfinite(ta)
    if world and ok.sum() >= 10:
        m["ay_err"] = float(np.sqrt(np.mean((est_ay[ok] - ta[ok]) ** 2)))
        m["ay_true"] = float(np.sqrt(np.mean(ta[ok] ** 2)))
    else:
        ok = valid & np.isfinite(ta)
        m["ay_err"], m["ay_true"] = math.nan, float(np.sqrt(np.mean(ta[ok] ** 2))) if ok.any() else math.nan
    return m


def ik_difference(est_mot: Path, true_mot: Path, fps: float) -> tuple[float, float, dict[str, float], int]:
    """(MAE over :data:`JOINT_COORDS` and matched frames, the same without :data:`AXIAL_COORDS`,
    per-coordinate MAE, frames), degrees."""
    te, ce = read_mot(est_mot)
    tt, ct = read_mot(true_mot)
    fe, ft = np.round(te * fps).astype(int), np.round(tt * fps).astype(int)
    common, ie, it = np.intersect1d(fe, ft, return_indices=True)
    per = {}
    for name in JOINT_COORDS:
        if name in ce and name in ct:
            d = (ce[name][ie] - ct[name][it] + 180.0) % 360.0 - 180.0
            per[name] = float(np.nanmean(np.abs(d)))
    other = [v for k, v in per.items() if k not in AXIAL_COORDS]
    return (float(np.mean(list(per.values()))) if per else math.nan, float(np.mean(other)) if other else math.nan,
            per, len(common))


def truth_ik(folder: Path, world: np.ndarray, fps: float, name: str = "truth.trc") -> Path:
    """IK on world-frame joint centres (the truth's, or a reference): their TRC through
    stages/opensim_ik.py (what --opensim runs). Returns the ``ik.mot``."""
    from pcnet.stages.opensim_ik import scale_and_ik
    from pcnet.stages.sinks.exports import write_trc

    folder.mkdir(parents=True, exist_ok=True)
    trc = write_trc(folder / name, world, fps)
    scale_and_ik(trc, folder, None, overwrite=True)
    return folder / "ik.mot"


# ------------------------------------------------------------------------------------------ summary
def finite(values) -> np.ndarray:
    v = np.asarray(list(values), float)
    return v[np.isfinite(v)]


def stats(values, f: str = ".3f") -> str:
    """``median / mean / p95`` of the finite values, or ``-``."""
    v = finite(values)
    if not len(v):
        return "-"
    return f"{np.median(v):{f}} / {v.mean():{f}} / {np.percentile(v, 95):{f}}"


def median(values, f: str = ".3f") -> str:
    v = finite(values)
    return f"{np.median(v):{f}}" if len(v) else "-"


def fmt(value: float, f: str) -> str:
    return f"{value:{f}}" if np.isfinite(value) else "-"


def summary_rows(label: str, cond: str, ms: list[dict]) -> list[str]:
    """The summary table's rows for one data set and input."""
    n = len(ms)
    sources: dict[str, int] = {}
    for m in ms:
        sources[m["root_path"]] = sources.get(m["root_path"], 0) + 1
    src = ", ".join(f"{k} {v}" for k, v in sources.items())
    measured_ay = [m for m in ms if np.isfinite(m["ay_err"])]
    below = sum(m["ay_err"] < m["ay_true"] for m in measured_ay)
    speed_ok = sum(m["speed_ms"] <= 0.10 for m in ms if np.isfinite(m["speed_ms"]))
    floor_ok = sum(abs(m["floor_cm"]) <= 2.0 for m in ms if np.isfinite(m["floor_cm"]))
    count = lambda key: len(finite(m[key] for m in ms))  # noqa: E731
    rows = [
        ("camera tilt error (deg)", stats((m["tilt_deg"] for m in ms), ".2f"), "-", "-", count("tilt_deg")),
        ("pelvis path RMS after yaw+shift (m)", stats(m["path_m"] for m in ms),
         median(m["pinned_m"] for m in ms) + " pinned", "-", count("path_m")),
        ("pelvis speed, median abs error (m/s)", stats(m["speed_ms"] for m in ms),
         median(m["zero_speed_ms"] for m in ms) + " zero",
         f"<= 0.10 (clean): {speed_ok} of {count('speed_ms')} clips", count("speed_ms")),
        ("floor above true ground, abs (cm)", stats((abs(m["floor_cm"]) for m in ms), ".1f"),
         "signed median " + median((m["floor_cm"] for m in ms), ".1f"),
         f"within 2: {floor_ok} of {count('floor_cm')} clips", count("floor_cm")),
        ("pelvis height, median abs error (cm)", stats((m["pelvis_h_cm"] for m in ms), ".1f"), "-", "-",
         count("pelvis_h_cm")),
        ("pelvis a_y RMS error (m/s^2)", stats((m["ay_err"] for m in ms), ".2f"),
         median((m["ay_true"] for m in ms), ".2f") + " true RMS (= zero)",
         f"< true RMS: {below} of {len(measured_ay)} clips", len(measured_ay)),
    ]
    os_ms = [m for m in ms if "ik_mae" in m]
    if os_ms:
        ok = sum(m["ik_mae"] <= 5.0 for m in os_ms if np.isfinite(m["ik_mae"]))
        rows.append(("OpenSim joint-angle MAE vs IK on truth (deg)", stats((m["ik_mae"] for m in os_ms), ".2f"),
                     _input_ref(os_ms, "ik_input"),
                     f"<= 5 (lifter noise): {ok} of {len(finite(m['ik_mae'] for m in os_ms))} clips",
                     len(finite(m["ik_mae"] for m in os_ms))))
        ok = sum(m["ik_mae_nonaxial"] <= 5.0 for m in os_ms if np.isfinite(m["ik_mae_nonaxial"]))
        rows.append(("the same without the 5 axial rotations (deg)", stats((m["ik_mae_nonaxial"] for m in os_ms), ".2f"),
                     _input_ref(os_ms, "ik_input_nonaxial"), f"<= 5 (lifter noise): {ok} of {len(finite(m['ik_mae_nonaxial'] for m in os_ms))} clips",
                     len(finite(m["ik_mae_nonaxial"] for m in os_ms))))
    return [f"| {label} | {cond} | {n} | {src} | {name} | {s} | {ref} | {target} | {k} |"
            for name, s, ref, target, k in rows]


def _input_ref(ms: list[dict], key: str) -> str:
    """The OpenSim rows' reference: IK on the noisy input placed in the true world frame."""
    v = finite(m[key] for m in ms if key in m)
    return f"{np.median(v):.2f} input alone (true rotation)" if len(v) else "-"


# --------------------------------------------------------------------------------------------- main
def select_clips(data: Path, key: str, cmu_split: str, max_clips: int, max_seconds: float):
    label, file = SETS[key]
    clips = load_mocap(data / "mocap" / file)
    if key == "cmu":
        clips = [c for s in cmu_split.split("+") for c in select_split(clips, s, "motion-style")]
        if cmu_split != "test":
            label = {"val": "CMU validation subjects 12, 60"}.get(cmu_split, f"CMU {cmu_split} subjects")
    long_enough = [c for c in clips if len(c.joints) / c.fps >= MIN_SECONDS]
    short = [c.name for c in clips if len(c.joints) / c.fps < MIN_SECONDS]
    picks = np.unique(np.linspace(0, len(long_enough) - 1, min(max_clips, len(long_enough))).round().astype(int))
    order = list(picks) + [i for i in range(len(long_enough)) if i not in set(picks)]
    out = []
    for i in order:
        c = long_enough[i]
        n = min(len(c.joints), int(round(max_seconds * c.fps)))
        out.append((c.name, np.asarray(c.joints[:n], np.float64), float(c.fps)))
    return label, out, short


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--max-clips", type=int, default=6, help="per data set")
    ap.add_argument("--opensim-clips", type=int, default=2, help="per data set: OpenSim IK on the first M clips")
    ap.add_argument("--max-seconds", type=float, default=20.0, help="keep at most the first S seconds of a clip")
    ap.add_argument("--sets", default="cmu,deepmimic")
    ap.add_argument("--cmu-split", default="test", choices=("test", "val", "val+test"))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--mode", default="auto", choices=("auto", "sequence"),
                    help="pcnet run --mode (auto: what a user gets by default; sequence: told the camera is static)")
    ap.add_argument("--no-video", action="store_true",
                    help="no black MP4 of the camera's size: the run then knows no image size (--fps given instead)")
    ap.add_argument("--keep", type=Path, default=None, help="keep the inputs and outputs in this folder")
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args()
    t0 = time.perf_counter()
    route, route_text = focal_route()
    if args.opensim_clips > 0:
        from pcnet.stages.opensim_ik import import_opensim
        try:
            import_opensim()
        except Exception as err:  # noqa: BLE001 - say why and go on without IK
            print(f"OpenSim unavailable ({err}); no IK", flush=True)
            args.opensim_clips = 0
    command = "python -m benchmarks.world_validation" + "".join(f" {a}" for a in sys.argv[1:])
    head = [__doc__.splitlines()[0], "", f"    {command}", "",
            f"camera {WIDTH}x{HEIGHT} px, f = {FOCAL_PX:.1f} px (26 mm equivalent), principal point at the centre, "
            f"'paper' views, distance U{DISTANCE_RANGE_M} m moved back to keep the clip in view (<= {MAX_DISTANCE_M:g} m); "
            f"lifter {LIFTER} (.npy), 2D AlphaPose Halpe-26; focal length: {route_text}; image size: "
            + ("not given (--no-video)" if args.no_video else "from a black MP4 of that size (--video)"), ""]
    print("\n".join(head), flush=True)
    tmp_root = Path(tempfile.mkdtemp(prefix="world_validation_")) if args.keep is None else args.keep
    per_clip = ["| data | clip | input | frames | fps | distance m | mode | root_path | tilt err deg | path m (pinned) | "
                "speed err m/s (zero) | floor cm | pelvis h err cm | a_y err (true RMS) m/s^2 | OpenSim MAE deg (non-axial) |",
                "|---|---|---|---:|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    summary = ["| data | input | clips | root_path (run's report) | metric | median / mean / p95 over clips | "
               "reference | target | clips measured |", "|---|---|---:|---|---|---|---|---|---:|"]
    coord_acc: dict = {}
    all_results: list[list[dict]] = []
    skipped: list[str] = []
    cli_example = ""
    try:
        for key in [s.strip() for s in args.sets.split(",") if s.strip()]:
            label, candidates, short = select_clips(args.data, key, args.cmu_split, args.max_clips, args.max_seconds)
            if short:
                skipped.append(f"{label}: {len(short)} clips shorter than {MIN_SECONDS:g} s")
            results = {c: [] for c in CONDITIONS}
            done = 0
            for name, joints, fps in candidates:
                if done >= args.max_clips:
                    break
                seed = [args.seed, zlib.crc32(name.encode())]
                world = truth_world(joints, fps)
                cam = place_camera(world, np.random.default_rng(seed))
                if cam is None:
                    skipped.append(f"{label}: {name} leaves the view at {MAX_DISTANCE_M:g} m")
                    continue
                with_ik = done < args.opensim_clips
                clip_dir = tmp_root / key / name.replace("/", "_")
                true_mot = truth_ik(clip_dir / "truth_ik", world, fps) if with_ik else None
                for k, cond in enumerate(CONDITIONS):
                    rel, px = make_inputs(world, cam, fps, cond != "clean", np.random.default_rng(seed + [1]))
                    t1 = time.perf_counter()
                    try:
                        out, cli = run_pcnet(clip_dir / cond.replace(" ", "_"), rel, px, fps, with_ik, route,
                                             not args.no_video, args.mode)
                    except Exception as err:  # noqa: BLE001 - one failing run is a result, not the end
                        skipped.append(f"{label}: {name} ({cond}): pcnet run failed: {type(err).__name__}: {err}")
                        continue
                    cli_example = cli_example or cli
                    cutoff = 6.0
                    with np.load(out / "canonical.npz", allow_pickle=False) as npz:
                        cutoff = float(json.loads(str(npz["report"])).get("cutoff_hz") or 6.0)
                    truth = compute_kinematics(world, fps, cutoff)
                    m = clip_metrics(out, truth, len(world), cam.rotation[:, 1])
                    if with_ik and (out / "ik.mot").is_file():
                        m["ik_mae"], m["ik_mae_nonaxial"], per, m["ik_frames"] = ik_difference(
                            out / "ik.mot", true_mot, fps)
                        for coord, v in per.items():
                            coord_acc.setdefault((label, cond, coord), []).append(v)
                    elif with_ik:
                        m["ik_mae"] = m["ik_mae_nonaxial"] = math.nan
                    if with_ik and cond != "clean":
                        # the input's own share: the same noisy joints placed in the true world frame
                        # (true camera rotation and pelvis), what a perfect rectification would give
                        placed = rel @ cam.rotation + world[:, PELVIS : PELVIS + 1]
                        floor_mot = truth_ik(clip_dir / "input_ik", placed, fps, "input.trc")
                        m["ik_input"], m["ik_input_nonaxial"], _, _ = ik_difference(floor_mot, true_mot, fps)
                    results[cond].append(m)
                    ik = f"{fmt(m['ik_mae'], '.2f')} ({fmt(m['ik_mae_nonaxial'], '.2f')})" if "ik_mae" in m else "-"
                    if "ik_input" in m:
                        ik += f" [input {fmt(m['ik_input'], '.2f')} ({fmt(m['ik_input_nonaxial'], '.2f')})]"
                    row = (f"| {key} | {name} | {cond} | {len(world)} | {fps:g} | {cam.distance:.2f} | "
                           f"{m['mode']} | {m['root_path']} | {fmt(m['tilt_deg'], '.2f')} | "
                           f"{fmt(m['path_m'], '.3f')} ({fmt(m['pinned_m'], '.3f')}) | "
                           f"{fmt(m['speed_ms'], '.3f')} ({fmt(m['zero_speed_ms'], '.3f')}) | "
                           f"{fmt(m['floor_cm'], '.1f')} | {fmt(m['pelvis_h_cm'], '.1f')} | "
                           f"{fmt(m['ay_err'], '.2f')} ({fmt(m['ay_true'], '.2f')}) | {ik} |")
                    per_clip.append(row)
                    print(row + f"  [{time.perf_counter() - t1:.0f} s]", flush=True)
                done += 1
            all_results += list(results.values())
            for cond in CONDITIONS:
                if results[cond]:
                    summary += summary_rows(label, cond, results[cond])
    finally:
        if args.keep is None:
            shutil.rmtree(tmp_root, ignore_errors=True)
    coords = ["OpenSim per coordinate, MAE (deg) vs IK on the truth, mean over clips:", "",
              "| data | input | " + " | ".join(JOINT_COORDS) + " |", "|---|---|" + "---:|" * len(JOINT_COORDS)]
    for label, cond in sorted({(a, b) for a, b, _ in coord_acc}):
        coords.append(f"| {label} | {cond} | " + " | ".join(
            f"{np.mean(coord_acc[(label, cond, c)]):.1f}" if (label, cond, c) in coord_acc else "-"
            for c in JOINT_COORDS) + " |")
    lines = head + [f"run as: {cli_example} (per clip and input; Python API run_pipeline(RunConfig(...)))", "",
                    "Summary (median / mean / p95 over clips; '-' = the run does not give the quantity, e.g. the "
                    "horizontal path from a root-relative lifter; reference = the error of reporting a pinned pelvis "
                    "or zero):", ""] + summary + ["", "Per clip:", ""] + per_clip + [""]
    if coord_acc:
        lines += coords + [""]
    runs = [m for rs in all_results for m in rs]
    lines += [f"runs whose notes mention the focal length (a sign the run used it): "
              f"{sum(m['focal_note'] for m in runs)} of {len(runs)}"]
    lines += [f"skipped: {s}" for s in skipped] + ["", f"run time {time.perf_counter() - t0:.0f} s"]
    print("\n".join(["", *summary, "", *(coords if coord_acc else []), "", *[f"skipped: {s}" for s in skipped]]),
          flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out} (run time {time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
