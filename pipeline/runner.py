"""The staged pipeline behind ``pcnet run``: files -> H36M-17 -> rectification -> kinematics
-> exports and a rerun recording.

All outputs are written into a temporary folder beside ``out`` that is renamed to ``out``
only when every stage has succeeded, so a failure never leaves a half-written result.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

from pcnet.adapters import get_2d_adapter, get_3d_adapter, probe_video
from pcnet.stages.conventions import H36M_JOINTS, L_WRIST, PELVIS, R_WRIST
from pcnet.stages.exports import plot_wrists, write_kinematics_csv, write_npz, write_trc
from pcnet.stages.kinematics import compute_kinematics
from pcnet.stages.rectify import NO_VALID_FRAME, rectify, up_refiner_note
from pcnet.stages.remap import mask_low_confidence, remap_to_h36m
from pcnet.stages.rerun_log import series_from_kinematics, write_recording
from pcnet.stages.rotations import decompose_camera_rotation
from pcnet.stages.scale import scale_to_height

from .config import RunConfig

STEPS = ("inputs", "remap", "rectify", "scale", "kinematics", "exports", "recording")


@dataclass
class RunResult:
    """What a run produced: counts, the rectification report and output paths."""

    frames: int
    valid_frames: int
    units: str
    method: str
    mode: str
    camera_tilt_deg: float
    camera_pitch_deg: float
    camera_roll_deg: float
    report: dict
    outputs: dict[str, Path] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)

    def summary(self) -> str:
        """A one-screen text summary."""
        lines = [
            f"frames            {self.frames} ({self.frames - self.valid_frames} dropped: no valid pose)",
            f"rectification     {self.method}, mode {self.mode} (requested {self.report.get('requested_mode')}"
            + (f"; spread of per-frame up {self.report['spread_deg']:.1f} deg" if "spread_deg" in self.report else "")
            + up_refiner_note(self.report) + ")",
            f"heading           from {self.report.get('heading_source')} (requested "
            f"{self.report.get('requested_heading_source')}; hip width varies "
            f"{self.report.get('hip_width_cv_percent', float('nan')):.1f} %)",
            f"camera tilt       {self.camera_tilt_deg:.1f} deg from level " + self._pitch_roll(),
            f"units             {self.units}",
        ]
        lines += [f"note              {n}" for n in self.notes]
        lines += [f"{name:<18}{path}" for name, path in self.outputs.items()]
        if "recording" in self.outputs:
            lines.append(f"open the recording with:  rerun {self.outputs['recording']}")
        return "\n".join(lines)


    def _pitch_roll(self) -> str:
        pitch_unc = self.report.get("camera_pitch_uncertainty_deg", float("nan"))
        roll_unc = self.report.get("camera_roll_uncertainty_deg", float("nan"))
        if not (np.isfinite(pitch_unc) and np.isfinite(roll_unc)):
            return f"(pitch {self.camera_pitch_deg:+.1f}, roll {self.camera_roll_deg:+.1f} deg)"
        return (f"(pitch {self.camera_pitch_deg:+.1f} +- {pitch_unc:.1f}, roll {self.camera_roll_deg:+.1f} "
                f"+- {roll_unc:.1f} deg; 95 % block bootstrap, evidence: {self.report.get('evidence')})")


def _load_inputs(cfg: RunConfig):
    video = probe_video(cfg.video) if cfg.video else None
    fps = float(cfg.fps or video.fps)
    kp2d = None
    if cfg.keypoints2d:
        options = {"person": cfg.person} if cfg.keypoints2d_format in ("alphapose", "mmpose") else {}
        kp = get_2d_adapter(cfg.keypoints2d_format).load(cfg.keypoints2d, **options)
        kp2d = remap_to_h36m(kp.points, kp.layout, confidence_channel=True)
    poses = get_3d_adapter(cfg.lifter).load(cfg.lifter_output, **cfg.lifter_options)
    joints = poses.joints if poses.layout == "h36m17" else remap_to_h36m(poses.joints, poses.layout)
    return video, fps, kp2d, joints, poses.units


def _align(cfg: RunConfig, video, kp2d, joints):
    counts = {"3D lifter output": (cfg.lifter_output, len(joints))}
    if kp2d is not None:
        counts["2D keypoints"] = (cfg.keypoints2d, len(kp2d))
    if video is not None:
        counts["video"] = (cfg.video, video.frame_count)
    n = min(c for _, c in counts.values())
    if len({c for _, c in counts.values()}) > 1:
        if cfg.align != "truncate":
            detail = ", ".join(f"{k} {p}: {c} frames" for k, (p, c) in counts.items())
            raise ValueError(f"frame counts differ ({detail}); pass --align truncate to use the first {n} frames")
        joints = joints[:n]
        kp2d = None if kp2d is None else kp2d[:n]
    return kp2d, joints


def run_pipeline(cfg: RunConfig, progress: bool = True) -> RunResult:
    """Run every stage for one recording and write its outputs into ``cfg.out``.

    Raises:
        FileExistsError: ``cfg.out`` exists and ``cfg.overwrite`` is False.
        ValueError / pcnet.adapters.AdapterError: bad inputs, naming file and field.
    """
    cfg.validate()
    out = Path(cfg.out)
    if out.exists() and not cfg.overwrite:
        raise FileExistsError(f"{out}: output folder exists; choose another --out or pass --overwrite")
    with tqdm(total=len(STEPS), desc="pcnet", disable=not progress, unit="stage") as bar:
        return _run_stages(cfg, out, bar)


def _run_stages(cfg: RunConfig, out: Path, bar) -> RunResult:
    seconds: dict[str, float] = {}
    clock = [time.perf_counter(), None]

    def step(name: str) -> None:
        now = time.perf_counter()
        if clock[1] is not None:
            seconds[clock[1]] = now - clock[0]
        clock[:] = [now, name]
        bar.set_postfix_str(name)

    step("inputs")
    video, fps, kp2d, joints, units = _load_inputs(cfg)
    kp2d, joints = _align(cfg, video, kp2d, joints)
    bar.update()

    step("remap")
    notes: list[str] = []
    joints = joints - joints[:, PELVIS : PELVIS + 1]  # root-relative camera frame
    if kp2d is not None:
        joints = mask_low_confidence(joints, kp2d[..., 2], cfg.confidence_threshold)
    if not np.isfinite(joints).any():
        raise ValueError(f"{cfg.lifter_output}: every joint of every frame is missing (NaN) after masking")
    bar.update()

    step("rectify")
    try:
        res = rectify(joints, cfg.method, cfg.weights, cfg.mode, fps, cfg.heading, cfg.up_refiner)
    except ValueError as err:
        raise ValueError(f"{cfg.lifter_output}: {err}") from err
    if not res.valid.any():
        raise ValueError(f"{cfg.lifter_output}: {NO_VALID_FRAME}")
    rotations, canonical, valid, report = res.rotation, res.canonical, res.valid, res.report
    bar.update()

    step("scale")
    if cfg.height is not None:
        joints, factor = scale_to_height(joints, cfg.height)
        canonical = (canonical * factor).astype(np.float32)
        notes.append(f"scaled by {factor:.4g} to a {cfg.height} m subject (from {units})")
        units = "m"
    elif units != "m":
        notes.append(f"lifter output is {units}, not metres: give --height for metric kinematics and a TRC file")
    bar.update()

    step("kinematics")
    kin = compute_kinematics(canonical, fps, cfg.cutoff_hz, units)
    kin_cam = compute_kinematics(joints, fps, cfg.cutoff_hz, units)
    bar.update()

    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        step("exports")
        frames = np.arange(len(joints))
        heading, pitch, roll = decompose_camera_rotation(rotations)
        write_npz(
            tmp / "canonical.npz", rotation=rotations, canonical=canonical, joints_camera=joints,
            up=rotations[:, :, 1], valid=valid, heading_deg=np.degrees(heading), fps=fps, units=units,
            method=cfg.method, mode=report["mode"], heading_source=report["heading_source"], joint_names=np.array(H36M_JOINTS),
            keypoints2d=kp2d if kp2d is not None else np.zeros((0, 17, 3), np.float32),
            report=_jsonable(report),
        )
        write_kinematics_csv(tmp / "kinematics.csv", frames, frames / fps, kin,
                             extra_columns={"valid": valid.astype(int), "heading_deg": np.degrees(heading)})
        outputs = {"canonical.npz": tmp / "canonical.npz", "kinematics.csv": tmp / "kinematics.csv"}
        if units == "m":
            write_trc(tmp / "canonical.trc", canonical, fps)
            outputs["canonical.trc"] = tmp / "canonical.trc"
        plot_wrists(tmp / "wrists.png", joints, canonical, fps, kin_cam.acceleration, kin.acceleration, units)
        outputs["wrists.png"] = tmp / "wrists.png"
        bar.update()

        step("recording")
        if cfg.recording:
            wrists = {n: kin.positions[:, j] for n, j in (("left_wrist", L_WRIST), ("right_wrist", R_WRIST))}
            write_recording(
                tmp / "recording.rrd", fps=fps, joints_cam=joints, canonical=canonical, rotations=rotations,
                up=rotations[:, :, 1], valid=valid, keypoints2d=kp2d, video_path=cfg.video,
                wrist_paths=wrists, series=series_from_kinematics(kin), min_confidence=cfg.confidence_threshold,
            )
            outputs["recording"] = tmp / "recording.rrd"
        bar.update()
        step("done")
        if out.exists():
            shutil.rmtree(out)
        tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise

    ok = valid & np.isfinite(pitch)
    tilt = np.degrees(np.arccos(np.clip(-rotations[ok, 1, 1], -1, 1)))  # angle of up from image-up
    return RunResult(
        frames=len(joints), valid_frames=int(valid.sum()), units=units, method=cfg.method, mode=report["mode"],
        camera_tilt_deg=float(np.mean(tilt)) if ok.any() else float("nan"),
        camera_pitch_deg=float(np.degrees(np.mean(pitch[ok]))) if ok.any() else float("nan"),
        camera_roll_deg=float(np.degrees(np.mean(roll[ok]))) if ok.any() else float("nan"),
        report=report, outputs={k: out / v.name for k, v in outputs.items()}, notes=notes, seconds=seconds,
    )


def _jsonable(report: dict) -> dict:
    """The report without per-frame arrays, with numpy scalars as floats."""
    clean = {}
    for k, v in report.items():
        if isinstance(v, np.ndarray):
            if v.ndim == 0 or v.size <= 3:
                clean[k] = v.tolist()
        elif isinstance(v, (np.floating, np.integer)):
            clean[k] = v.item()
        elif isinstance(v, dict):
            clean[k] = _jsonable(v)
        else:
            clean[k] = v
    return clean
