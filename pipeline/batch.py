"""``pcnet batch``: many recordings from a CSV manifest, one row each, on a local pool of
worker processes (``--engine local``) or on Ray (``--engine ray``, one task per row).

The manifest is validated whole before any work; each row then runs the ``pcnet run``
pipeline into its own output folder (written beside it and renamed in, so a failed or
stopped row leaves no half-written folder); a row that succeeded gets a resume marker
(:mod:`pcnet.pipeline.batch_marker`) so that a re-run skips it while its inputs, settings
and the pcnet version (with its code digest) are unchanged. The JSON summary (default ``MANIFEST.pcnet_batch.json``)
records every row: its fields are in docs/cluster.md, "Results". The terminal gets one short
line per row and per finding, then a short summary (:func:`format_summary`); the long form
(every row, its error in full, its warnings, restarts) goes to the Markdown report beside the
JSON summary (:func:`report_path`, :func:`batch_markdown`).
"""

from __future__ import annotations

import contextlib
import copy
import csv
import errno
import gc
import io
import json
import operator
import os
import re
import socket
import stat
import time
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from functools import lru_cache
from pathlib import Path

from pcnet.stages.core.atomic import write_text
from pcnet.stages.core.errors import InputError, close_names, refuse

from .batch_marker import (BATCH_MARKER, INPUT_FIELDS, completed_record, input_files, read_batch_marker,
                           record_status, renamed_inputs, settings_change)
from .batch_worker import FINDINGS, PER_COLUMN_FIELDS, RESULT_FIELDS, RUN_FIELDS, cpu_cores, error_line
from .config import (COMMAND_LINE_OPTIONS, PATH_FIELDS, fps_contradiction, parse_hypothesis, pcnet_version,
                     reads_folder, RunConfig)
from .interrupt import EXIT_INTERRUPTED
from .io import close_file
from .outdir import check_out_folder, clean_stale, foreign_entries, is_within, read_marker

ENGINES = ("local", "ray")
STATUSES = ("ok", "skipped", "failed", "cancelled")
#: Previous statuses that --retry-failed does not run again.
DONE = ("ok", "skipped")
SUMMARY_SUFFIX = ".pcnet_batch.json"
#: How the batch report (:func:`batch_markdown`) begins: how a report pcnet may replace is known.
REPORT_TITLE = "# pcnet batch"
#: Lines the terminal summary gives each of the failed rows and the warnings at most; the
#: rest are counted and left to the report.
SUMMARY_LINES = 10
ROW_SOURCE = "manifest row"
#: Seconds between rewrites of the JSON summary while a batch runs.
SUMMARY_EVERY_S = 2.0
#: Up to this many rows the summary is rewritten at every result (a rewrite costs little).
SUMMARY_EVERY_RESULT_ROWS = 200
_NUMERIC = {"height": float, "fps": float, "person": int, "confidence_threshold": float, "cutoff_hz": float,
            "focal_px": float, "mass": float}
_LIFTER_OPTIONS = COMMAND_LINE_OPTIONS  # the lifter options a row gives as columns of their own
_BOOLEAN = {"1": True, "true": True, "yes": True, "0": False, "false": False, "no": False}
_BOOLEAN_COLUMNS = ("overwrite", "recording", "plots", "fps_override", "c3d", "camera_prior", "residual_cutoff", "opensim")
#: Columns naming files or folders (the config's path fields): relative to the manifest's folder.
_PATH_COLUMNS = PATH_FIELDS


def _boolean(key: str, raw: str) -> bool:
    try:
        return _BOOLEAN[raw.lower()]
    except KeyError:
        raise InputError(f"column {key}: expected true/false (1/0, yes/no), got {raw!r}") from None


def _number(key: str, raw: str) -> float | int:
    try:
        return _NUMERIC[key](raw)
    except ValueError:
        raise InputError(f"column {key}: expected a number, got {raw!r}") from None


def row_to_config(row: dict, base: Path, overwrite: bool) -> RunConfig:
    """A :class:`RunConfig` from one manifest row (empty cells = defaults; relative paths are
    relative to ``base``, the manifest's folder; no ``out`` = ``base/pcnet_out``).

    Raises:
        InputError: an unknown column, or the values the columns do not take (naming each: the
            cells no column reads, then the first value the config refuses; a user trial fixed
            one row three times, one cell a run).
    """
    # lifter_options is a table in TOML; in a manifest its entries are columns of their own.
    unknown = sorted(set(row).difference(_column_set()))
    if unknown:
        raise InputError(f"unknown columns {unknown}; expected some of {', '.join(manifest_columns())}")
    values, options, problems, unread = {}, {}, [], set()
    for key, raw in row.items():
        if raw is None or str(raw).strip() == "":
            continue
        raw = str(raw).strip()
        try:
            if key in _PATH_COLUMNS:
                values[key] = _manifest_path(base, raw)
            elif key in _NUMERIC:
                (options if key in _LIFTER_OPTIONS else values)[key] = _number(key, raw)
            elif key in ("pixel", "measured_root"):
                options[key] = _boolean(key, raw)
            elif key == "hypothesis":
                options[key] = parse_hypothesis(raw)
            elif key in _LIFTER_OPTIONS:
                options[key] = raw
            elif key in _BOOLEAN_COLUMNS:
                values[key] = _boolean(key, raw)
            else:
                values[key] = raw
        except InputError as err:
            problems.append(str(err))
            unread.add(key)
    values.setdefault("overwrite", overwrite)
    values.setdefault("out", str(base / "pcnet_out"))  # beside the manifest, like every relative path
    try:
        config = RunConfig.from_values(ROW_SOURCE, {**values, "lifter_options": options})
    except InputError as err:  # less what follows from a cell already refused (a missing rate after fps 'abc')
        problems += [p for p in err.problems if not any(f"'{k}'" in p for k in unread)]
    refuse(problems)
    return config


class _RowConfigs:
    """Each row's config (``dataclasses.asdict`` of :func:`row_to_config`), validated once per
    distinct setting: rows that differ only in their paths (each recording's files, its
    ``out``) share one validation, since :meth:`RunConfig.validate` looks at a path only to
    see whether it is given. A row whose cells are refused is parsed again each time (its
    message may name its own paths)."""

    def __init__(self, base: Path, overwrite: bool):
        self.base, self.overwrite = base, overwrite
        self._valid: dict[tuple, dict] = {}  # the row's cells, paths as given or not -> a config of them
        self._columns: dict[tuple, tuple] = {}  # a row's column names -> its path columns, getters

    def config(self, row: dict) -> dict:
        """The row's config.

        Raises:
            InputError: as :func:`row_to_config`.
        """
        names = tuple(row)
        columns = self._columns.get(names)
        if columns is None:
            path_names = tuple(n for n in names if n in _PATH_COLUMNS)
            columns = self._columns[names] = (path_names, _cells_of(path_names),
                                              _cells_of(tuple(n for n in names if n not in _PATH_COLUMNS)))
        path_names, path_cells, other_cells = columns
        given = [_given(cell) for cell in path_cells(row)]
        key = (names, other_cells(row), tuple(cell is not None for cell in given))
        template = self._valid.get(key)
        if template is None:
            template = self._valid[key] = _config_dict(row_to_config(row, self.base, self.overwrite))
        config = dict(template)  # the row's own: planning marks rows to run again with overwrite
        options = template["lifter_options"]
        config["lifter_options"] = copy.deepcopy(options) if options else {}
        for name, cell in zip(path_names, given):
            if cell is not None:
                config[name] = _manifest_path(self.base, cell)
        return config


def _cells_of(names: tuple[str, ...]) -> Callable[[dict], tuple]:
    """A function giving a row's cells of the columns ``names``, as a tuple."""
    if len(names) > 1:
        return operator.itemgetter(*names)
    return lambda row: tuple(row[name] for name in names)


def _given(cell) -> str | None:
    """A cell's text without surrounding blanks, None for an empty one (the default)."""
    if cell is None:
        return None
    return str(cell).strip() or None


#: Paths are plain strings split at "/" (POSIX), where the string shortcuts below apply.
_POSIX = os.sep == "/" and os.altsep is None


