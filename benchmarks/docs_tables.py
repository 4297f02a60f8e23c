"""Write the benchmark pages' generated tables (docs/benchmarks/*.md, docs/world_validation.md) from the results files.

    python -m benchmarks.docs_tables            # rewrite every generated table in place
    python -m benchmarks.docs_tables --check    # exit 1 if a page's table differs from its file

A generated table sits in a page between two markers; everything outside them is left alone::

    <!-- generated: heldout -->
    ...
    <!-- /generated -->

The marker names the generator: ``heldout`` (benchmarks/results/heldout/*.json, what
``bash benchmarks/evaluate_all.sh`` wrote; the same table ``python -m benchmarks.readme_tables``
prints), ``view_gate`` (results/view_gate.txt), ``speed`` (results/speed_release5.txt,
speed_quarter_turns.txt, speed.txt), ``pipeline_throughput`` (results/pipeline_throughput.txt),
``scripts`` (the index table of benchmarks/README.md, for docs/benchmarks/scripts.md),
``md FILE N``: the N-th markdown table (1-based) of results/FILE as the command printed it,
or ``text FILE``: all of results/FILE, as printed, in a fenced block (fixed-width tables).
Nothing here runs a benchmark: the numbers are the results files' own.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from benchmarks.readme_tables import heldout_table

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
PAGES = ROOT / "docs" / "benchmarks"
#: Pages outside docs/benchmarks/ that hold generated tables too.
OTHER_PAGES = (ROOT / "docs" / "world_validation.md",)
MARK = re.compile(r"(<!-- generated: (?P<spec>[^>]*?) -->\n)(?P<body>.*?)(<!-- /generated -->)", re.S)


def markdown_table(name: str | Path, n: int) -> str:
    """The ``n``-th markdown table (consecutive lines starting with ``|``) of a results file
    (``name`` under results/, or a path)."""
    tables, current = [], []
    for line in (RESULTS / name).read_text().splitlines():
        if line.startswith("|"):
            current.append(line.rstrip())
        elif current:
            tables.append(current)
            current = []
    if current:
        tables.append(current)
    if not 1 <= n <= len(tables):
        raise SystemExit(f"{name}: no markdown table {n} (it has {len(tables)})")
    return "\n".join(tables[n - 1])


def view_gate() -> str:
    """Per-frame tilt error by camera roll, clean, from ``view_gate.py``'s text output."""
    sets = {"DeepMimic all": "DeepMimic, clean (three clips trained on by the camera-frame network)",
            "Bandai test": "Bandai motion-style test, clean", "CMU test": "CMU test subjects, clean"}
    names = {"camera-frame": "camera-frame alone", "body-frame": "body-frame alone", "gated": "pcnet (the pair)"}
    text = (RESULTS / "view_gate.txt").read_text().splitlines()
    header = next(line for line in text if line.startswith("data ") and "estimator" in line)
    rolls = header.split()[2:]
    out = ["| data | estimator | " + " | ".join(f"roll {r}" if i == 0 else r for i, r in enumerate(rolls)) + " |",
           "|---|---|" + "---|" * len(rolls)]
    for key, label in sets.items():
        first = True
        for line in text:
            m = re.match(rf"{re.escape(key)}\s+(camera-frame|body-frame|gated)\s+([-\d.\s]+)$", line)
            if m:
                values = m.group(2).split()
                out.append(f"| {label if first else ''} | {names[m.group(1)]} | " + " | ".join(values) + " |")
                first = False
    return "\n".join(out)


def _speed_rows(name: str) -> dict[tuple[str, str], str]:
    rows = {}
    for line in (RESULTS / name).read_text().splitlines():
        m = re.match(r"(.+?)\s{2,}(\S+|\d+ nets)\s+(\d+)\s+([\d,]+)$", line)
        if m and m.group(3) in ("1", "1024"):
            rows[(m.group(1).strip(), m.group(3))] = m.group(4)
        if line.startswith("ratios"):
            break
    return rows


