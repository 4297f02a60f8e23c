"""The mocap sets the calibration benchmarks share: the shipped weights' training mix
(Bandai + the CMU training set) split by motion and style (models/MODEL_CARD.md)."""

from __future__ import annotations

from pathlib import Path

from pcnet.models.datasets import Clip, load_mocap, select_split

#: The files of the shipped weights' training mix, under ``DATA/mocap``.
TRAINING_MIX = ("bandai_h36m17.npz", "cmu_train_h36m17.npz")


def training_mix_splits(data: Path, *parts: str) -> list[list[Clip]]:
    """For each of ``parts`` (``"train"``, ``"val"``, ``"test"``), the training mix's clips
    in that motion-style split, Bandai's first; each file is read once."""
    loaded = [load_mocap(data / "mocap" / name) for name in TRAINING_MIX]
    return [[c for clips in loaded for c in select_split(clips, part, "motion-style")] for part in parts]