@lru_cache(maxsize=4096)
def _manifest_path(base: Path, raw: str) -> str:
    """A path cell as the config holds it: ``str(base / raw)`` for a relative one, ``raw``
    for an absolute one. A manifest names its few input files on many rows (each is joined
    once) and its outputs as one folder's entries (that folder is joined once, then each
    name appended)."""
    if _POSIX and not raw.startswith("/"):
        head, _, name = raw.rpartition("/")
        if head and name not in ("", ".", ".."):
            folder = _manifest_path(base, head)
            return folder + name if folder.endswith("/") else f"{folder}/{name}"
    return str(base / raw) if not Path(raw).is_absolute() else raw


@lru_cache(maxsize=1)
def _column_set() -> frozenset[str]:
    return frozenset(manifest_columns())


@lru_cache(maxsize=1)
def manifest_columns() -> tuple[str, ...]:
    """Every column a manifest may have: the fields of ``pcnet run``'s configuration and the
    lifter options that have a flag of their own."""
    return tuple(sorted(({f.name for f in fields(RunConfig)} - {"lifter_options"}) | set(_LIFTER_OPTIONS)))


def _header_problem(manifest: Path, header: list[str]) -> str | None:
    """What is wrong with the header line, as one line (the header is line 1), or None."""
    where = f"{manifest}: line 1"
    first = header[0].strip() if header else ""
    if first.startswith("["):
        return f"{where}: expected a CSV header of column names, got {first!r} (a TOML file? a manifest is CSV)"
    if first.startswith("#"):
        return f"{where}: expected a CSV header of column names, got the comment {first!r} (comments are not allowed)"
    names = [h.strip() for h in header]
    if "" in names:  # a spreadsheet's export of empty columns beside the table
        return (f"{where}: expected a name for every column, got {names.count('')} unnamed "
                f"column{'s' * (names.count('') > 1)} (column {names.index('') + 1}; empty columns a spreadsheet "
                f"exported? delete them)")
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        return f"{where}: expected each column once, got {', '.join(twice)} more than once"
    unknown = [n for n in names if n not in manifest_columns()]
    if unknown:
        # a line split by another separator is one "name": the separator is the hint, not a near name
        hint = close_names([n for n in unknown if n != "lifter_options" and ";" not in n and "\t" not in n],
                           manifest_columns())
        if "lifter_options" in unknown:
            hint += f" (lifter_options: a manifest gives each as a column of its own, {', '.join(_LIFTER_OPTIONS)})"
        if any(";" in n for n in unknown):
            hint += " (columns separated by ';'? a manifest separates them by commas)"
        if any("\t" in n for n in unknown):
            hint += " (columns separated by tabs? a manifest separates them by commas)"
        return (f"{where}: unknown columns {unknown}{hint}; expected columns named like the fields of `pcnet run`: "
                f"{', '.join(manifest_columns())}")
    return None


def read_manifest(manifest: Path) -> tuple[list[tuple[int, dict]], dict[int, str]]:
    """The rows of a CSV manifest (a header line, then one recording per line) with the
    line each starts on (blank lines are skipped; a quoted cell may span lines), and a
    problem line per row with more or fewer cells than the header (by line; those rows are
    not among the rows), so that the other rows are still checked.

    Raises:
        InputError: the file is empty, not UTF-8 text, not CSV, has no header or no rows, or
            a header with a column given twice or not a column of :func:`manifest_columns`.
    """
    if manifest.exists() and not manifest.is_file() and not manifest.is_dir():  # reading a pipe waits forever
        raise InputError(f"{manifest}: expected a CSV manifest file, got a special file (a named pipe or device)")
    raw = manifest.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        if b"\x00" in raw:
            raise InputError(f"{manifest}: expected a UTF-8 CSV manifest, got binary data (byte {err.start})") from None
        raise InputError(f"{manifest}: expected a UTF-8 CSV manifest, got a byte that is not UTF-8 at offset "
                         f"{err.start} (a spreadsheet's Latin-1 or Windows export? save it as 'CSV UTF-8')") from None
    if "\x00" in text:
        raise InputError(f"{manifest}: expected a UTF-8 CSV manifest, got binary data (NUL bytes)")
    if not text.strip():
        what = "an empty file" if not text else "only blank lines"
        raise InputError(f"{manifest}: expected a CSV manifest with a header and rows, got {what}")
    reader = csv.reader(io.StringIO(text, newline=""))  # quoted cells may hold newlines
    header, rows, start, miscounted = None, [], 1, {}
    try:
        for cells in reader:
            line, start = start, reader.line_num + 1
            if not any(c.strip() for c in cells):
                continue
            if header is None:
                header = cells
                problem = _header_problem(manifest, header)
                if problem:
                    raise InputError(problem)
                names = [name.strip() for name in header]
                continue
            if len(cells) != len(header):
                miscounted[line] = f"{manifest}: line {line}: expected {len(header)} cells (the header's), got {len(cells)}"
                continue
            rows.append((line, dict(zip(names, cells))))
    except csv.Error as err:
        raise InputError(f"{manifest}: line {reader.line_num}: expected CSV, got {err}") from None
    if not rows and not miscounted:
        raise InputError(f"{manifest}: expected at least one row below the header {header}, got none")
    return rows, miscounted


class ManifestError(InputError):
    """Everything wrong with a manifest, found before any row ran: ``lines`` holds one line
    per problem (manifest, line, column, expected, found), printed one per line."""

    def __init__(self, lines: list[str]):
        super().__init__("; ".join(lines))
        self.lines = list(lines)


@dataclass
class BatchOptions:
    """``pcnet batch``'s options (see :func:`run_batch`)."""

    engine: str = "local"
    workers: int | None = None
    retries: int = 0
    address: str | None = None
    overwrite: bool = False
    retry_failed: bool = False
    summary_json: str | os.PathLike | None = None


@dataclass
class PlannedRow:
    """One manifest row after validation: its config, and ``run`` or ``skip`` with the result
    a skipped row reports (from its output's marker or the previous summary)."""

    row: int
    line: int
    config: dict
    cells: dict = field(default_factory=dict)
    action: str = "run"
    known: dict = field(default_factory=dict)
    #: Why a row runs again over its own earlier output (no --overwrite), for its messages.
    rerun: str = ""
    #: The manifest that wrote the earlier output this row would run again over, where another.
    written_by: str = ""
    #: What `pcnet gait` and `pcnet opensim` made from that earlier output, gone with it.
    made_from_it: tuple[str, ...] = ()

    @property
    def out(self) -> Path:
        return Path(self.config["out"])


@dataclass
class BatchReport:
    """What a batch did: ``rows`` (per-row summary dicts, manifest order), whether it was
    interrupted, where the JSON summary went, wall time and the engine's start-up time, the
    summary's header (``settings``: manifest, engine, workers, ...), the restarts of rows whose
    worker died, where the Markdown report went, and ``findings``: by row number, the rows'
    warnings as :func:`pcnet.pipeline.batch_worker.finding_records` (a row without them, one
    skipped by ``--retry-failed``, gets :func:`row_findings`' reading of its texts)."""

    rows: list[dict]
    interrupted: bool
    summary_path: Path
    seconds: float
    engine_start_seconds: float = 0.0
    settings: dict = field(default_factory=dict)
    restarts: list[str] = field(default_factory=list)
    report_path: Path | None = None
    findings: dict[int, list[dict]] = field(default_factory=dict)

    def counts(self) -> dict[str, int]:
        return {status: sum(r["status"] == status for r in self.rows) for status in STATUSES}

    @property
    def exit_code(self) -> int:
        """130 when interrupted, 1 when a row failed, else 0."""
        if self.interrupted:
            return EXIT_INTERRUPTED
        return 1 if self.counts()["failed"] else 0


def default_summary_path(manifest: str | os.PathLike) -> Path:
    """``<manifest>.pcnet_batch.json`` beside the manifest."""
    manifest = Path(manifest)
    return manifest.with_name(manifest.name + SUMMARY_SUFFIX)


def report_path(summary: str | os.PathLike) -> Path:
    """The Markdown report beside the JSON summary: its name with ``.md`` for its suffix
    (``runs.csv.pcnet_batch.json`` -> ``runs.csv.pcnet_batch.md``; ``NAME.md`` itself ->
    ``NAME.md.md``)."""
    summary = Path(summary)
    report = summary.with_suffix(".md")
    return report if report != summary else summary.with_name(summary.name + ".md")