def speed() -> str:
    """poses/s of the shipped networks (release 5), release 4's and release 3's, batch 1 and 1024."""
    files = ("speed_release5.txt", "speed_quarter_turns.txt", "speed.txt")
    runs = [_speed_rows(f) for f in files]
    labels = (("geometric (numpy)", "geometric (numpy)"),
              ("3DPCNet shipped torch eager", "3DPCNet shipped (hidden 128) torch eager"),
              ("3DPCNet shipped onnxruntime", "3DPCNet shipped (hidden 128) onnxruntime"),
              ("3DPCNet paper torch eager", "3DPCNet paper width (hidden 256) torch eager"),
              ("3DPCNet paper onnxruntime", "3DPCNet paper width (hidden 256) onnxruntime"),
              ("pcnet shipped pair (gated)", "pcnet shipped pair (two networks + gate), onnxruntime"),
              ("3DPCNet shipped training step", "3DPCNet shipped (hidden 128), one training step"),
              ("3DPCNet paper training step", "3DPCNet paper width (hidden 256), one training step"))
    out = ["| method | batch 1 | batch 1024 | release 4, batch 1 | release 4, batch 1024 | release 3, batch 1 "
           "| release 3, batch 1024 |", "|---|---|---|---|---|---|---|"]
    for key, label in labels:
        cells = [run.get((key, b), "-") for run in runs for b in ("1", "1024")]
        out.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def pipeline_throughput() -> str:
    """Wall time, rate, memory and disk per recording length, from the lines the command printed."""
    out = ["| recording | frames | wall time | frames/s | peak RSS | outputs | arrays on disk while running |",
           "|---|---|---|---|---|---|---|"]
    pattern = re.compile(r"(\d+) min = (\d+) frames, .*?: ([\d.]+) s, (\d+) frames/s, peak RSS (\d+) MB, "
                         r"outputs (\d+) MB, arrays on disk while running (\d+) MB")
    for line in (RESULTS / "pipeline_throughput.txt").read_text().splitlines():
        m = pattern.match(line)
        if m:
            minutes, frames, wall, rate, rss, outputs, disk = m.groups()
            out.append(f"| {minutes} min | {int(frames):,} | {float(wall):.0f} s | {int(rate):,} | {rss} MB "
                       f"| {int(outputs):,} MB | {disk} MB |")
    return "\n".join(out)


def scripts() -> str:
    """The index of the benchmark scripts: the first table of benchmarks/README.md."""
    return markdown_table(ROOT / "benchmarks" / "README.md", 1)


def text_block(name: str) -> str:
    """All of results/``name`` in a fenced block, as its command printed it."""
    return "```text\n" + (RESULTS / name).read_text().rstrip("\n") + "\n```"


def generate(spec: str) -> str:
    parts = spec.split()
    if parts[0] == "md" and len(parts) == 3:
        return markdown_table(parts[1], int(parts[2]))
    if parts[0] == "text" and len(parts) == 2:
        return text_block(parts[1])
    generators = {"heldout": heldout_table, "view_gate": view_gate, "speed": speed,
                  "pipeline_throughput": pipeline_throughput, "scripts": scripts}
    if len(parts) != 1 or parts[0] not in generators:
        raise SystemExit(f"unknown generated table {spec!r}")
    return generators[parts[0]]()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true", help="only check that every page is up to date")
    args = parser.parse_args()
    stale = []
    for page in [*sorted(PAGES.glob("*.md")), *OTHER_PAGES]:
        text = page.read_text()
        new = MARK.sub(lambda m: m.group(1) + generate(m.group("spec")) + "\n" + m.group(4), text)
        if new != text:
            stale.append(page.relative_to(ROOT))
            if not args.check:
                page.write_text(new)
    for page in stale:
        print(f"{'stale' if args.check else 'wrote'}: {page}")
    return 1 if (args.check and stale) else 0


if __name__ == "__main__":
    raise SystemExit(main())
