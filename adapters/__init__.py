"""pcnet.adapters: translate foreign pose files into pcnet's conventions.

Each adapter reads one upstream format and returns arrays + layout + frame + units, with
NaN for anything missing (``docs/CONVENTIONS.md``). No pose maths happens here beyond axis
flips/permutations, unit scaling and picking a person or hypothesis; remapping to H36M-17
(``pcnet.stages.remap.remap_to_h36m``) and root-centring are the caller's steps.

Built in (:func:`available_2d`, :func:`available_3d` list what is registered):
2D (``Keypoints2D``): ``alphapose``, ``mmpose``, ``openpose``, ``mediapipe``.
3D (``Poses3D``, camera frame): ``motionbert``, ``ddhpose``, ``videopose3d``, ``mediapipe``,
``generic``, and the depth-sensor skeletons ``kinect_v1`` (20 joints) and ``azure_kinect`` (32).

Use either the functions (``load_alphapose(path, person=...)``) or the registry
(``get_2d_adapter("alphapose").load(path, person=...)``); see ``registry`` for adding one,
in a package of its own too (the ``pcnet.adapters`` entry point group).
"""

from .types import POSE_UNITS, AdapterError, Keypoints2D, Poses3D, VideoInfo
from .registry import (
    available_2d,
    available_3d,
    get_2d_adapter,
    get_3d_adapter,
    Registered,
    register_2d,
    register_3d,
    registered,
)

# Importing the adapter modules registers them, in this order: the order in which `pcnet run
# --help` offers the 2D formats and the lifters (a new adapter: its module and one line here).
from .alphapose import load_alphapose
from .mmpose import load_mmpose
from .openpose import load_openpose
from .motionbert import load_motionbert
from .ddhpose import load_ddhpose
from .videopose3d import load_videopose3d
from .mediapipe import load_mediapipe_2d, load_mediapipe_3d
from .generic import axes_to_camera, load_generic
from .kinect import load_azure_kinect, load_kinect_v1
from .video import first_shown_frame, iter_frames, probe_video, read_frame
from .registry import load_plugins

# After the built-ins: a plugin cannot take a built-in's name (the registry refuses it).
load_plugins()

__all__ = [
    "POSE_UNITS", "AdapterError", "Keypoints2D", "Poses3D", "VideoInfo",
    "available_2d", "available_3d", "get_2d_adapter", "get_3d_adapter", "register_2d", "register_3d",
    "Registered", "registered",
    "load_alphapose", "load_mmpose", "load_openpose", "load_mediapipe_2d", "load_mediapipe_3d",
    "load_motionbert", "load_ddhpose", "load_videopose3d", "load_generic", "axes_to_camera",
    "load_kinect_v1", "load_azure_kinect",
    "probe_video", "read_frame", "iter_frames", "first_shown_frame",
]