class _PathFacts:
    """What checking a manifest asks the file system, asked once per path: a manifest names
    its few input files and their folders on many rows, and its outputs side by side in one
    folder. Resolved paths (each folder resolved once; a path below it then costs one
    ``lstat`` of its last name, a full :meth:`Path.resolve` only where that name is a
    symbolic link), whether an input is a file or a folder, the folders above an output.
    The file system is taken as unchanged while the check runs; nothing is kept after it."""

    def __init__(self):
        self._resolved: dict[str, Path] = {}
        self._folder: dict[str, Path] = {}
        self._kind: dict[str, str] = {}
        self._ancestors: dict[str, tuple[Path, ...]] = {}
        self._exists: dict[str, bool] = {}  # what resolving a path found: whether it exists

    def resolve(self, path: str | os.PathLike) -> Path:
        """``Path(path).resolve()``."""
        key = os.fspath(path)
        found = self._resolved.get(key)
        if found is None:
            found = self._resolved[key] = self._resolve(key)
        return found

    def _resolve(self, key: str) -> Path:
        if _POSIX and _normal_absolute(key):  # the parent and name as Path would split them
            cut = key.rindex("/")
            parent_key, name = key[:cut] or "/", key[cut + 1:]
        else:
            path = Path(key)
            if not path.is_absolute() or path.name in ("", ".."):
                return path.resolve()
            parent_key, name = str(path.parent), path.name
        try:
            parent = self.resolve(parent_key)
        except RuntimeError:  # a symlink loop: as Path.resolve says it
            return Path(key).resolve()
        candidate = parent / name
        try:
            mode = os.lstat(candidate).st_mode
        except OSError as err:  # as realpath: a name that cannot be read is taken as it is
            if err.errno in (errno.ENOENT, errno.ENOTDIR):
                self._exists[key] = False
            return candidate
        except ValueError:
            return Path(key).resolve()
        # realpath resolves name by name, so below a resolved folder only a link changes the path
        if stat.S_ISLNK(mode):
            return Path(key).resolve()
        self._exists[key] = True
        return candidate

    def exists(self, path: str) -> bool:
        """``Path(path).exists()`` (known without another ``stat`` once ``path`` was resolved)."""
        found = self._exists.get(path)
        return _exists(path) if found is None else found

    def folder(self, path: str) -> Path:
        """``Path(path).resolve().parent``."""
        found = self._folder.get(path)
        if found is None:
            found = self._folder[path] = self.resolve(path).parent
        return found

    def ancestors(self, resolved: Path) -> tuple[Path, ...]:
        """``tuple(resolved.parents)`` (nearest first), shared by the paths in one folder."""
        key = os.path.dirname(str(resolved))
        found = self._ancestors.get(key)
        if found is None:
            parent = resolved.parent
            found = self._ancestors[key] = (parent, *parent.parents) if parent != resolved else ()
        return found

    def kind(self, path: str) -> str:
        """``file``, ``folder`` or ``missing`` (``Path.is_file()``, ``Path.is_dir()``)."""
        found = self._kind.get(path)
        if found is None:
            found = self._kind[path] = ("file" if Path(path).is_file() else
                                        "folder" if Path(path).is_dir() else "missing")
        return found


def _normal_absolute(path: str) -> bool:
    """Whether ``path`` is absolute and written as ``str(Path(path))`` writes it (no empty or
    ``.`` name, no ``..`` at its end), so that its parent and name are the text around its
    last "/"."""
    return (path.startswith("/") and not path.startswith("//") and "//" not in path and "/./" not in path
            and not path.endswith(("/", "/.", "/..")))


def _exists(path: str) -> bool:
    """``Path(path).exists()`` without building the Path (a stat; the same errors ignored)."""
    try:
        os.stat(path)
    except OSError as err:
        if err.errno in (errno.ENOENT, errno.ENOTDIR, errno.EBADF, errno.ELOOP):
            return False
        raise
    except ValueError:
        return False
    return True


def _config_dict(cfg: RunConfig) -> dict:
    """``dataclasses.asdict(cfg)`` at a fraction of its cost (its fields are plain values but
    ``lifter_options``, copied): a manifest builds one per row."""
    values = {f.name: getattr(cfg, f.name) for f in fields(cfg)}
    values["lifter_options"] = copy.deepcopy(values["lifter_options"])
    return values


def _input_problems(where: str, row: dict, inputs: dict[str, str], paths: _PathFacts) -> list[str]:
    """Input files a row names (``inputs``, :func:`input_files`) that do not exist (or are
    folders, but for a 2D format read from a folder), one line each."""
    problems = []
    for column, path in inputs.items():
        kind = paths.kind(path)
        # an OpenPose --write_json folder, which a user trial's row could not name
        if kind == "folder" and column == "keypoints2d" and reads_folder(
                (_given(row.get("keypoints2d_format")) or "").lower()):
            continue
        if kind != "file":
            found = "a folder" if kind == "folder" else "no such file"
            near = "" if kind == "folder" else close_file(Path(path))
            problems.append(f"{where}: column {column}: expected an existing file, got "
                            f"{(row.get(column) or '').strip()!r} ({found}: {path}){near}")
    return problems


def _out_problem(where: str, row: dict, out: str, inputs: dict[str, str], paths: _PathFacts) -> str | None:
    """``out`` that is an input's folder or contains one (an ``--overwrite`` could then
    replace the inputs' folder), or None. ``out`` inside an input's folder is fine: the
    common layout of outputs beside their recordings."""
    out = paths.resolve(out)
    for column, path in inputs.items():
        folder = paths.folder(path)
        if is_within(folder, out):
            given = (row.get("out") or "").strip() or "pcnet_out"
            relation = "is" if folder == out else "contains"
            return (f"{where}: column out: expected a folder apart from the inputs, got {given!r}, which {relation} "
                    f"the folder of {column} {path}")
    return None


def _shared_out_problems(manifest: Path, planned: list[PlannedRow], paths: _PathFacts) -> dict[int, str]:
    """``{line: problem}`` of rows writing an output folder an earlier row writes, or one
    inside or around it: they would silently replace each other (rows without ``out`` share
    ``pcnet_out`` beside the manifest), or one row's output would hold the other's, which no
    later ``--overwrite`` could replace."""
    outs: dict[Path, int] = {}  # each output folder -> the first line writing it
    holders: dict[Path, int] = {}  # each folder holding an output folder -> a line writing inside it
    problems = {}
    for item in planned:
        target = paths.resolve(item.config["out"])
        parents = paths.ancestors(target)
        inside = next((p for p in parents if p in outs), None)
        if target in outs:
            relation = f"which line {outs[target]} also writes"
        elif inside is not None:
            relation = f"inside line {outs[inside]}'s output folder"
        elif target in holders:
            relation = f"which holds line {holders[target]}'s output folder"
        else:
            outs[target] = item.line
            for parent in parents:  # nearest first; a folder in holders has its parents there too
                if parent in holders:
                    break
                holders[parent] = item.line
            continue
        given = (item.cells.get("out") or "").strip() or "pcnet_out"
        problems[item.line] = (f"{manifest}: line {item.line}: column out: expected a folder of its own, got "
                               f"{given!r}, {relation}")
    return problems


#: Words after a flag that continue the sentence: not the flag's value.
_SENTENCE_WORDS = ("to", "or", "and", "anyway", "with", "if", "for", "then")
_FLAG = r"--([a-z][a-z0-9-]*)(?: (?!(?:" + "|".join(_SENTENCE_WORDS) + r")\b)([a-z0-9.]+))?"


def in_manifest_terms(message: str) -> str:
    """A row's error as a manifest user reads it: the ``pcnet run`` flags that the pipeline
    names (``--fps``, ``pass --fps-override``, ``--no-camera-prior``) as the row's columns
    (``column fps``, ``set column fps_override to true``, ``column camera_prior false``), flags
    side by side as a list (``column lifter generic, column units``); the batch's own
    ``--overwrite`` stays a flag."""
    def flag(match: re.Match) -> str:
        asked, name, value = match.group(1), match.group(2).replace("-", "_"), match.group(3)
        rest = f" {value}" if value else ""
        if name.startswith("no_") and name[3:] in _BOOLEAN_COLUMNS:  # --no-camera-prior: a column set false
            return f"set column {name[3:]} to false{rest}" if asked else f"column {name[3:]} false{rest}"
        if name not in manifest_columns() or name == "overwrite":
            return match.group(0)
        if asked and name in _BOOLEAN_COLUMNS:
            return f"set column {name} to true{rest}"
        if asked:
            return f"set column {name}" + (f" to {value}" if value else "")
        return f"{'out' if name == 'out' else 'column ' + name}{rest}"
    # "pcnet run --lifter generic" is the row's columns: no command (a bad-input trial read
    # "read it with pcnet run column lifter generic, column units mm")
    message = message.replace("pcnet run --", "--")
    listed = re.sub(f"({_FLAG}) (?=--)", r"\1, ", message)  # flags side by side: a list
    return re.sub(f"(pass )?{_FLAG}", flag, listed)


