"""Print the README's result tables (markdown) from the JSON that
``benchmarks/evaluate_all.sh`` wrote to benchmarks/results/."""

from __future__ import annotations

import json
from pathlib import Path

RESULTS = Path(__file__).parent / "results"
DATASETS = (("bandai_test", "Bandai test"), ("deepmimic_all", "DeepMimic all"))
ALL_METRICS = ("rotation_deg", "tilt_deg", "heading_deg", "mpjpe_mm", "pa_mpjpe_mm")


def cell(result: dict, metric: str) -> str:
    s = result[metric]
    return f"{s['mean']:.2f} / {s['median']:.2f} / {s['p95']:.2f}"


def row(label: str, name: str, result: dict, metrics=ALL_METRICS) -> str:
    return f"| {label} | {name} | " + " | ".join(cell(result, m) for m in metrics) + " |"


def load(name: str) -> dict:
    return json.loads((RESULTS / f"{name}.json").read_text())


def main() -> None:
    print("| data, views | method | rotation | tilt | heading | MPJPE | PA-MPJPE |\n|---|---|---|---|---|---|---|")
    for key, label in DATASETS:
        for views in ("paper", "wide"):
            for method in ("geometric", "pcnet", "pcnet-rigid"):
                print(row(f"{label}, {views}", method, load(f"{method}_{key}_{views}")))
            print(row(f"{label}, {views}", "pcnet, no up refiner", load(f"pcnet_{key}_{views}_norefiner")))
            print(row(f"{label}, {views}", "3DPCNet alone (heading predicted, no up refiner)",
                      load(f"pcnet_{key}_{views}_predicted_heading")))
    print("\n| data, views | method | rotation | tilt | heading | MPJPE | PA-MPJPE |\n|---|---|---|---|---|---|---|")
    for key, label in DATASETS:
        for method in ("geometric", "pcnet", "pcnet-rigid"):
            print(row(f"{label}, paper, noise", method, load(f"{method}_{key}_paper_noise")))
        print(row(f"{label}, paper, noise", "pcnet, no up refiner", load(f"pcnet_{key}_paper_noise_norefiner")))
    modes = (("frame", "frame"), ("sequence-norefiner", "sequence, no up refiner"), ("sequence", "sequence"))
    header = "\n| data, views | mode | rotation | tilt | heading | MPJPE |\n|---|---|---|---|---|---|"
    for inputs in ("noise", "clean"):  # per-clip cameras: with noise, then clean inputs
        print(header)
        for key, label in DATASETS:
            for views in ("paper", "wide"):
                for mode, name in modes:
                    result = load(f"pcnet_{key}_{views}_perclip_{inputs}_{mode}")
                    print(row(f"{label}, {views}", name, result, ALL_METRICS[:4]))
    print(header)  # a camera fixed in the world, noise
    for key, label in DATASETS:
        for mode, name in modes:
            print(row(f"{label}, paper", name, load(f"pcnet_{key}_paper_static_noise_{mode}"), ALL_METRICS[:4]))


if __name__ == "__main__":
    main()
