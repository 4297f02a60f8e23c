"""The resume marker of ``pcnet batch``: ``OUT/.pcnet_batch.json``, written into a row's
staged output before it is swapped in (so the output never appears without it), says which
inputs (sha256), settings and pcnet version (with a digest of its code) produced that output.

A re-run skips a row whose output folder is complete (pcnet's own output marker says
``complete``) and whose batch marker matches the row's input bytes, settings and the
installed pcnet version and code. Input files are compared by content, not by path, so a study folder
moved or mounted elsewhere (a manifest with relative paths) is still complete. The marker is
listed in the output folder's ``.pcnet-output`` file list, so a later ``--overwrite`` (or a
re-run after an input changed) may replace the folder.

Only the standard library is imported here: batch workers import this module before they
set their thread counts, which must happen before numpy is imported.
"""

from __future__ import annotations

import json
import os
import socket
import time
from pathlib import Path

from pcnet.stages.core.atomic import write_text
from pcnet.stages.core.digest import sha256_path

from .batch_worker import FINDINGS, RESULT_FIELDS, RUN_FIELDS
from .config import UNKNOWN_CODE, pcnet_version
from .outdir import listed_files_missing, read_marker

BATCH_MARKER = ".pcnet_batch.json"
#: RunConfig fields that name input files (hashed into the marker).
INPUT_FIELDS = ("lifter_output", "keypoints2d", "video", "weights")
#: RunConfig fields that do not change what a row writes (``out`` is where the marker lives;
#: the input files count by their bytes, not their paths).
_NOT_SETTINGS = ("out", "overwrite", "camera_up_from", *INPUT_FIELDS)


def input_files(config: dict) -> dict[str, str]:
    """``{field: path}`` of the input files a row's config names (fields left empty omitted),
    ``camera_up_from``'s the trial run's ``canonical.npz`` (a clinic's re-filmed standing trial
    left its exercises' rows skipped on the old up)."""
    files = {name: str(config[name]) for name in INPUT_FIELDS if config.get(name)}
    if config.get("camera_up_from"):
        files["camera_up_from"] = str(Path(config["camera_up_from"]) / "canonical.npz")
    return files


def settings_of(config: dict) -> dict:
    """The part of a row's config (``dataclasses.asdict(RunConfig)``) that decides its
    outputs, as JSON-comparable values."""
    return json.loads(json.dumps({k: v for k, v in config.items() if k not in _NOT_SETTINGS}, sort_keys=True))


def input_hashes(config: dict) -> dict[str, dict]:
    """``{field: {"path", "sha256"}}`` for every input file of a row (each file read once per
    version in the worker: the run's report reads the same digests)."""
    return {name: {"path": path, "sha256": sha256_path(path)} for name, path in input_files(config).items()}


def write_batch_marker(folder: Path, config: dict, inputs: dict[str, dict], result: dict, manifest: str = "") -> Path:
    """Write ``folder/.pcnet_batch.json`` (atomically), ``folder`` being the row's staged
    output (``run_pipeline``'s ``before_publish``): its ``.pcnet-output`` marker then lists it
    when the folder is completed, so that ``--overwrite`` sees a folder holding only pcnet's
    files.

    ``inputs`` are the hashes taken before the row ran (what the run read), ``result`` the
    row's frames, valid frames, mode, warnings and their findings (shown again when a re-run
    skips the row), ``manifest`` where the manifest whose row it is lies, seen from the output
    folder (:func:`pcnet.pipeline.batch.manifest_from`; a re-run of another manifest's row over it
    needs ``--overwrite``).
    """
    record = {
        "writer": "pcnet batch", "pcnet_version": pcnet_version(), "settings": settings_of(config),
        "inputs": inputs, "result": {k: result.get(k) for k in (*RESULT_FIELDS, *RUN_FIELDS, FINDINGS)},
        "host": socket.gethostname(), "pid": os.getpid(), "time": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "manifest": manifest,
    }
    return write_text(folder / BATCH_MARKER, json.dumps(record, indent=1) + "\n")