def _as_columns(message: str) -> str:
    """RunConfig names its source "manifest row" and its fields quoted; here the row is the
    line already, and the fields are the manifest's columns (a lifter option, which a config
    names by its ``lifter_options.`` key, is a column of its own)."""
    return re.sub(re.escape(ROW_SOURCE) + r": (fields?) ((?:'[\w.]+'(?: and )?)+)",
                  lambda m: ("columns " if m.group(1) == "fields" else "column ")
                  + m.group(2).replace("'", "").replace("lifter_options.", ""),
                  message)


def _written_by(rows: list[tuple[int, dict]], base: Path) -> dict[str, int]:
    """``{resolved out folder: manifest line}`` of the rows' outputs (a row without ``out``
    writes ``pcnet_out`` beside the manifest)."""
    return {str(Path(_manifest_path(base, _given(row.get("out")) or RunConfig.out)).resolve()): line
            for line, row in rows}


def _parse_rows(manifest: Path, rows: list[tuple[int, dict]], overwrite: bool,
                paths: _PathFacts) -> tuple[list[PlannedRow], list[PlannedRow], dict[int, str]]:
    """Every row's config (absolute paths), the rows whose settings were refused (their config
    only their ``out``, which other rows must still not share), and ``{line: problem}`` for the
    rows whose settings, input files or ``out`` (against the inputs) are wrong."""
    configs = _RowConfigs(manifest.resolve().parent, overwrite)
    planned, refused, problems = [], [], {}
    writes = _written_by(rows, configs.base) if any(_given(r.get("camera_up_from")) for _, r in rows) else {}
    for index, (line, row) in enumerate(rows, start=1):
        where = f"{manifest}: line {line}"
        try:
            config = configs.config(row)
        except InputError as err:
            # a missing input named first: it may be why the settings look wrong (no rate recorded)
            given = {name: _manifest_path(configs.base, cell) for name in INPUT_FIELDS
                     if (cell := _given(row.get(name))) is not None}
            trial = _given(row.get("camera_up_from"))
            writer = writes.get(str(Path(_manifest_path(configs.base, trial)).resolve())) if trial else None
            # a clinic's manifest put the standing trial and its exercises in one batch
            first = [f"{where}: column camera_up_from: line {writer} of this manifest writes {trial!r}: run that row "
                     f"in a batch of its own first, then this one"] if writer is not None else []
            problems[line] = "\n".join([*_input_problems(where, row, given, paths), *first,
                                        *(f"{where}: {_as_columns(p)}" for p in err.problems
                                          if not (first and "camera_up_from" in p))])
            out = _manifest_path(configs.base, _given(row.get("out")) or RunConfig.out)
            refused.append(PlannedRow(index, line, {"out": out}, row))
            continue
        inputs = input_files(config)
        found = (_input_problems(where, row, inputs, paths) or
                 [p for p in [_out_problem(where, row, config["out"], inputs, paths)] if p])
        if not found:
            found += _video_rate_problem(where, config)
        if found:
            problems[line] = "\n".join(found)
        planned.append(PlannedRow(index, line, config, row))
    return planned, refused, problems


def _video_rate_problem(where: str, config: dict) -> list[str]:
    """A row's ``fps`` that contradicts its video's own rate (without ``fps_override``), found
    before any row runs as ``pcnet run`` would find it when the row starts (a user trial: a
    row 2 hours into a batch). The container's rate is read, not its frames."""
    video, fps = config.get("video"), config.get("fps")
    if not video or fps is None or config.get("fps_override"):
        return []
    from pcnet.adapters import AdapterError, probe_video

    try:
        recorded = probe_video(video, verify=False).fps
    except AdapterError:
        return []  # the row's own run says what is wrong with the video
    problem = fps_contradiction(fps, video, recorded)
    return [f"{where}: {in_manifest_terms(problem)}"] if problem else []


def read_previous_summary(path: Path) -> dict[str, dict]:
    """``{resolved out: row}`` of a previous run's JSON summary.

    Raises:
        InputError: the summary is missing or not a pcnet batch summary.
    """
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"--retry-failed: expected the previous run's summary {path}, got no such file; run without "
                         f"--retry-failed first (or name the summary with --summary-json)") from None
    except (OSError, ValueError, RecursionError) as err:
        why = "JSON nested too deeply" if isinstance(err, RecursionError) else err
        raise InputError(f"--retry-failed: expected the previous run's summary {path}, got {why}") from None
    if not isinstance(data, dict) or data.get("writer") != "pcnet batch" or not isinstance(data.get("rows"), list):
        raise InputError(f"--retry-failed: expected a pcnet batch summary in {path}, got another file")
    return {str(Path(r["out"]).resolve()): r for r in data["rows"] if isinstance(r, dict) and r.get("out")}


def _decide(item: PlannedRow, options: BatchOptions, previous: dict[str, dict] | None, paths: _PathFacts,
            manifest: Path) -> None:
    """Set ``item.action``: skip a row whose output is complete and current (or, with
    ``--retry-failed``, that succeeded last time with the row's settings: its inputs are not
    read); re-run a row over its own previous
    batch output (``overwrite``, which still refuses files pcnet did not write), noting in
    ``item.written_by`` another manifest's output, which only ``--overwrite`` replaces."""
    if previous is not None:
        before = previous.get(str(paths.resolve(item.config["out"])))
        if before is not None and before.get("status") in DONE and item.out.is_dir():
            record = read_batch_marker(item.out)
            changed = settings_change(record, item.config) if record else ""  # cheap: no input is read
            if record and not changed and renamed_inputs(record, item.config):
                # another file named (a trial swapped two rows' recordings and got the old numbers):
                # its bytes decide, as a plain run's check does; a moved study folder still matches
                changed = record_status(item.out, item.config)[1]
            if changed:  # not the manifest's row any more (a user trial: it was called complete)
                item.config["overwrite"] = True
                item.rerun = changed
                item.written_by = _other_manifest(record, item.out, manifest)
                item.made_from_it = _made_from_the_output(item.out, item.config)
                return
            item.action = "skip"
            # with how it ran (a trial: a no-op re-run lost every row's timing)
            item.known = {k: before.get(k) for k in (*RESULT_FIELDS, *RUN_FIELDS)}
            # the warnings as raised (kinds, actions) are in the output's marker, not the summary's texts
            result = record.get("result")
            findings = result.get(FINDINGS) if isinstance(result, dict) else None
            if findings is not None:
                item.known[FINDINGS] = findings
            return
    if item.config["overwrite"]:  # --overwrite, or the row's own overwrite column (a trial: it did nothing)
        return
    if not paths.exists(item.config["out"]):
        return
    record, why = record_status(item.out, item.config)
    if record is not None:
        item.action = "skip"
        item.known = dict(record.get("result") or {})
    elif earlier := read_batch_marker(item.out):
        item.config["overwrite"] = True  # our own earlier output of changed inputs or settings
        item.rerun = why
        item.written_by = _other_manifest(earlier, item.out, manifest)
        item.made_from_it = _made_from_the_output(item.out, item.config)


def _made_from_the_output(out: Path, config: dict) -> tuple[str, ...]:
    """The files of ``out`` that `pcnet gait` and `pcnet opensim` made from a row's earlier
    output, which replacing it removes (a study trial lost its gait table's sources with no
    word), less those the row's own run writes again (its ``opensim``)."""
    from pcnet.stages.opensim_ik import OUTPUTS as OPENSIM_OUTPUTS

    from .gait import OUTPUTS as GAIT_OUTPUTS

    names = GAIT_OUTPUTS + (() if config.get("opensim") else OPENSIM_OUTPUTS)
    return tuple(name for name in names if (out / name).is_file())


def manifest_from(out: str | os.PathLike, manifest: str | os.PathLike) -> str:
    """Where ``manifest`` lies as seen from the output folder ``out`` (a relative path): what an
    output's batch record keeps of the manifest whose row made it, so that a study folder moved
    or copied whole, manifest and outputs together, keeps it."""
    return os.path.relpath(Path(manifest).resolve(), Path(out).resolve())


