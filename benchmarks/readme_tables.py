"""Print the README's held-out result table (markdown) from the JSON that
``bash benchmarks/evaluate_all.sh`` wrote to benchmarks/results/heldout/.

    python -m benchmarks.readme_tables

``python -m benchmarks.docs_tables`` writes this table, and the other generated tables, into
the benchmark pages of the docs site (docs/benchmarks/).
"""

from __future__ import annotations

import json
from pathlib import Path

RESULTS = Path(__file__).parent / "results"
ALL_METRICS = ("rotation_deg", "tilt_deg", "heading_deg", "mpjpe_mm", "pa_mpjpe_mm")


def cell(result: dict, metric: str) -> str:
    s = result[metric]
    return f"{s['mean']:.2f} / {s['median']:.2f} / {s['p95']:.2f}"


HELDOUT_ROWS = (  # (file stem without the model, data/split label, protocol label)
    ("bandai_test_motion-style_frame", "Bandai test, motion-style", "frame, clean"),
    ("bandai_test_motion-style_lifter_frame", "Bandai test, motion-style", "frame, lifter"),
    ("bandai_test_motion-style_perclip_lifter_sequence", "Bandai test, motion-style", "per-clip, lifter, sequence"),
    ("bandai_test_motion-style_perclip_lifter_sequence_noprior", "Bandai test, motion-style",
     "per-clip, lifter, sequence, no camera prior"),
    ("bandai_test_clip_frame", "Bandai test, clip (old split)", "frame, clean"),
    ("bandai_unseen_frame", "Bandai, groups unseen by the clip split", "frame, clean"),
    ("cmu_test_frame", "CMU test subjects 10, 14", "frame, clean"),
    ("cmu_test_perclip_lifter_sequence", "CMU test subjects 10, 14", "per-clip, lifter, sequence"),
    ("deepmimic_all_frame", "DeepMimic all", "frame, clean"),
    ("deepmimic_all_lifter_frame", "DeepMimic all", "frame, lifter"),
    ("deepmimic_all_perclip_lifter_sequence", "DeepMimic all", "per-clip, lifter, sequence"),
    ("deepmimic_all_perclip_lifter_sequence_noprior", "DeepMimic all", "per-clip, lifter, sequence, no camera prior"),
    ("deepmimic_untrained_frame", "DeepMimic, clips not trained on", "frame, clean"),
    ("deepmimic_untrained_perclip_lifter_sequence", "DeepMimic, clips not trained on", "per-clip, lifter, sequence"),
)
HELDOUT_METHODS = ("geometric", "pcnet-camnet", "pcnet-bodynet", "pcnet")


def heldout_table() -> str:
    """The held-out table: each row with its clips, groups, scored and invalid frames (left out
    of the metrics) and, for Bandai, the clips the shipped weights trained on. Rows of one
    data/protocol must have scored the same frames (``frame_set``): checked."""
    folder = RESULTS / "heldout"
    lines = ["| data, split | protocol | method | clips / groups | frames (invalid) | trained on | rotation | tilt "
             "| heading | MPJPE | PA-MPJPE |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for stem, data, protocol in HELDOUT_ROWS:
        sets = set()
        for method in HELDOUT_METHODS:
            path = folder / f"{method}_{stem}.json"
            if not path.is_file():
                continue
            r = json.loads(path.read_text())
            sets.add(r["frame_set"])
            o = r.get("training_overlap", r.get("shipped_training_overlap"))
            trained = f"{o['clips_trained_on']} clips, {o['groups_with_a_trained_take']} groups" if o else "none"
            lines.append(f"| {data} | {protocol} | {method} | {r['clips']} / {r['groups']} | {r['frames']} "
                         f"({r['invalid_frames']}) | {trained} | " + " | ".join(cell(r, m) for m in ALL_METRICS) + " |")
        if len(sets) > 1:
            raise SystemExit(f"{stem}: methods scored different frames {sorted(sets)}")
    return "\n".join(lines)


def heldout() -> None:
    """Print the held-out table (``heldout_table``)."""
    print(heldout_table())


if __name__ == "__main__":
    import argparse

    argparse.ArgumentParser(description="Print the README's held-out result table from benchmarks/results/heldout/ "
                                        "(written by bash benchmarks/evaluate_all.sh).").parse_args()
    heldout()
