"""The sequence intervals on every real recording with a gravity truth (decision 0080).

    python -m benchmarks.real_intervals --data ../shared/data [--out benchmarks/results/real_intervals.txt]

Each recording is run as the README runs it: `pcnet run` with its defaults (sequence mode, no
`--focal-px`; a file's own calibration is used where it carries one), from every lifter output
the shared data holds for it, and from its video alone (the embedded MediaPipe; needs the
``video`` extra):

- the four Pose2Sim lab cameras (``real/pose2sim_gravity``, one man standing, 11 frames at
  60 fps): the stored MediaPipe 0.10.21 files (2D and 3D, the lab's camera matrix inside) and
  the ``.mp4`` alone; truth: the calibration's ``up_camera``;
- the boxing clip (``real/boxing_motionbert``): MotionBERT with AlphaPose 2D and the video, and
  the video alone; the Sports2D clip (``real/sports2d_demo``): its stored MediaPipe file with the
  video, and the video alone; truth: the vanishing points of :mod:`benchmarks.vanishing_gravity`
  (their point estimate; their own 95 % intervals are printed there).

Per recording: the summary's camera pitch and roll with their printed half-widths, the
truth's, whether each axis's interval holds it, and the tilt error of the up the summary
describes. The count of recordings whose two intervals both hold the truth decides
decision 0080's rule.
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmarks.gravity_benchmark import deg_between, pitch_roll_deg
from benchmarks.report import trial_arguments
from pcnet.pipeline.config import RunConfig
from pcnet.pipeline.runner import run_pipeline
from pcnet.stages.core.rotations import compose_camera_rotation

RESULT = Path(__file__).resolve().parent / "results" / "real_intervals.txt"
COMMAND = "python -m benchmarks.real_intervals --data ../shared/data"
POSE2SIM = ("real", "pose2sim_gravity")
CAMERAS = ("cam01", "cam02", "cam03", "cam04")


@dataclass(frozen=True)
class IntervalCheck:
    """One `pcnet run` against a true camera up: degrees; ``*_half`` the printed 95 %
    half-widths (NaN where the run printed none); ``up`` ``(3,)`` the camera-frame up its
    summary's pitch and roll describe."""

    mode: str
    pitch: float
    roll: float
    pitch_half: float
    roll_half: float
    true_pitch: float
    true_roll: float
    tilt_error: float
    up: np.ndarray = field(compare=False)

    @property
    def pitch_holds(self) -> bool:
        return bool(abs(self.pitch - self.true_pitch) <= self.pitch_half)

    @property
    def roll_holds(self) -> bool:
        return bool(abs(self.roll - self.true_roll) <= self.roll_half)

    @property
    def has_interval(self) -> bool:
        return bool(np.isfinite(self.pitch_half + self.roll_half))

    @property
    def holds(self) -> bool:
        return self.pitch_holds and self.roll_holds


def scratch_run(cfg: RunConfig):
    """:func:`pcnet.pipeline.runner.run_pipeline` of ``cfg`` into a throwaway folder, without
    the rerun recording; its result."""
    with tempfile.TemporaryDirectory() as tmp:
        return run_pipeline(RunConfig(**{**cfg.__dict__, "out": str(Path(tmp) / "out"), "recording": False}))


def check_run(cfg: RunConfig, up_true: np.ndarray) -> IntervalCheck:
    """Run ``cfg`` (:func:`scratch_run`) and compare its summary's camera pitch and roll, and
    their intervals, with ``up_true`` ``(3,)`` (camera frame)."""
    result = scratch_run(cfg)
    rep = result.report.as_record()
    p, r = result.camera_pitch_deg, result.camera_roll_deg
    tp, tr = pitch_roll_deg(up_true)
    # the up its summary's pitch and roll describe (smooth mode has no single sequence up)
    up = compose_camera_rotation(0.0, np.radians(p), np.radians(r))[:, 1]
    return IntervalCheck(result.mode, p, r, float(rep.get("camera_pitch_interval_deg", np.nan)),
                         float(rep.get("camera_roll_interval_deg", np.nan)), tp, tr, float(deg_between(up, up_true)), up)