def _other_manifest(record: dict, out: Path, manifest: Path) -> str:
    """The manifest that wrote a batch record of ``out``, where it is another than ``manifest``
    (:func:`manifest_from`; ``""`` for this one, or a record from before manifests were
    recorded), as a path."""
    wrote = record.get("manifest")
    if not isinstance(wrote, str) or not wrote or wrote == manifest_from(out, manifest):
        return ""
    return os.path.normpath(Path(out).resolve() / wrote)


def _out_folder_problem(manifest: Path, item: PlannedRow, paths: _PathFacts) -> str | None:
    """What :func:`~pcnet.pipeline.outdir.check_out_folder` (the rule ``pcnet run`` applies)
    refuses about a row that will run, as a manifest line, or None; and another manifest's
    earlier output, which a changed row runs again over only with ``--overwrite`` (a user trial's
    second manifest replaced the first's result unasked)."""
    if item.written_by:
        return (f"{manifest}: line {item.line}: column out: expected this manifest's own earlier output to run "
                f"this row again ({item.rerun}), got the output of another manifest's row ({item.written_by}); "
                f"pass --overwrite to replace it, or choose another out")
    try:
        check_out_folder(item.config["out"], input_files(item.config).values(), item.config["overwrite"],
                         resolve=paths.resolve, exists=paths.exists)
    except (InputError, OSError) as err:
        text = " ".join(str(err).split()).removeprefix(f"--out {item.config['out']}: ")
        text = text.replace("choose another --out", "choose another out")
        foreign = foreign_entries(item.out) if item.rerun and item.out.is_dir() else []
        if foreign:
            shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
            text = (f"expected to run this row again ({item.rerun}), got its folder also holding files pcnet did not "
                    f"write or that changed since ({shown}); move them away to run it again, or choose another out")
        if isinstance(err, FileExistsError):
            given = (item.cells.get("out") or "").strip() or "pcnet_out"
            text = (f"expected a new folder, got {given!r}, an existing folder without a pcnet batch marker "
                    f"({item.config['out']}); pass --overwrite to replace a previous pcnet output")
        return f"{manifest}: line {item.line}: column out: {text}"
    return None


def _check_summary_path(path: Path, manifest: Path, planned: list[PlannedRow], paths: _PathFacts) -> None:
    """The summary and the report beside it (:func:`report_path`) may replace only an
    earlier pcnet batch summary and report, in a writable folder, and may not be the manifest
    or an input.

    Raises:
        InputError: naming ``--summary-json``, the path (and the report's name) and the rule.
    """
    resolved = path.resolve()
    inputs = {paths.resolve(p) for item in planned for p in input_files(item.config).values()}
    outs = {paths.resolve(item.config["out"]): item.line for item in planned}
    files = ((resolved, ""), (report_path(resolved), f" (its report beside it, {report_path(path).name})"))
    for file, what in files:
        if file == manifest.resolve() or file in inputs:
            raise InputError(f"--summary-json {path}{what}: expected a file of its own, got the manifest or an input")
        holder = next((p for p in [file, *file.parents] if p in outs), None)
        if holder is not None:
            raise InputError(f"--summary-json {path}{what}: expected a place outside the rows' output folders, got "
                             f"one in line {outs[holder]}'s ({holder}), which a row's output replaces")
    if not resolved.parent.is_dir() or not os.access(resolved.parent, os.W_OK):
        state = "not writable" if resolved.parent.is_dir() else "which does not exist"
        raise InputError(f"--summary-json {path}: expected a writable folder for the batch summary, got "
                         f"{resolved.parent}, {state}; name another place with --summary-json")
    for file, what in files:
        if file.exists() and not _written_by_batch(file):
            raise InputError(f"--summary-json {path}{what}: expected a new file or an earlier pcnet batch "
                             f"{'report' if what else 'summary'}, got a file pcnet did not write; name another place "
                             f"with --summary-json")


def _written_by_batch(file: Path) -> bool:
    """Whether ``file`` is an earlier pcnet batch summary (JSON) or report (Markdown)."""
    try:
        text = file.read_text()
        return (text.startswith(REPORT_TITLE) if file.suffix == ".md"
                else json.loads(text).get("writer") == "pcnet batch")
    except (OSError, ValueError, AttributeError, RecursionError):  # ValueError: not UTF-8 or not JSON
        return False


def plan_batch(manifest: str | os.PathLike, options: BatchOptions) -> tuple[list[PlannedRow], Path]:
    """Validate the whole manifest and decide, per row, run or skip; returns the rows and
    the summary path. Nothing is written.

    Raises:
        InputError: a Ray cluster address that accepts no connection
            (:func:`pcnet.pipeline.batch_ray.check_reachable`), an unreadable manifest
            (:func:`read_manifest`), a missing or foreign
            ``--retry-failed`` summary, an unusable ``--summary-json`` path.
        ManifestError: one line per problem of any row: unknown columns or bad values, an
            input file that does not exist, an ``out`` that is (or contains) an input's
            folder, two rows sharing an ``out``, an ``out`` that ``pcnet run`` would refuse
            (an existing folder without ``--overwrite``, a folder holding files pcnet did
            not write, the current folder).
    """
    manifest = Path(manifest)
    if options.engine == "ray" and options.address:
        from .batch_ray import check_reachable

        check_reachable(options.address)
    with _collector_paused():
        return _plan(manifest, options)


@contextlib.contextmanager
def _collector_paused():
    """Python's cyclic garbage collector paused: checking a manifest makes objects by the
    million and no cycles, and each full collection on the way walks every one of them
    (a quarter of the check's time at 100,000 rows)."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def _plan(manifest: Path, options: BatchOptions) -> tuple[list[PlannedRow], Path]:
    """:func:`plan_batch` past the cluster's address."""
    rows, miscounted = read_manifest(manifest)
    paths = _PathFacts()  # for this check only: the file system as it is now
    planned, refused, problems = _parse_rows(manifest, rows, options.overwrite, paths)
    problems.update(miscounted)
    every_row = sorted([*planned, *refused], key=operator.attrgetter("line"))
    for line, problem in _shared_out_problems(manifest, every_row, paths).items():
        # every cell's problem at once (a trial fixed a missing file, then heard of its shared out); one per cell
        if "column out:" not in problems.get(line, ""):
            problems[line] = f"{problems[line]}\n{problem}" if line in problems else problem
    summary = Path(options.summary_json) if options.summary_json else default_summary_path(manifest)
    _check_summary_path(summary, manifest, [item for item in planned if item.line not in problems], paths)
    previous = read_previous_summary(summary) if options.retry_failed else None
    for item in planned:
        if item.line in problems:
            continue
        _decide(item, options, previous, paths, manifest)
        problem = _out_folder_problem(manifest, item, paths) if item.action == "run" else None
        if problem:
            problems[item.line] = problem
    if problems:
        raise ManifestError([line for _, text in sorted(problems.items()) for line in text.split("\n")])
    if any(item.action == "run" and item.config.get("c3d") for item in planned):
        from pcnet.stages.sinks.exports import require_ezc3d

        require_ezc3d()  # before any work, as `pcnet run --c3d`: not once per row at its end
    if any(item.action == "run" and item.config.get("opensim") for item in planned):
        from pcnet.stages.opensim_ik import import_opensim

        import_opensim()
    return planned, summary


def _engine(options: BatchOptions, on_result, on_retry):
    if options.engine == "ray":
        from .batch_ray import RayEngine

        return RayEngine(options.workers, options.retries, options.address, on_result, on_retry)
    from .batch_local import LocalEngine

    return LocalEngine(options.workers or cpu_cores(), options.retries, on_result, on_retry)


def _tilt_uncertainty(row: dict) -> str | None:
    """The report's cell for a row's camera-tilt uncertainty: ``"6.9 (95 % interval)"``."""
    half, what = row.get("camera_tilt_uncertainty_deg"), row.get("camera_tilt_uncertainty")
    return what if half is None else f"{half:.1f} ({what})"