def read_batch_marker(out: Path) -> dict:
    """The batch marker of ``out``, ``{}`` when missing, unreadable or not pcnet batch's."""
    try:
        data = json.loads((out / BATCH_MARKER).read_text())
    except (OSError, ValueError, RecursionError):  # RecursionError: nested too deeply
        return {}
    return data if isinstance(data, dict) and data.get("writer") == "pcnet batch" else {}


def completed_record(out: Path, config: dict) -> dict | None:
    """The batch marker of ``out`` when it holds a complete, current output of this row
    (:func:`record_status`), else ``None``."""
    return record_status(out, config)[0]


_SINCE = "since its earlier output"


def settings_change(record: dict, config: dict) -> str:
    """``""`` when a batch record's settings are those of the row's ``config`` (no input read),
    else one phrase naming the settings that changed, at most three."""
    old, new = record.get("settings"), settings_of(config)
    if not isinstance(old, dict):
        return "its earlier output's settings are unreadable"
    differ = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
    if not differ:
        return ""
    more = f" and {len(differ) - 3} more" if len(differ) > 3 else ""
    return f"setting{'s' * (len(differ) > 1)} {', '.join(differ[:3])}{more} changed {_SINCE}"


def version_change(recorded: str) -> str:
    """One phrase saying how the pcnet that wrote an earlier output (``recorded``, its
    :func:`~pcnet.pipeline.config.pcnet_version`) differs from the installed one: its code alone
    where the release version is the same."""
    now = pcnet_version()
    if now.endswith(f"+code.{UNKNOWN_CODE}"):
        return f"pcnet's code cannot be read to compare with its earlier output's (pcnet {now})"
    if recorded.split("+")[0] == now.split("+")[0]:
        return f"pcnet's code changed {_SINCE} (pcnet {recorded} -> {now})"
    return f"pcnet {recorded} -> {now} {_SINCE}"


def renamed_inputs(record: dict, config: dict) -> list[str]:
    """The input fields whose file a row names by another resolved path than its batch record
    read (no input is read; a field added or dropped counts)."""
    recorded = record.get("inputs") if isinstance(record.get("inputs"), dict) else {}
    files = input_files(config)
    return sorted(name for name in set(recorded) | set(files)
                  if not isinstance(recorded.get(name), dict) or name not in files
                  or Path(str(recorded[name].get("path", ""))).resolve() != Path(files[name]).resolve())


def record_status(out: Path, config: dict) -> tuple[dict | None, str]:
    """``(marker, "")`` when ``out`` holds a complete output of exactly this row (every file
    pcnet wrote there still present; same settings, same pcnet version, the same input files by
    sha256, wherever they are now), else ``(None, why)``: one phrase naming what differs (the
    files missing, the pcnet version, the settings that changed, at most three named, or the
    input files). Inputs are hashed only when everything cheaper already matches, once each."""
    if read_marker(out).get("state") != "complete":
        return None, "its earlier output is incomplete"
    missing = listed_files_missing(out)
    if missing:
        return None, f"its earlier output lacks {', '.join(missing[:3])}"
    record = read_batch_marker(out)
    if not record:
        return None, "its earlier output has no batch record"
    if record.get("pcnet_version") != pcnet_version() or pcnet_version().endswith(f"+code.{UNKNOWN_CODE}"):
        return None, version_change(str(record.get("pcnet_version", "unknown")))
    changed_settings = settings_change(record, config)
    if changed_settings:  # the inputs named anew too, by path (their bytes are not read: it runs anyway)
        moved = renamed_inputs(record, config)
        return None, changed_settings + (f"; it names another {', '.join(moved)}" if moved else "")
    recorded, files = record.get("inputs"), input_files(config)
    if not isinstance(recorded, dict) or not all(isinstance(v, dict) for v in recorded.values()):
        return None, "its earlier output's inputs are unreadable"
    changed = sorted(set(recorded) ^ set(files))
    for name in sorted(set(recorded) & set(files)):
        try:
            if sha256_path(files[name], cached=False) != recorded[name].get("sha256"):
                changed.append(name)
        except OSError:
            changed.append(name)
    if changed:
        return None, f"input{'s' * (len(changed) > 1)} {', '.join(changed)} changed {_SINCE}"
    return record, ""
