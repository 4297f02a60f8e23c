#!/usr/bin/env bash
# Re-run every `pcnet evaluate` behind the README's result tables; JSON into
# benchmarks/results/. Then `python benchmarks/readme_tables.py` prints the tables.
# Needs ../shared/data (the mocap); about 15 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=benchmarks/results
MOCAP=${MOCAP:-../shared/data/mocap}
declare -A DATA=([bandai_test]="$MOCAP/bandai_h36m17.npz --split test" [deepmimic_all]="$MOCAP/deepmimic_h36m17.npz --split all")
for key in bandai_test deepmimic_all; do
  for views in paper wide; do
    for method in geometric pcnet pcnet-rigid; do
      # clean inputs, one random camera per frame (the paper's protocol)
      pcnet evaluate --method $method --data ${DATA[$key]} --views $views --json $OUT/${method}_${key}_${views}.json
    done
    # 3DPCNet without pcnet's frame up refiner (hip-line heading as the default)
    pcnet evaluate --method pcnet --no-up-refiner --data ${DATA[$key]} --views $views \
      --json $OUT/pcnet_${key}_${views}_norefiner.json
    # the paper's model alone: the network's own heading, no up refiner
    pcnet evaluate --method pcnet --heading predicted --no-up-refiner --data ${DATA[$key]} --views $views \
      --json $OUT/pcnet_${key}_${views}_predicted_heading.json
    for mode in frame sequence-norefiner sequence; do
      args="--mode ${mode%-norefiner}"
      [[ $mode == *-norefiner ]] && args="$args --no-up-refiner"
      # one fixed camera per clip, upstream-like noise (issue 5's protocol)
      pcnet evaluate --method pcnet --data ${DATA[$key]} --views $views --camera per-clip --noise $args \
        --json $OUT/pcnet_${key}_${views}_perclip_noise_${mode}.json
      # one fixed camera per clip, clean inputs (mocap-like: the hip-line heading applies)
      pcnet evaluate --method pcnet --data ${DATA[$key]} --views $views --camera per-clip $args \
        --json $OUT/pcnet_${key}_${views}_perclip_clean_${mode}.json
    done
  done
  for mode in frame sequence-norefiner sequence; do
    args="--mode ${mode%-norefiner}"
    [[ $mode == *-norefiner ]] && args="$args --no-up-refiner"
    # one camera fixed in the world: the subject's own turns show (a real recording)
    pcnet evaluate --method pcnet --data ${DATA[$key]} --views paper --camera static --noise $args \
      --json $OUT/pcnet_${key}_paper_static_noise_${mode}.json
  done
  for method in geometric pcnet pcnet-rigid; do
    # upstream-like noise, one random camera per frame
    pcnet evaluate --method $method --data ${DATA[$key]} --views paper --noise --json $OUT/${method}_${key}_paper_noise.json
  done
  pcnet evaluate --method pcnet --no-up-refiner --data ${DATA[$key]} --views paper --noise \
    --json $OUT/pcnet_${key}_paper_noise_norefiner.json
done