def _row_summary(item: PlannedRow, result: dict | None, status: str | None = None) -> dict:
    """A row of the summary: the engine's result, or a skipped / cancelled / pending row."""
    base = {"row": item.row, "line": item.line, "out": str(item.out), "status": status, **dict.fromkeys(RESULT_FIELDS),
            "mode": "", "seconds": None, "error": "", "warnings": [], "notes": [],
            "host": "", "pid": None, "attempts": 0, "threads": None,
            # why it ran over its own earlier output (a study manager found it only on stderr)
            "ran_again": item.rerun if item.action != "skip" else ""}
    if item.action == "skip":
        base.update(status="skipped", **{k: v for k, v in item.known.items() if v is not None})
    elif result is not None:
        base.update(result, row=item.row)
        base["status"] = result.get("status", status)
    base.pop(FINDINGS, None)  # the terminal's and the report's: the warnings' texts are the summary's
    return base


class _SummaryWriter:
    """Writes the JSON summary atomically while the batch runs, so that a driver that dies
    still leaves what finished (at every result, or at most every :data:`SUMMARY_EVERY_S`
    for batches over :data:`SUMMARY_EVERY_RESULT_ROWS` rows, whose rewrites would add up;
    these rewrites also leave out the rows' ``angles``, five times the rest of a row: 10,000
    rows took 5.8 s to write with them), and at the end, in full."""

    def __init__(self, path: Path, header: dict):
        self.path, self.header, self.last = path, header, 0.0

    def write(self, rows: list[dict], force: bool = False, **extra) -> None:
        now = time.monotonic()
        if not force and len(rows) > SUMMARY_EVERY_RESULT_ROWS and now - self.last < SUMMARY_EVERY_S:
            return
        self.last = now
        if len(rows) > SUMMARY_EVERY_RESULT_ROWS and not extra.get("finished"):
            rows = [{k: v for k, v in r.items() if k not in PER_COLUMN_FIELDS} for r in rows]
        counts = {status: sum(r["status"] == status for r in rows) for status in (*STATUSES, "pending")}
        data = {**self.header, **extra, "counts": counts, "rows": rows}
        write_text(self.path, json.dumps(data, indent=1) + "\n")


def run_batch(manifest: str | os.PathLike, options: BatchOptions | None = None,
              progress: Callable[[str], None] | None = None) -> BatchReport:
    """Validate ``manifest``, then run its rows that need running with ``options.engine``
    and write the JSON summary (fields: docs/cluster.md, "Results") and, at the end, the
    Markdown report beside it (:func:`report_path`, :func:`batch_markdown`).

    ``progress`` gets a few lines per row as it finishes (:func:`progress_lines`: one for
    the row, one per warning), and one per restart of a row whose worker died. Ctrl-C (or
    SIGTERM) stops the batch: no further row starts, running rows are stopped without leaving
    half-written folders, and the report marks them ``cancelled`` (``exit_code`` 130).

    Raises:
        InputError, ManifestError: see :func:`plan_batch`; nothing has run then.
    """
    with _only_batch_of(manifest):
        return _run_batch(manifest, options or BatchOptions(), progress)


@contextlib.contextmanager
def _only_batch_of(manifest: str | os.PathLike):
    """Hold an exclusive ``flock(2)`` on ``manifest`` while its batch runs, so that a second
    ``pcnet batch`` of it is refused in one line before it plans anything: a file-safety
    trial's two batches of one manifest both failed every row the other was writing and wrote
    one summary, wrong, between them. Released with the file when the batch ends or its
    process dies. Where the file cannot be opened (:func:`plan_batch` says why) or the platform
    has no ``flock`` (Windows), nothing is held.

    Raises:
        InputError: another process holds the manifest.
    """
    try:
        import fcntl
        # a named pipe's open would wait for a writer (a file-safety trial); read_manifest refuses it
        held = open(manifest, "rb") if os.path.isfile(manifest) else None
    except (ImportError, OSError):
        held = None
    if held is None:
        yield
        return
    with held:
        try:
            fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(f"{manifest}: expected no other pcnet batch of this manifest running, got one running "
                             f"it now; let it finish (or stop it), then run again") from None
        except OSError:  # a file system without locks (some network shares): as before
            pass
        yield


def _run_batch(manifest: str | os.PathLike, options: BatchOptions,
               progress: Callable[[str], None] | None) -> BatchReport:
    started, wall_start = time.perf_counter(), time.time()
    planned, summary_path = plan_batch(manifest, options)
    by_row = {item.row: item for item in planned}
    results: dict[int, dict] = {}
    jobs = [{"row": item.row, "config": item.config, "manifest": manifest_from(item.out, manifest)}
            for item in planned if item.action == "run"]
    header = _summary_header(manifest, options, len(jobs))
    writer = _SummaryWriter(summary_path, header)
    restarts: list[str] = []

    def rows(unfinished: str) -> list[dict]:
        # A row stopped while running reports the attempt it was in (engines that know it).
        started = getattr(engine, "started", {})
        return [_row_summary(item, results.get(item.row) or started.get(item.row), unfinished) for item in planned]

    def on_result(result: dict) -> None:
        if result.get("error"):
            result = dict(result, error=in_manifest_terms(result["error"]))
        results[result["row"]] = result
        if progress is not None:
            progress(progress_lines(len(results), len(jobs), by_row[result["row"]], result))
        writer.write(rows("pending"))

    def on_retry(row: int, line: str) -> None:
        restarts.append(f"line {by_row[row].line}: {line}")
        if progress is not None:
            progress(restarts[-1])

    engine = None
    writer.write(rows("pending"), force=True)
    engine = _engine(options, on_result, on_retry)
    try:
        _, interrupted = engine.run(jobs)
    except KeyboardInterrupt:  # arrived outside the engine's loop (e.g. while Ray started)
        interrupted = True
    except Exception as err:  # the engine itself failed (Ray refused to start): no row stays "pending"
        writer.write(rows("cancelled"), force=True, finished=True, error=error_line(err))
        raise
    if interrupted:
        results.update(_published_before_the_stop(planned, results, since=wall_start))
    final = rows("cancelled")
    if interrupted and not (options.engine == "ray" and options.address):
        _clean_cancelled(planned, results)
    seconds = time.perf_counter() - started
    start_s = getattr(engine, "start_seconds", 0.0)
    writer.write(final, force=True, finished=True, interrupted=interrupted, seconds=round(seconds, 3),
                 engine_start_seconds=round(start_s, 3))
    findings = {item.row: (item.known if item.action == "skip" else results.get(item.row) or {}).get(FINDINGS)
                for item in planned}
    report = BatchReport(final, interrupted, summary_path, seconds, start_s, header, restarts,
                         report_path(summary_path), {row: found for row, found in findings.items() if found})
    write_text(report.report_path, batch_markdown(report))
    return report


def _summary_header(manifest, options: BatchOptions, jobs: int) -> dict:
    workers = options.workers or (None if options.engine == "ray" and options.address else cpu_cores())
    return {"writer": "pcnet batch", "pcnet_version": pcnet_version(), "manifest": str(Path(manifest).resolve()),
            "engine": options.engine, "address": options.address, "workers": workers, "rows_to_run": jobs,
            "retries": options.retries, "overwrite": options.overwrite, "retry_failed": options.retry_failed,
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "interrupted": False,
            # A driver killed outright (SIGKILL, a lost node) cannot rewrite its rows' "pending":
            # False here and no such process says so.
            "finished": False, "driver_host": socket.gethostname(), "driver_pid": os.getpid()}


def _published_before_the_stop(planned: list[PlannedRow], results: dict[int, dict], since: float) -> dict[int, dict]:
    """Rows the interrupt caught after their worker had published the output but before its
    result came back: their output and this run's resume marker are complete, so they are
    ``ok``, not ``cancelled`` (which says the output was left as it was)."""
    found = {}
    for item in planned:
        if item.action != "run" or item.row in results:
            continue
        try:
            fresh = (item.out / BATCH_MARKER).stat().st_mtime >= since
        except OSError:
            continue
        record = completed_record(item.out, item.config) if fresh else None
        if record is not None:
            found[item.row] = {**dict(record.get("result") or {}), "row": item.row, "status": "ok",
                               "host": record.get("host", ""), "pid": record.get("pid")}
    return found


def _clean_cancelled(planned: list[PlannedRow], results: dict[int, dict]) -> None:
    """Remove the staged folders that stopped rows left (their processes are gone; only
    folders carrying pcnet's marker naming a dead process are touched)."""
    for item in planned:
        if item.action == "run" and item.row not in results:
            try:
                clean_stale(item.out.resolve())
            except OSError:
                pass


