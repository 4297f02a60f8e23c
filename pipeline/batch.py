"""``pcnet batch``: many recordings from a CSV manifest, in parallel processes."""

from __future__ import annotations

import csv
import io
from concurrent.futures import ProcessPoolExecutor
from dataclasses import fields
from pathlib import Path

from pcnet.stages.errors import InputError

from .config import RunConfig, parse_hypothesis

_NUMERIC = {"height": float, "fps": float, "person": int, "confidence_threshold": float, "cutoff_hz": float}
_LIFTER_OPTIONS = ("pixel", "hypothesis", "layout", "axes", "units", "key")
_BOOLEAN = {"1": True, "true": True, "yes": True, "0": False, "false": False, "no": False}


def _boolean(key: str, raw: str) -> bool:
    try:
        return _BOOLEAN[raw.lower()]
    except KeyError:
        raise InputError(f"column {key}: expected true/false (1/0, yes/no), got {raw!r}") from None


def row_to_config(row: dict, base: Path, overwrite: bool) -> RunConfig:
    """A :class:`RunConfig` from one manifest row (empty cells = defaults; relative paths are
    relative to the manifest's folder). Raises ValueError naming the bad column."""
    # lifter_options is a table in TOML; in a manifest its entries are columns of their own.
    known = ({f.name for f in fields(RunConfig)} - {"lifter_options"}) | set(_LIFTER_OPTIONS)
    unknown = {k for k in row if k not in known}
    if unknown:
        raise InputError(f"unknown columns {sorted(unknown)[:5]}; expected columns named like the fields of `pcnet run`"
                         f" (lifter, lifter_output, keypoints2d, keypoints2d_format, video, out, ...)")
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
                raise InputError(f"column {key}: expected a number, got {raw!r}") from None
        elif key == "pixel":
            options["pixel"] = _boolean(key, raw)
        elif key == "hypothesis":
            options[key] = parse_hypothesis(raw)
        elif key in _LIFTER_OPTIONS:
            options[key] = raw
        elif key in ("overwrite", "recording", "fps_override"):
            values[key] = _boolean(key, raw)
        else:
            values[key] = raw
    values.setdefault("overwrite", overwrite)
    return RunConfig.from_values("manifest row", {**values, "lifter_options": options})


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


def read_manifest(manifest: Path) -> list[dict]:
    """The rows of a CSV manifest (a header line, then one recording per line).

    Raises:
        InputError: the file is empty, not UTF-8 text, not CSV, has no header or no rows,
            or a row has more cells than the header (naming the manifest and the line).
    """
    try:
        text = manifest.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise InputError(f"{manifest}: expected a UTF-8 CSV manifest, got binary data (byte {err.start})") from None
    if "\x00" in text:
        raise InputError(f"{manifest}: expected a UTF-8 CSV manifest, got binary data (NUL bytes)")
    if not text.strip():
        raise InputError(f"{manifest}: expected a CSV manifest with a header and rows, got an empty file")
    try:
        reader = csv.DictReader(io.StringIO(text, newline=""))  # quoted cells may hold newlines
        rows = list(reader)
    except csv.Error as err:
        raise InputError(f"{manifest}: expected CSV, got {err}") from None
    for line, row in enumerate(rows, start=2):
        if None in row:
            raise InputError(f"{manifest}: line {line}: expected at most {len(reader.fieldnames)} cells "
                             f"(the header's), got {len(reader.fieldnames) + len(row[None])}")
    if not rows:
        raise InputError(f"{manifest}: expected at least one row below the header {reader.fieldnames}, got none")
    return rows


def _refuse_shared_outputs(manifest: Path, rows: list[dict]) -> None:
    """Two rows writing one output folder would silently replace each other: refused before
    any row runs (rows without ``out`` share the default ``pcnet_out`` too)."""
    seen: dict[Path, int] = {}
    for line, row in enumerate(rows, start=2):
        out = (row.get("out") or "").strip() or "pcnet_out"
        target = (manifest.parent / out).resolve()
        if target in seen:
            raise InputError(f"{manifest}: line {line}: column out: expected a folder of its own, got {out!r}, "
                             f"which line {seen[target]} also writes")
        seen[target] = line


def run_batch(manifest: str | Path, workers: int = 2, overwrite: bool = False) -> list[dict]:
    """Run every row of ``manifest`` (CSV with a header) in ``workers`` processes; returns
    one result dict per row, in manifest order.

    Raises:
        InputError: before any row runs, for an unreadable manifest, two rows sharing an
            output folder, or a row whose settings are invalid (naming the line). A row whose
            inputs fail while it runs is reported in its result instead.
    """
    manifest = Path(manifest)
    rows = read_manifest(manifest)
    _refuse_shared_outputs(manifest, rows)
    for line, row in enumerate(rows, start=2):  # every row's settings checked before any row runs
        try:
            row_to_config(row, manifest.parent, overwrite)
        except InputError as err:
            raise InputError(f"{manifest}: line {line}: {err}") from None
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
