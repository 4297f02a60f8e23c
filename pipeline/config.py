"""Configuration of one ``pcnet run``: a plain dataclass, loadable from TOML or a CSV row."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from pcnet.models.toml_config import check_config_keys, read_toml

KEYPOINT_FORMATS = ("alphapose", "mmpose", "openpose", "mediapipe")
LIFTERS = ("motionbert", "ddhpose", "videopose3d", "mediapipe", "generic")
MODES = ("auto", "frame", "sequence", "smooth")
ALIGN = ("none", "truncate")


@dataclass
class RunConfig:
    """Inputs and options of the staged pipeline (same names as ``pcnet run``'s options).

    ``lifter_options`` are passed to the 3D adapter (``pixel`` for motionbert,
    ``hypothesis``/``step`` for ddhpose, ``layout``/``axes``/``units``/``key`` for generic);
    ``person`` picks a 2D track (AlphaPose ``idx``, MMPose instance position); ``heading``
    is the heading source of :func:`pcnet.stages.rectify.rectify` (``None`` = its default);
    ``up_refiner`` its up refiners (frame, and static-camera in sequence mode; on by default).
    """

    lifter: str
    lifter_output: str
    keypoints2d: str | None = None
    keypoints2d_format: str | None = None
    video: str | None = None
    out: str = "pcnet_out"
    method: str = "pcnet"
    mode: str = "auto"
    heading: str | None = None
    height: float | None = None
    fps: float | None = None
    person: int | None = None
    confidence_threshold: float = 0.3
    cutoff_hz: float = 6.0
    align: str = "none"
    overwrite: bool = False
    recording: bool = True
    weights: str | None = None
    up_refiner: bool = True
    lifter_options: dict = field(default_factory=dict)

    def validate(self) -> "RunConfig":
        """Check choices and combinations; raises ValueError naming the field."""
        from pcnet.stages.rectify import METHODS

        from pcnet.stages.heading import HEADING_SOURCES

        # (field, value, choices, None allowed)
        for name, value, choices, optional in (
            ("lifter", self.lifter, LIFTERS, False), ("method", self.method, METHODS, False),
            ("mode", self.mode, MODES, False), ("align", self.align, ALIGN, False),
            ("heading", self.heading, HEADING_SOURCES, True),
            ("keypoints2d_format", self.keypoints2d_format, KEYPOINT_FORMATS, True),
        ):
            if not (optional and value is None) and value not in choices:
                raise ValueError(f"{name}: expected one of {choices}, got {value!r}")
        if (self.keypoints2d is None) != (self.keypoints2d_format is None):
            raise ValueError("keypoints2d and keypoints2d_format: give both or neither")
        if self.video is None and self.fps is None:
            raise ValueError("fps: needed when no video is given (the frame rate of the keypoint files)")
        if self.height is not None and not self.height > 0:
            raise ValueError(f"height: expected the subject's height in metres (> 0), got {self.height}")
        if not 0 <= self.confidence_threshold <= 1:
            raise ValueError(f"confidence_threshold: expected a value in [0, 1], got {self.confidence_threshold}")
        return self


def load_run_config(path: str | Path, **overrides) -> RunConfig:
    """Read a TOML file whose top-level keys are :class:`RunConfig` fields (plus an optional
    ``[lifter_options]`` table); relative paths are resolved against the file's folder;
    ``overrides`` (not None) win.

    Raises:
        ValueError: unknown keys or invalid values, naming the file.
    """
    path = Path(path)
    raw = read_toml(path)
    check_config_keys(path, "", raw, RunConfig)
    for key in ("video", "keypoints2d", "lifter_output", "out", "weights"):
        if isinstance(raw.get(key), str):
            raw[key] = str((path.parent / raw[key]).resolve()) if not Path(raw[key]).is_absolute() else raw[key]
    raw.update({k: v for k, v in overrides.items() if v is not None})
    try:
        return RunConfig(**raw).validate()
    except (TypeError, ValueError) as err:
        raise ValueError(f"{path}: {err}") from err