def row_findings(records: list[dict] | None, warnings: list[str]) -> list:
    """A row's warnings as :class:`pcnet.stages.flags.Finding` s, most severe first: from
    their ``records`` (:func:`pcnet.pipeline.batch_worker.finding_records`), else (a row known
    only by its summary's texts) each text shortened, of severity CHECK, its action
    ``see report.md`` (the row's), as :mod:`pcnet.stages.flags` keeps a text of no kind."""
    from pcnet.stages.flags import Finding, Kind, Severity, ranked, shortened

    try:
        if records is not None:
            return ranked(Finding(Severity[r["severity"]], r["headline"], r["action"], r["detail"],
                                  None if r["kind"] is None else Kind[r["kind"]]) for r in records)
    except (KeyError, TypeError):  # a record of another pcnet's kinds: read as texts
        pass
    return [Finding(Severity.CHECK, shortened(text), "see report.md", text) for text in warnings]


def _finding_lines(records: list[dict] | None, warnings: list[str]) -> list[tuple]:
    """:func:`row_findings` with each one's terminal line (``WARNING headline -> action``,
    the ``pcnet run`` flags it names as the manifest's columns)."""
    return [(f, in_manifest_terms(f.terminal_line())) for f in row_findings(records, warnings)]


def progress_lines(done: int, total: int, item: PlannedRow, result: dict) -> str:
    """What the terminal gets as a row ends: one line (its status, time, and its output
    folder, with why it ran again over its own earlier output, or its one-line error), then
    one short line per warning, most severe first, with
    the action it asks; the warnings' full text is in the row's report.md and the batch
    report."""
    detail = str(item.out) if result["status"] == "ok" else result["error"]
    if result["status"] == "ok" and item.rerun:  # the earlier output, an OpenSim fit included, is gone
        made = item.made_from_it
        shown = ", ".join(made[:4]) + (f" and {len(made) - 4} more" if len(made) > 4 else "")
        detail += (f" (ran again: {item.rerun}; its earlier output replaced"
                   + (f", with what pcnet gait or pcnet opensim made from it ({shown}): run them again" if made else "")
                   + ")")
    took = f" {result['seconds']:.1f} s" if result.get("seconds") is not None else ""
    head = f"[{done}/{total}] line {item.line} {result['status']}{took}: {detail}"
    found = _finding_lines(result.get(FINDINGS), result.get("warnings") or [])
    return "\n".join([head, *(f"    {text}" for _, text in found)])


def _counts_line(report: BatchReport) -> str:
    counts = report.counts()
    done = counts["ok"] + counts["skipped"]
    # skipped rows ran in an earlier batch: their outputs are complete, but not processed now
    line = (f"{done} of {len(report.rows)} recordings have complete outputs "
            f"({', '.join(f'{v} {k}' for k, v in counts.items())}) in {report.seconds:.1f} s")
    # a cancelled or failed row leaves its folder as it was: an earlier complete output there is
    # still whole (a user trial's Ctrl-C under --overwrite read "0 of 13" with every earlier output
    # intact; another's killed worker left one unmentioned)
    kept = {status: [r["line"] for r in report.rows
                     if r["status"] == status and read_marker(Path(r["out"])).get("state") == "complete"]
            for status in ("cancelled", "failed")}
    # which rows, by their manifest lines (a study manager had to look them up)
    said = [f"{len(lines)} {status} row{'s' * (len(lines) != 1)} ({_lines_text(lines)})"
            for status, lines in kept.items() if lines]
    total = sum(map(len, kept.values()))
    return line + (f"; {' and '.join(said)} still hold{'s' * (total == 1)} an earlier complete output, not this run's"
                   if said else "")


def _lines_text(lines: list[int], shown: int = 5) -> str:
    """``"line 5"``, ``"lines 3, 7"``, ``"lines 3, 7, 9, 12, 15 and 4 more"``."""
    text = ", ".join(map(str, lines[:shown])) + (f" and {len(lines) - shown} more" if len(lines) > shown else "")
    return f"line{'s' * (len(lines) != 1)} {text}"


def _interrupted_line(report: BatchReport) -> str:
    """What an interrupted batch left, and the command that runs the rows it did not finish:
    with ``--overwrite`` the same command would run the finished rows again too, and a plain
    one skips a cancelled row that still holds its earlier output (a user trial)."""
    resume = ("--retry-failed --overwrite runs them alone" if report.settings.get("overwrite")
              else "the same command runs them")
    return f"interrupted: no further row started; cancelled rows left their output folders as they were; {resume}"


def _lines(items: list[str], what: str, details: str) -> list[str]:
    """At most :data:`SUMMARY_LINES` of ``items``, then how many more the report has."""
    more = len(items) - SUMMARY_LINES
    return items[:SUMMARY_LINES] + ([f"         ... and {more} more {what}: {details}"] if more > 0 else [])


def _grouped_findings(report: BatchReport) -> list[str]:
    """The warnings of the rows with complete outputs, one line per kind of finding (a finding
    of no kind: per distinct line), with the manifest lines that have it (at most
    :data:`SUMMARY_LINES` of them, the rest counted), most severe first. Where the rows'
    numbers differ, the line is the first row's and says so."""
    from pcnet.stages.flags import ranked

    seen: dict = {}  # kind (or terminal line) -> (its first finding, its line, the rows, the lines seen)
    for r in report.rows:
        if r["status"] in DONE:
            for f, text in _finding_lines(report.findings.get(r["row"]), r.get("warnings") or []):
                _, _, at, texts = seen.setdefault(f.kind or text, (f, text, [], set()))
                if not at or at[-1] is not r:  # a row with two findings of one kind counts once
                    at.append(r)
                texts.add(text)
    rank = {id(f): i for i, f in enumerate(ranked(first for first, _, _, _ in seen.values()))}
    out = []
    for _, text, at, texts in sorted(seen.values(), key=lambda group: rank[id(group[0])]):
        more = f" and {len(at) - SUMMARY_LINES} more" if len(at) > SUMMARY_LINES else ""
        # the rows differ in the numbers, and may in what they name (a scale trial: another limb)
        differ = f"; {len(at)} rows, the first's text shown, the batch report has each" if len(texts) > 1 else ""
        label = _row_label if len(at) <= NAMED_ROWS else (lambda r: str(r["line"]))  # many: the report names them
        out.append(f"{text} (line{'s' * (len(at) > 1)} {', '.join(map(label, at[:SUMMARY_LINES]))}{more}{differ})")
    return out


#: Up to this many rows, a grouped warning names each row's output folder beside its line.
NAMED_ROWS = 3


def _row_label(row: dict) -> str:
    """A row as the summary names it: its manifest line and its output folder's name (a user
    trial had to look the lines up to know which athlete a warning was about)."""
    return f"{row['line']}: {Path(row['out']).name}"


def _outputs_line(rows: list[dict]) -> str | None:
    """Where the complete outputs are: the one folder, or the folder holding them all."""
    outs = [r["out"] for r in rows if r["status"] in DONE]
    if len(outs) < 2:
        return outs[0] if outs else None
    return f"{os.path.commonpath(outs)} ({len(outs)} folders)"


def _opensim_line(rows: list[dict]) -> str | None:
    """The OpenSim fits' marker RMS over the complete outputs that have one: the range and
    the row of the largest (every row's own: the report)."""
    fitted = [r for r in rows if r["status"] in DONE and r.get("opensim_rms_cm") is not None]
    if not fitted:
        return None
    worst = max(fitted, key=lambda r: r["opensim_rms_cm"])
    if len(fitted) == 1:
        return f"marker RMS {worst['opensim_rms_cm']:.2f} cm (line {_row_label(worst)})"
    low = min(r["opensim_rms_cm"] for r in fitted)
    return (f"marker RMS {low:.2f}-{worst['opensim_rms_cm']:.2f} cm over {len(fitted)} rows (largest: line "
            f"{_row_label(worst)})")


def _units_line(rows: list[dict]) -> str | None:
    """Where complete outputs are not in metres (a row without ``height`` for a lifter whose
    output is not metric): their lines, since their columns are named and scaled otherwise
    (``pelvis_y_normalised``); None when every row is metric (or says nothing)."""
    done = [r for r in rows if r["status"] in DONE and r.get("units")]
    other = [r for r in done if r["units"] != "m"]
    if not other:
        return None
    metric = len(done) - len(other)
    metric_rows = f"; m in {metric} row{'s' * (metric != 1)}" if metric else ""
    return f"{_lines_by(other, lambda r: r['units'])}, not metres (column height scales them){metric_rows}"


