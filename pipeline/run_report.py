"""What a ``pcnet run`` decided and measured for one recording, typed: the rectification's
report and the facts the later steps add (the camera's tilt, the display rotation, the world
frame, the low-pass cutoff, the motion check). :meth:`RunReport.as_record` is ``canonical.npz``'s
``report`` (docs/outputs.md lists its keys) and report.md's "Report numbers"."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

from pcnet.stages.floor import Floor
from pcnet.stages.rectification_report import RectificationReport

from .checks import CameraTilt


@dataclass(frozen=True)
class RunReport:
    """One run's report.

    rectification: what rectification decided; tilt: the camera's tilt, pitch and roll from
    level of the recording's mean up (deg; sequence mode: its one up); tilt_per_frame_deg:
    median, 5th and 95th percentile of the per-frame tilt (deg;
    :func:`pcnet.stages.flags.per_frame_tilt_summary`), ``None`` in sequence mode (its frames share
    its one up); display_rotation: how a video stored
    turned was read (:meth:`pcnet.pipeline.video_orientation.DisplayOrientation.report`), or
    ``None``; kinematics_frame: ``"world"`` or ``"canonical"``; root_path: where a world
    frame's pelvis path came from (:mod:`pcnet.pipeline.pelvis_path`), ``None`` without a world
    frame; floor: the world frame's floor (:class:`pcnet.stages.floor.Floor`), or ``None``; cutoff_hz, cutoff_source: the low-pass cutoff (Hz) and where it came from
    (``"cutoff_hz"`` or ``"residual analysis"``); implausible_frames: frames the motion check
    marked, ``None`` when it did not run (non-metric poses); inputs: what the run read (each
    file, the format it was read as and the joint layout found in it; empty where unknown).
    """

    rectification: RectificationReport
    tilt: CameraTilt
    tilt_per_frame_deg: list[float] | None
    display_rotation: dict | None
    kinematics_frame: str
    root_path: str | None
    floor: Floor | None
    cutoff_hz: float
    cutoff_source: str
    implausible_frames: int | None
    inputs: dict = field(default_factory=dict)

    def as_record(self) -> dict:
        """The flat record of docs/outputs.md (not yet JSON: :func:`pcnet.stages.sinks.result.jsonable`)."""
        out = {"inputs": self.inputs} if self.inputs else {}
        out.update(self.rectification.as_record())
        if self.display_rotation is not None:
            out["display_rotation"] = self.display_rotation
        out.update(camera_record(self.tilt, self.tilt_per_frame_deg))
        if self.root_path is not None:
            out.update(root_path=self.root_path, floor=None if self.floor is None else asdict(self.floor))
        out.update(kinematics_frame=self.kinematics_frame, cutoff_hz=self.cutoff_hz, cutoff_source=self.cutoff_source)
        if self.implausible_frames is not None:
            out["implausible_frames"] = self.implausible_frames
        return out


def camera_record(tilt: CameraTilt, tilt_per_frame_deg: list[float] | None) -> dict:
    """The report's camera keys, what the summary's tilt line prints, in every mode (sequence
    mode: its one up): ``camera_tilt_deg``, ``camera_pitch_deg``, ``camera_roll_deg`` and, where
    given (frame and smooth modes), ``camera_tilt_per_frame_deg`` (docs/outputs.md)."""
    out = dict(camera_tilt_deg=tilt.tilt_deg, camera_pitch_deg=tilt.pitch_deg, camera_roll_deg=tilt.roll_deg)
    if tilt_per_frame_deg is not None:
        out["camera_tilt_per_frame_deg"] = tilt_per_frame_deg
    return out


__all__ = ["RunReport", "camera_record"]
