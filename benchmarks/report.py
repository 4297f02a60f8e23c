"""What the text benchmarks do with their report: print it and write it under results/."""

from __future__ import annotations

from pathlib import Path


def print_and_save(lines: list[str], out: Path) -> None:
    """Print ``lines`` and write them (newline-terminated) to ``out``, creating its folder."""
    text = "\n".join(lines) + "\n"
    print(text)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