def _lines_by(rows: list[dict], kind) -> str:
    """``rows`` grouped by ``kind(row)`` in first-seen order, each group as ``"{kind} in lines
    a, b and N more"`` (at most :data:`SUMMARY_LINES` lines named), the groups joined by ``"; "``."""
    groups: dict[str, list[int]] = {}
    for r in rows:
        groups.setdefault(kind(r), []).append(r["line"])
    return "; ".join(f"{k} in {_lines_text(lines, SUMMARY_LINES)}" for k, lines in groups.items())


def _world_line(rows: list[dict]) -> str | None:
    """Where the complete outputs' world frames got their pelvis path and floor (report.md's
    ``root_path`` and ``floor.kind``), by manifest lines: a metric path and a fitted floor plane
    or not is what a lab reads first; None where no row has a world frame (or says nothing)."""
    framed = [r for r in rows if r["status"] in DONE and r.get("root_path")]
    if not framed:
        return None
    return _lines_by(framed, lambda r: f"pelvis path {r['root_path']}, floor {r.get('floor') or '-'}")


def format_summary(report: BatchReport) -> str:
    """The summary that reads in seconds: the counts, one line per failed row (its error),
    one line per distinct warning of the complete outputs (most severe first, with its
    action and the manifest lines), each list cut at :data:`SUMMARY_LINES`; the OpenSim fits'
    marker RMS where rows asked for them; where the outputs, the JSON summary and the report
    are. Every row in full: the report."""
    details = str(report.report_path or report.summary_path)
    lines = [_counts_line(report)] + ([_interrupted_line(report)] if report.interrupted else [])
    failed = [f"FAILED   line {r['line']}: {r['error']}" for r in report.rows if r["status"] == "failed"]
    lines += _lines(failed, "failed rows", details)
    lines += ["once fixed, --retry-failed runs the failed and cancelled rows alone"] * bool(failed)
    lines += _lines(_grouped_findings(report), "warnings", details)
    opensim, outputs, units = _opensim_line(report.rows), _outputs_line(report.rows), _units_line(report.rows)
    lines += [f"{'units':<17} {units}"] * bool(units)
    world = _world_line(report.rows)
    lines += [f"{'world frame':<17} {world}"] * bool(world)
    lines += [f"{'OpenSim IK':<17} {opensim}"] * bool(opensim)
    lines += [f"{'outputs':<17} {outputs}"] * bool(outputs) + [f"{'summary':<17} {report.summary_path}"]
    if report.report_path is not None:
        lines.append(f"details: {report.report_path}")
    return "\n".join(lines)


def _cell(value) -> str:
    return "-" if value is None or value == "" else str(value).replace("|", "/").replace("\n", " ")


def _trunk_lean(row: dict) -> float | None:
    """The row's median trunk lean from vertical (``trunk_inclination_deg``, the run summary's
    trunk lean), ``None`` without: a seated row read 26 deg from vertical looked as
    trustworthy as a standing one with only the camera's tilt beside it (a physiotherapist's trial)."""
    trunk = (row.get("angles") or {}).get("trunk_inclination_deg")
    return None if trunk is None else trunk.get("median")


def batch_markdown(report: BatchReport) -> str:
    """The batch report: what the terminal summary leaves out. The counts and the batch's
    settings; a table of every row (status, its warnings' count, attempts, frames, valid frames, mode,
    units (a row without ``height`` may not be in metres), tilt and its uncertainty, posture, the
    trunk's median lean from vertical, pelvis path, floor, the OpenSim
    fit's marker RMS, seconds,
    worker, threads, output folder); the rows run again over their earlier output and why; every failed row's error in full (and its traceback
    where the failure is a bug of pcnet); every warning of every row, most severe
    first, with its action and its full text once (where an earlier row's says the same with
    other numbers, a pointer to that row's); every row's notes (a trial found a file of another lifter named
    only in one row's report.md); the restarts of rows whose worker died."""
    s = report.settings
    n = s.get("workers")
    workers = f"{n} worker{'s' if n != 1 else ''}" if n else "a worker per CPU"
    out = [f"{REPORT_TITLE}: {s.get('manifest', '')}", "", _counts_line(report) + "."]
    out += ["", _interrupted_line(report) + "."] if report.interrupted else []
    out += ["", f"- **engine**: {s.get('engine')}" + (f" at {s['address']}" if s.get("address") else "")
            + f", {workers}, retries {s.get('retries')}; started {s.get('started')}, engine start "
              f"{report.engine_start_seconds:.1f} s",
            f"- **options**: overwrite {s.get('overwrite')}, retry_failed {s.get('retry_failed')}",
            f"- **summary**: {report.summary_path} (every row's fields, docs/cluster.md \"Results\")",
            # where a row's provenance lies (a trial found none in the summary or this report)
            f"- **provenance**: pcnet {s.get('pcnet_version', 'unknown')}; each complete row's input digests "
            f"(sha256), settings and pcnet version in its output's {BATCH_MARKER}, and its report.md's "
            f"inputs.settings",
            "", "## Rows", "",
            "| row | line | status | warnings | tries | frames | valid | mode | units | tilt deg | tilt +- deg (what) "
            "| posture | trunk from vertical deg (median) | pelvis path | floor | OpenSim RMS cm | seconds | worker "
            "| threads | output |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in report.rows:
        seconds = f"{r['seconds']:.1f}" if r.get("seconds") is not None else None
        worker = f"{r['host']}:{r['pid']}" if r.get("pid") else None
        # how many, at a glance (a physiotherapist's trial found no row's trouble in the table)
        warned = len(r.get("warnings") or []) if r["status"] in DONE else None
        out.append("| " + " | ".join(_cell(v) for v in (r["row"], r["line"], r["status"], warned, r["attempts"],
                                                          r["frames"],
                                                          r["valid"], r.get("mode"), r.get("units"),
                                                          r.get("camera_tilt_deg"), _tilt_uncertainty(r),
                                                          r.get("posture"), _trunk_lean(r), r.get("root_path"),
                                                          r.get("floor"),
                                                          r.get("opensim_rms_cm"), seconds,
                                                          worker, r.get("threads"),
                                                          r["out"])) + " |")
    again = [r for r in report.rows if r.get("ran_again")]
    if again:
        out += ["", "## Rows run again over their earlier output", ""]
        out += [f"- line {r['line']} (row {r['row']}, {r['status']}): {r['ran_again']}" for r in again]
    failed = [r for r in report.rows if r["status"] == "failed"]
    out += ["", "## Failed rows", ""] + ([] if failed else ["None."])
    for r in failed:
        out += [f"### line {r['line']} (row {r['row']})", "", r["error"], ""]
        if r.get("traceback"):
            out += ["```", r["traceback"].rstrip(), "```", ""]
    warned = [r for r in report.rows if r.get("warnings")]
    out += ["", "## Warnings", "", "Each row's, most severe first, with its full text where an earlier row's does not "
            "say the same (every row's in full in its report.md)." if warned else "None."]
    said: dict[str, int] = {}  # a full text with its numbers masked -> the first line giving it
    for r in warned:
        out += ["", f"### line {r['line']} (row {r['row']}, {r['status']}): {r['out']}", ""]
        for i, f in enumerate(row_findings(report.findings.get(r["row"]), r["warnings"]), 1):  # as report.md's
            out += [f"#### {i}. {f.headline}", "", f"Severity: {f.severity.name.lower()}. Action: "
                    f"{in_manifest_terms(f.action)}.", ""]
            # a study's rows repeat a warning's paragraph with other numbers (a yoga trial read 120 words a row)
            masked = re.sub(r"\d+(?:\.\d+)?", "#", f.detail)
            if masked in said:
                out += [f"The text of line {said[masked]}'s, with this row's numbers.", ""]
            else:
                said[masked] = r["line"]
                out += [f.detail, ""]
    noted = [r for r in report.rows if r.get("notes")]
    out += ["", "## Notes", "", "Each row's in full (also in its report.md): what it assumed and what to check."
            if noted else "None."]
    for r in noted:
        out += ["", f"### line {r['line']} (row {r['row']}, {r['status']}): {r['out']}", ""]
        out += [f"- {in_manifest_terms(n)}" for n in r["notes"]]
    out += ["", "## Restarts", ""] + ([f"- {line}" for line in report.restarts] or ["None."])
    return re.sub(r"\n{3,}", "\n\n", "\n".join(out)).rstrip() + "\n"