def vanishing_truths(data: Path) -> dict[str, np.ndarray]:
    """The true camera up ``(3,)`` of each recording of :mod:`benchmarks.vanishing_gravity`
    (its point estimate from the vanishing points)."""
    from benchmarks.vanishing_gravity import LINES, RECORDINGS, truth

    from pcnet.stages.core.perspective import focal_px_from_35mm

    specs = json.loads(LINES.read_text())
    rng = np.random.default_rng(0)
    return {name: truth(spec, focal_px_from_35mm(spec["width"], spec["height"]), rng)["up"]
            for name, spec in specs.items() if name in RECORDINGS}


def recordings(data: Path) -> list[tuple[str, str, RunConfig, np.ndarray]]:
    """``(scene, source, run configuration, true up)`` of every recording (module docstring)."""
    from benchmarks.vanishing_gravity import RECORDINGS

    out = []
    for cam in CAMERAS:
        stored = data.joinpath(*POSE2SIM, f"statictrial_{cam}.npz")
        with np.load(stored, allow_pickle=False) as f:
            up = np.asarray(f["up_camera"], np.float64)
        up = up / np.linalg.norm(up)
        video = stored.with_suffix(".mp4")
        out.append((f"Pose2Sim {cam}", "MediaPipe 0.10.21, stored file",
                    RunConfig(video=str(video), lifter="mediapipe", lifter_output=str(stored), keypoints2d=str(stored),
                              keypoints2d_format="mediapipe"), up))
        out.append((f"Pose2Sim {cam}", "video alone (embedded MediaPipe)", RunConfig(video=str(video)), up))
    truths = vanishing_truths(data)
    sources = {"boxing": "MotionBERT on AlphaPose", "sports2d": "MediaPipe, stored file"}
    for name, rec in RECORDINGS.items():
        run = {k: str(data / v) if k in ("video", "keypoints2d", "lifter_output") else v for k, v in rec["run"].items()}
        out.append((name, sources[name], RunConfig(**run), truths[name]))
        out.append((name, "video alone (embedded MediaPipe)", RunConfig(video=run["video"]), truths[name]))
    return out


def main(argv=None) -> int:
    args = trial_arguments(__doc__, RESULT, argv, script="real_intervals", needs="real/pose2sim_gravity")
    lines = [__doc__.splitlines()[0], "", f"    {COMMAND}", "",
             f"{'scene':<16}{'source':<34}{'mode':<10}{'pitch':>16}{'true':>7}{'roll':>16}{'true':>7}"
             f"{'both hold':>11}{'tilt err':>10}"]
    checks = []
    for scene, source, cfg, up in recordings(args.data):
        c = check_run(cfg, up)
        checks.append((source, c))
        mark = "yes" if c.holds else ("-" if not c.has_interval else "NO")
        lines.append(f"{scene:<16}{source:<34}{c.mode:<10}{c.pitch:+7.1f} +- {c.pitch_half:4.1f}{c.true_pitch:+7.1f}"
                     f"{c.roll:+7.1f} +- {c.roll_half:4.1f}{c.true_roll:+7.1f}{mark:>11}{c.tilt_error:10.1f}")
        print(lines[-1], flush=True)
    lines.append("")
    with_interval = [(s, c) for s, c in checks if c.has_interval]
    for label, keep in (("all", lambda s: True), ("stored lifter files", lambda s: "video alone" not in s),
                        ("video alone (embedded MediaPipe)", lambda s: "video alone" in s)):
        cs = [c for s, c in with_interval if keep(s)]
        lines.append(f"{label}: both intervals hold the truth in {sum(c.holds for c in cs)} of {len(cs)} recordings "
                     f"(pitch {sum(c.pitch_holds for c in cs)}, roll {sum(c.roll_holds for c in cs)}); "
                     f"mean tilt error {np.mean([c.tilt_error for c in cs]):.1f} deg")
    text = "\n".join(lines) + "\n"
    print("\n".join(lines[-4:]))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
