"""``pcnet batch``: many recordings from a CSV manifest, in parallel processes."""

from __future__ import annotations

import csv
from concurrent.futures import ProcessPoolExecutor
from dataclasses import fields
from pathlib import Path

from .config import RunConfig

_NUMERIC = {"height": float, "fps": float, "person": int, "confidence_threshold": float, "cutoff_hz": float}
_LIFTER_OPTIONS = ("pixel", "hypothesis", "layout", "axes", "units", "key")


def row_to_config(row: dict, base: Path, overwrite: bool) -> RunConfig:
    """A :class:`RunConfig` from one manifest row (empty cells = defaults; relative paths are
    relative to the manifest's folder). Raises ValueError naming the bad column."""
    known = {f.name for f in fields(RunConfig)} | set(_LIFTER_OPTIONS)
    unknown = {k for k in row if k and k not in known}
    if unknown:
        raise ValueError(f"unknown columns {sorted(unknown)}")
    values, options = {}, {}
    for key, raw in row.items():
        if raw is None or str(raw).strip() == "":
            continue
        raw = str(raw).strip()
        if key in ("video", "keypoints2d", "lifter_output", "out", "weights"):
            values[key] = str(base / raw) if not Path(raw).is_absolute() else raw
        elif key in _NUMERIC:
            try:
                values[key] = _NUMERIC[key](raw)
            except ValueError:
                raise ValueError(f"column {key}: expected a number, got {raw!r}") from None
        elif key == "pixel":
            options["pixel"] = raw.lower() in ("1", "true", "yes")
        elif key == "hypothesis":
            options[key] = int(raw) if raw.lstrip("-").isdigit() else raw
        elif key in _LIFTER_OPTIONS:
            options[key] = raw
        elif key in ("overwrite", "recording"):
            values[key] = raw.lower() in ("1", "true", "yes")
        else:
            values[key] = raw
    values.setdefault("overwrite", overwrite)
    return RunConfig(**values, lifter_options=options).validate()


def _run_row(args: tuple[int, dict, str, bool]) -> dict:
    index, row, base, overwrite = args
    from pcnet.pipeline.runner import run_pipeline

    try:
        cfg = row_to_config(row, Path(base), overwrite)
        result = run_pipeline(cfg, progress=False)
        return {"row": index, "status": "ok", "frames": result.frames, "valid": result.valid_frames,
                "mode": result.mode, "out": cfg.out, "error": ""}
    except Exception as err:  # one recording's failure must not stop the others
        return {"row": index, "status": "failed", "frames": 0, "valid": 0, "mode": "",
                "out": row.get("out", ""), "error": f"{type(err).__name__}: {err}"}


def run_batch(manifest: str | Path, workers: int = 2, overwrite: bool = False) -> list[dict]:
    """Run every row of ``manifest`` (CSV with a header) in ``workers`` processes; returns
    one result dict per row, in manifest order."""
    manifest = Path(manifest)
    with open(manifest, newline="") as fh:
        rows = list(csv.DictReader(fh))
    if not rows:
        raise ValueError(f"{manifest}: the manifest has no rows")
    jobs = [(i + 1, row, str(manifest.parent), overwrite) for i, row in enumerate(rows)]
    if workers <= 1:
        return [_run_row(j) for j in jobs]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(_run_row, jobs))


def format_summary(results: list[dict]) -> str:
    """A plain-text table: row, status, frames, valid, mode, output or error."""
    lines = [f"{'row':>4}  {'status':<7}{'frames':>7}{'valid':>7}  {'mode':<9}output / error"]
    for r in results:
        lines.append(f"{r['row']:>4}  {r['status']:<7}{r['frames']:>7}{r['valid']:>7}  {r['mode']:<9}"
                     f"{r['out'] if r['status'] == 'ok' else r['error']}")
    ok = sum(r["status"] == "ok" for r in results)
    lines.append(f"{ok} of {len(results)} recordings processed")
    return "\n".join(lines)
