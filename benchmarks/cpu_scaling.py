"""How much faster this machine runs two CPU-bound processes than one: the ceiling for any
process pool's speed-up, `pcnet batch` included (benchmarks/batch_throughput.py).

    python -m benchmarks.cpu_scaling [--repeat 7]

Three single-threaded workloads (thread counts pinned to 1), each timed alone and as two
copies started together; ratio = 2 x (one alone) / (two together), 2.0 on two independent
cores. Alternating the two, ``--repeat`` times, median and range printed: a shared VM's
speed varies from second to second. Writes benchmarks/results/cpu_scaling.txt.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

RESULT = Path(__file__).resolve().parent / "results" / "cpu_scaling.txt"
WORKLOADS = {
    "Python loop (interpreter only)": "s = 0\nfor i in range(15_000_000): s += i * i",
    "numpy on (17, 3) poses (cache-resident, like the stages)": (
        "import numpy as np\na = np.random.rand(17, 3)\nfor _ in range(250_000): b = a @ a.T"),
    "numpy on 160 MB arrays (memory-bound)": (
        "import numpy as np\na = np.random.rand(20_000_000)\nfor _ in range(12): b = np.sqrt(a) * a + 1"),
}
ENV = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")


def _wall(code: str, copies: int) -> float:
    t = time.perf_counter()
    procs = [subprocess.Popen([sys.executable, "-c", code], env=ENV) for _ in range(copies)]
    if any(p.wait() for p in procs):
        raise SystemExit(f"a workload failed: {code!r}")
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    lines = [f"python -m benchmarks.cpu_scaling --repeat {args.repeat}",
             f"{os.cpu_count()} CPUs ({platform.machine()}), Python {platform.python_version()}",
             "| workload | one alone, s (median) | two together, s (median) | throughput ratio median [min, max] |",
             "|---|---|---|---|"]
    for name, code in WORKLOADS.items():
        one, two = [], []
        for _ in range(args.repeat):
            one.append(_wall(code, 1))
            two.append(_wall(code, 2))
        ratios = 2 * np.array(one) / np.array(two)
        lines.append(f"| {name} | {np.median(one):.2f} | {np.median(two):.2f} | "
                     f"{np.median(ratios):.2f}x [{ratios.min():.2f}, {ratios.max():.2f}] |")
        print(lines[-1], flush=True)
    RESULT.write_text("\n".join(lines) + "\n")
    print(f"wrote {RESULT}")


if __name__ == "__main__":
    main()
