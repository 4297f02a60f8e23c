"""The ``pcnet`` command line."""

from __future__ import annotations

import ast
import dataclasses
import json
import math
import os
import re
import shlex
import shutil
import signal
import sys
from pathlib import Path

import click

from pcnet.models.datasets import CAMERAS
from pcnet.pipeline.batch import ENGINES
from pcnet.pipeline.config import (ALIGN, MODES, check_camera_up_use, keypoint_formats, lifter_names,
                                   multi_track_formats, parse_camera_up, pcnet_version)
from pcnet.pipeline.interrupt import (EXIT_INTERRUPTED, STOP_SIGNALS, InterruptedAfterPublishing, came_from_interrupt,
                                      exception_chain, quiet_interrupt_hook, raise_interrupt)
from pcnet.stages.core.errors import InputError, import_extra, one_line, short_path
from pcnet.stages.heading import HEADING_SOURCES
from pcnet.stages.rectify import METHODS, POSTURES, check_method_weights, check_posture


class _ErrorBoundary(click.Group):
    """Every command's body runs here: bad input (:class:`InputError`, an ``OSError`` from
    the user's files or folders or their environment, a bad option value, input too deep or
    too large for the interpreter: ``RecursionError``, ``MemoryError``) ends in one line and
    exit 1, Ctrl-C and SIGTERM in one line and exit 130. Any other exception is a bug of pcnet
    and keeps its traceback."""

    def invoke(self, ctx: click.Context):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt as stop:
            _stop_interrupted(stop)
        except (click.exceptions.Exit, click.Abort):
            raise
        except BrokenPipeError:  # the reader stopped reading (pcnet docs PAGE | head): no error line for it
            # as the Python docs advise (library/signal, "Note on SIGPIPE"): the interpreter's own flush at exit
            # would raise again
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            raise click.exceptions.Exit(1) from None
        except Exception as err:
            if came_from_interrupt(err):
                _stop_interrupted(err)
            line = _bad_input_line(ctx, err)
            if line is None:  # a bug of pcnet, or click's own exception: as raised
                raise
            _leave_if_writer_stopped(line)
            raise click.ClickException(line) from err


def _leave_if_writer_stopped(line: str) -> None:
    """Print the error ``line`` and leave at once (exit 1) where a recording's rerun file writer
    stopped (:func:`pcnet.stages.sinks.rerun_log.writer_stopped`): the run's own clean-up has run,
    and rerun's shutdown at exit would wait on the stopped writer forever."""
    from pcnet.stages.sinks.rerun_log import writer_stopped

    if writer_stopped():
        click.echo(f"Error: {line}", err=True)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(1)


def _existing(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    """An input path that names something (a file, a folder, a link): checked as the option is
    read, so a missing file is named before any other problem of the run (a user trial was told
    to pass --fps for a file that did not exist). A link that leads nowhere or loops is left to
    the readers, which say which."""
    if value is not None and not os.path.lexists(value):
        from pcnet.pipeline.io import close_file

        raise click.BadParameter(f"Path '{value}' does not exist{close_file(Path(value))}.", ctx=ctx, param=param)
    return value


#: ``--strict``'s exit status: every output written, and at least one WARNING (1 is bad input
#: with nothing written, 130 an interrupted run).
EXIT_WARNED = 3
_STRICT_HELP = (f"Exit with status {EXIT_WARNED} where a WARNING is printed (every output still written): for scripts "
                "that gate on the exit status; 0 then means no warning, 1 bad input with nothing written.")


def _strict_exit(warnings: int) -> None:
    """``--strict``'s end of a command that printed ``warnings`` WARNING lines (an automated
    pipeline's trial found a shuffled joint order written with exit 0, said only in warnings)."""
    if warnings:
        # on stderr, where "above" pointed at lines a script had sent elsewhere (a file-safety trial)
        click.echo(f"--strict: exit {EXIT_WARNED}: {warnings} WARNING{'s' * (warnings != 1)} in the summary on stdout",
                   err=True)
        raise click.exceptions.Exit(EXIT_WARNED)


def _stop_after_writing(what: str, where: str = "") -> None:
    """Exit 130 for an interrupt that came after ``what`` (``--out OUT``, a file) was written
    whole, saying so."""
    click.echo(f"pcnet: interrupted after {what} was written whole{where}", err=True)
    raise click.exceptions.Exit(EXIT_INTERRUPTED) from None


def _stop_interrupted(stop: BaseException | None = None) -> None:
    # the interrupt itself, or what it caused, may say the output was published whole just before
    for err in exception_chain(stop):
        if isinstance(err, InterruptedAfterPublishing):
            _stop_after_writing(err.path)
    click.echo("pcnet: interrupted; nothing half-written was left behind", err=True)
    raise click.exceptions.Exit(EXIT_INTERRUPTED) from None


def _bad_input_line(ctx: click.Context, err: Exception) -> str | None:
    """The one line for bad input (:class:`InputError`, an ``OSError`` from the user's files
    or folders or their environment, a bad option value, input too deep or too large for the
    interpreter, a symlink loop); ``None`` for anything else (click's other exceptions, which
    click prints itself, and pcnet's bugs, which keep their traceback)."""
    if isinstance(err, (InputError, OSError)):
        return one_line(err)
    if isinstance(err, (RecursionError, MemoryError)):
        # The readers bound what they parse and name the file; this is the last resort
        # for whatever slips past them, still one line and no output (the writers clean up).
        return f"pcnet {ctx.invoked_subcommand or ''}: {one_line(err)}"
    if isinstance(err, click.UsageError):  # a bad option value: one line and exit 1 like any bad input
        hint = f" (see pcnet {err.ctx.info_name} --help)" if err.ctx is not None and err.ctx.parent else ""
        if err.ctx is not None and err.ctx.info_name == "run":
            hint = _input_option_hint(err.format_message()) or hint
        return one_line(err.format_message()) + hint
    if isinstance(err, UnicodeEncodeError) and "surrogates not allowed" in str(err):
        # a path holding bytes that are not UTF-8 (a Latin-1 name), which writers of UTF-8 text and
        # rerun cannot encode (a file-safety trial's got a 60-line traceback)
        return (f"pcnet {ctx.invoked_subcommand or ''}: expected input and output file and folder names in UTF-8, "
                f"got one with other bytes ({one_line(err)}): rename it")
    if isinstance(err, RuntimeError) and str(err).startswith("Symlink loop from "):
        # Path.resolve() on a symlink loop (Python < 3.13 raises RuntimeError, not OSError)
        path = ast.literal_eval(str(err)[len("Symlink loop from "):])  # the path's repr, as pathlib wrote it
        return f"{path}: expected a file or folder, got a symlink loop"
    return None


#: A file's suffix -> the `pcnet run` option it is given with (a coach's trial typed `pcnet run demo.mp4`).
_INPUT_OPTIONS = {**dict.fromkeys((".mp4", ".mov", ".avi", ".mkv", ".m4v", ".webm"), "--video"),
                  **dict.fromkeys((".npy", ".npz", ".csv", ".mat", ".trc", ".c3d"), "--lifter-output"),
                  ".json": "--keypoints2d"}


def _input_option_hint(message: str) -> str:
    """``" (did you mean --video demo.mp4?)"`` for `pcnet run`'s "unexpected extra argument"
    naming a file whose suffix says which input it is (:data:`_INPUT_OPTIONS`), else ``""``."""
    found = re.fullmatch(r"Got unexpected extra arguments? \((.+)\)", message.strip())
    if not found:
        return ""
    first = found.group(1).split()[0]
    option = _INPUT_OPTIONS.get(Path(first).suffix.lower())
    return f" (did you mean {option} {first}? see pcnet run --help)" if option else ""


def _print_version(ctx: click.Context, _param: click.Parameter, value: bool) -> None:
    if value and not ctx.resilient_parsing:
        click.echo(f"pcnet, version {pcnet_version()}")
        ctx.exit()


@click.group(cls=_ErrorBoundary, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--version", is_flag=True, expose_value=False, is_eager=True, callback=_print_version,
              help="Show the version (the release and a digest of its code, as reports record it) and exit.")
def main() -> None:
    """pcnet: rectify monocular 3D human poses into a gravity-aligned, body-centred frame."""
    # SIGTERM (a scheduler's or `kill`'s stop) and SIGHUP (a closed terminal) unwind like Ctrl-C,
    # so the same clean-up runs.
    for signum in STOP_SIGNALS:
        if signal.getsignal(signum) is signal.SIG_DFL:
            signal.signal(signum, raise_interrupt)
    # and one landing in an import lock's weakref callback prints no traceback, as under the
    # entry point (a fresh clone's test run of `python -m pcnet.pipeline.cli` printed one)
    sys.unraisablehook = quiet_interrupt_hook(sys.unraisablehook)


def _new_output_file(path: str | os.PathLike, option: str, overwrite: bool = False, inputs=(),
                     companions: tuple[str, ...] = (), written_by_pcnet=None) -> None:
    """Refuse, before any work, an output file that pcnet must not write: its folder is
    missing or read-only, it is one of the ``inputs``, or it (or a ``companions`` file written
    beside it, e.g. ``.json`` metadata) exists and ``overwrite`` is not set, or is set but
    ``written_by_pcnet(file)`` (``(Path) -> bool``, the command's own output's signature) does
    not recognise the file: pcnet replaces only files it wrote."""
    target = Path(path).resolve()
    folder = target.parent
    if not folder.is_dir():
        raise InputError(f"{option} {path}: expected an existing folder for it, got no folder {folder}")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"{option} {path}: expected a folder pcnet may write to, got read-only {folder}")
    written = [target] + [target.with_suffix(suffix) for suffix in companions]
    for item in inputs:
        if item is not None and Path(item).resolve() in written:
            raise InputError(f"{option} {path}: expected a new file, got the input {item} itself")
    for file in written:
        # a file this command did not write is named as such first: "pass --overwrite" would only be
        # refused next (an ML trial's mocap sidecar ft.json beside --out ft.onnx)
        if file.exists() and written_by_pcnet is not None and not written_by_pcnet(file):
            raise InputError(f"{option} {path}: expected a new file or one this command wrote, got an existing "
                             f"{file.name} that it did not write; choose another {option} (--overwrite replaces only "
                             f"pcnet's own files)")
        if file.exists() and not overwrite:
            raise InputError(f"{option} {path}: expected a new file, got an existing {file.name}; "
                             f"pass --overwrite to replace it")


def _json_object_with(file: Path, keys: set[str]) -> bool:
    """Whether ``file`` is a JSON object holding every key in ``keys``."""
    try:
        data = json.loads(file.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError):  # RecursionError: nested too deeply
        return False
    return isinstance(data, dict) and keys <= data.keys()


#: What identifies each single-file output of pcnet when --overwrite is asked to replace it.
_EVALUATE_JSON_KEYS = {"method", "views", "split", "split_scheme", "data"}
_EXPORT_JSON_KEYS = {"model_config", "opset"}
_RECTIFY_MEMBERS = {"rotation.npy", "canonical.npy", "up.npy", "valid.npy", "method.npy", "mode.npy"}


def _rectify_output(file: Path) -> bool:
    import zipfile

    try:
        with zipfile.ZipFile(file) as archive:
            return _RECTIFY_MEMBERS <= set(archive.namelist())
    except (OSError, zipfile.BadZipFile):
        return False


def _exported_model(file: Path) -> bool:
    """An ``.onnx`` counts as pcnet's where its ``.json`` description beside it does."""
    return _json_object_with(file.with_suffix(".json"), _EXPORT_JSON_KEYS)


class _RegisteredChoice(click.Choice):
    """``click.Choice`` over the names ``names()`` returns (the adapter registry's, through
    :mod:`pcnet.pipeline.config`), read when click first needs them: the registry is the one
    list, and a command that takes no adapter never imports the adapters (OpenCV). Any case
    (``VideoPose3D``, as its authors write it) reads as the registered name."""

    def __init__(self, names) -> None:  # no super().__init__(): ``choices`` is computed
        self._names = names
        self.case_sensitive = False

    @property
    def choices(self) -> tuple[str, ...]:
        return tuple(self._names())


class _Number(click.ParamType):
    """A float option whose refusal shows the value a user meant: a decimal comma (``1,75``,
    usual in much of Europe) or a unit typed after the number (``30fps``, ``1.75m``) are named
    with the number to give (a coach's trial read click's "'1,75' is not a valid float")."""

    name = "float"

    def convert(self, value, param, ctx):
        if isinstance(value, float):
            return value
        text = str(value).strip()
        try:
            return float(text)
        except ValueError:
            pass
        hint = ""
        if re.fullmatch(r"[+-]?\d+,\d+", text):
            hint = f" (a decimal comma? give {text.replace(',', '.')})"
        elif m := re.fullmatch(r"([+-]?\d+(?:[.,]\d+)?)\s*[A-Za-z/%]+", text):
            hint = f" (a unit after the number? give {m.group(1).replace(',', '.')}, in the option's own unit)"
        self.fail(f"expected a number, got {text!r}{hint}", param, ctx)


_NUMBER = _Number()


class _PersonOption(click.Option):
    """``--person``, whose help names the registered multi-track 2D formats' track ids."""

    def get_help_record(self, ctx: click.Context):
        self.help = f"2D track id to follow ({' / '.join(multi_track_formats().values())})."
        return super().get_help_record(ctx)


_camera_up_option = click.option(
    "--camera-up", default=None,
    help="X,Y,Z: the static camera's up (against gravity) in its own frame (x right, y down, z forward; a level "
         "camera's is 0,-1,0), where it is known (a calibration, the filming phone's gravity sensor): sequence mode "
         "takes it instead of estimating one.")
_camera_prior_option = click.option(
    "--camera-prior/--no-camera-prior", "camera_prior", default=None,
    help="--no-camera-prior: sequence mode's up from the poses (and floor contacts) alone, without the camera "
         "prior and the lying hypothesis (frame and smooth modes have no camera prior; for the paper's single "
         "network, give one 3DPCNet's ONNX as --weights).")

_posture_option = click.option(
    "--posture", type=click.Choice(POSTURES), default=None,
    help="Sequence mode with the shipped ensemble: the body's posture, where you know it. A body lying under a "
         "level camera and an upright one under a camera turned a quarter turn give the same poses; auto leaves "
         "it to the priors [auto].")

_METHOD_HELP = ("pcnet: the shipped ensemble of two 3DPCNets (gated by camera view); pcnet-rigid: the same without the residual; "
                "geometric: the paper's baseline (section 2.3).")

_heading_option = click.option(
    "--heading", type=click.Choice(HEADING_SOURCES), default=None,
    help="Heading about the up axis from: predicted (the method's rotation), hips (the input's hip line, "
         "exact on clean mocap) or auto (hips when precise) [auto; geometric: predicted].")


@main.command()
@click.option("--method", type=click.Choice(METHODS), required=True, help=_METHOD_HELP)
@click.option("--data", type=click.Path(dir_okay=False), required=True,
              help="Mocap .npz: one (T, 17, 3) H36M-17 array per clip, metres, world frame +Y up (docs/guide/commands.md).")
@click.option("--split", type=click.Choice(["train", "val", "test", "all"]), default="test", show_default=True,
              help="Which clips of --data under --split-scheme; all: every clip (the training split's too: the summary says how much the weights trained on).")
@click.option("--split-scheme", type=click.Choice(["motion-style", "clip"]), default="motion-style", show_default=True,
              help="motion-style: whole Bandai motion-style groups and some whole styles held out of train (CMU: "
                   "whole subjects); clip: the old per-take hash earlier releases were trained with (the shipped "
                   "weights: motion-style), which puts sibling takes of most test clips in train.")
@click.option("--unseen-by", type=click.Choice(["motion-style", "clip"]), default=None,
              help="Keep only clips whose motion-style group (CMU: subject) has no take in this scheme's train "
                   "split; --unseen-by clip scores the groups that weights trained on the clip split never saw.")
@click.option("--untrained-only", is_flag=True, default=False,
              help="Leave out the clips the weights' training record names as trained on (their train split of this "
                   "file, or a file trained on whole: DeepMimic's three floor motions for the shipped weights).")
@click.option("--views", type=click.Choice(["paper", "wide"]), default="paper", show_default=True,
              help="Synthetic camera views (docs/CONVENTIONS.md): paper (3DPCNet's) or wide (any yaw, pitch +-45).")
@click.option("--camera", type=click.Choice(CAMERAS), default="per-frame", show_default=True,
              help="per-frame: a new camera each frame (paper); per-clip: one camera per clip, panning with the "
                   "subject's turns; static: one camera fixed in the world (sequence and auto modes need per-clip or "
                   "static).")
@click.option("--noise", type=click.Choice(["none", "frame", "lifter"]), default="none", is_flag=False,
              flag_value="frame", show_default=True,
              help="Input noise: frame (each frame's error drawn anew; --noise alone), lifter (errors that persist "
                   "over a clip like a monocular lifter's, pcnet.models.lifter_noise; use a per-clip or static "
                   "camera for sequence modes) or none.")
@click.option("--mode", type=click.Choice(["frame", "sequence", "smooth", "auto"]), default="frame", show_default=True,
              help="Per-frame (paper) or sequence-aware rectification of each clip.")
@_heading_option
@_camera_prior_option
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@click.option("--max-frames", type=int, default=None,
              help="Score at most N evenly spaced frames (every clip is still rectified whole: its sequence modes "
                   "read the whole recording, so this does not shorten the run).")
@click.option("--weights", type=click.Path(dir_okay=False), default=None, help="ONNX weights (default: shipped).")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), default=None, help="Also write the numbers here, each clip's means among them (per_clip).")
@click.option("--overwrite", is_flag=True, help="Replace an existing --json file.")
def evaluate(method, data, split, split_scheme, unseen_by, untrained_only, views, camera, noise, mode, heading,
             camera_prior, seed, max_frames, weights, json_out, overwrite):
    """Rotation/tilt/heading error and MPJPE/PA-MPJPE on mocap seen by synthetic cameras.
    --max-frames scores N evenly spaced frames of whole rectified clips (same method, same
    per-clip decisions); invalid frames are counted and excluded."""
    from pcnet.pipeline.evaluate import evaluate as run_eval, format_table
    from pcnet.stages.core.atomic import write_text

    if json_out:
        _new_output_file(json_out, "--json", overwrite, inputs=(data, weights),
                         written_by_pcnet=lambda f: _json_object_with(f, _EVALUATE_JSON_KEYS))
    check_method_weights(method, weights, "--weights")
    if max_frames is not None and max_frames < 1:
        raise InputError(f"--max-frames: expected a count >= 1, got {max_frames}")
    result = run_eval(method, data, split, views, seed, max_frames, weights, camera, noise,
                      mode, heading, split_scheme=split_scheme, unseen_by=unseen_by,
                      camera_prior=camera_prior is not False, untrained_only=untrained_only)
    click.echo(format_table(result))
    if json_out:
        from pcnet.stages.sinks.exports import finite_or_null

        write_text(json_out, json.dumps(finite_or_null(result), indent=2, allow_nan=False) + "\n", replace=overwrite)


@main.command()
@click.argument("input_path", type=click.Path(dir_okay=False))
@click.option("--out", "out_path", type=click.Path(dir_okay=False), required=True,
              help="The .npz archive to write (rotation, canonical, up, valid, ...: docs/guide/commands.md).")
@click.option("--method", type=click.Choice(METHODS), default="pcnet", show_default=True, help=_METHOD_HELP)
@click.option("--key", default=None, help="Array name inside an .npz input.")
@click.option("--mode", type=click.Choice(["frame", "sequence", "smooth", "auto"]), default="frame", show_default=True,
              help="frame: each frame alone (paper); sequence: one up for a static camera; smooth: moving camera.")
@click.option("--fps", type=_NUMBER, default=None,
              help="Frame rate (Hz): needed by the modes that pool frames over seconds (sequence, smooth, auto); "
                   "frame mode reads it only for the pcnet ensemble's 2 s view-gate window (30 when not given).")
@_heading_option
@_camera_prior_option
@_posture_option
@click.option("--weights", type=click.Path(dir_okay=False), default=None,
              help="ONNX weights of one 3DPCNet instead of the shipped ensemble (pcnet export).")
@_camera_up_option
@click.option("--overwrite", is_flag=True, help="Replace an existing --out file.")
@click.option("--strict", is_flag=True, help=_STRICT_HELP)
def rectify(input_path, out_path, method, key, mode, fps, heading, camera_prior, posture, weights, camera_up,
            overwrite, strict):
    """Rectify (T,17,3) H36M-17 camera-frame poses (OpenCV axes) from a .npy/.npz file."""
    import numpy as np

    from pcnet.adapters.validate import nonfinite_line
    from pcnet.pipeline.checks import CameraTilt, per_frame_tilt, pitch_half_width, pose_checks
    from pcnet.pipeline.io import read_pose_array
    from pcnet.pipeline.run_report import camera_record
    from pcnet.stages.flags import ranked, signed_deg, with_looking
    from pcnet.stages.core.conventions import validate_fps
    from pcnet.stages.sinks.exports import write_npz
    from pcnet.pipeline.rectification import rectify as run_rectify

    _new_output_file(out_path, "--out", overwrite, inputs=(input_path, weights), written_by_pcnet=_rectify_output)
    if Path(out_path).suffix.lower() != ".npz":
        raise InputError(f"--out {out_path}: expected a file name ending in .npz (an npz archive is written), got "
                         f"{Path(out_path).suffix or 'no suffix'}")
    if fps is None and mode != "frame":
        raise InputError(f"--mode {mode} pools frames over seconds: give --fps, the recording's frame rate (Hz)")
    if fps is not None:
        validate_fps(fps, "--fps")
    check_method_weights(method, weights, "--weights")
    check_posture(posture or "auto", method, weights, mode, camera_prior is not False, "--posture")
    up = None if camera_up is None else parse_camera_up(camera_up, "--camera-up")
    if up is not None:
        check_camera_up_use(mode, posture or "auto", "--camera-up", "--posture")
    joints, nonfinite, placeholders = read_pose_array(input_path, key)
    try:
        res = run_rectify(joints, method, weights, mode=mode, fps=fps, heading=heading,
                          camera_prior=camera_prior is not False, posture=posture or "auto",
                          camera_up=up)
    except InputError as err:
        if weights is not None and str(err).startswith((f"{weights}:", f"{Path(weights)}:")):
            raise  # the weights file's own error, already naming it
        raise InputError(f"{input_path}: {err}") from err
    findings = ranked(pose_checks(joints, res))  # what pcnet run would say of these poses alone
    # the camera's tilt, pitch and roll as pcnet run's report gives them (a trial found them missing)
    tilt = CameraTilt.of(res.rotation, res.valid)
    per_frame = per_frame_tilt(res.rotation, res.valid, res.mode)
    # the report and the warnings kept with the arrays (a trial's declared posture was printed, then lost)
    write_npz(out_path, replace=overwrite, rotation=res.rotation, canonical=res.canonical, up=res.up, valid=res.valid,
              method=np.array(method), mode=np.array(res.mode), heading_source=np.array(res.heading_source),
              frame_tilt_bound_deg=res.report.frame_tilt_bound_deg,
              report={**res.report.as_record(), **camera_record(tilt, per_frame)},
              flags=np.array([f.detail for f in findings], dtype=str))
    try:  # the archive is written: an interrupt from here on says so (a file-safety trial)
        cv = res.report.heading.hip_width_cv_percent
        requested = f" (requested {mode})" if mode != res.mode else ""
        click.echo(f"{out_path}: {len(res.valid)} frames, {int(res.valid.sum())} valid, method {method}, mode {res.mode}{requested}, "
                   f"heading from {res.heading_source} (hip width CV "
                   + (f"{cv:.2f} %)" if np.isfinite(cv) else "needs two frames)"))
        pitch_roll = (f"(pitch {signed_deg(tilt.pitch_deg)}, roll {signed_deg(tilt.roll_deg)} deg, of the "
                      f"{'one' if res.mode == 'sequence' else 'mean'} up"
                      + (f"; per frame median {per_frame[0]:.1f}, 5-95 % {per_frame[1]:.1f}-{per_frame[2]:.1f}"
                         if per_frame else "")
                      + ("; given, --camera-up)" if up is not None else
                         "; its intervals in the archive's report, docs/outputs.md)" if res.mode == "sequence" else ")"))
        click.echo(f"camera tilt {tilt.tilt_deg:.1f} deg from level "
                   + with_looking(pitch_roll, tilt.pitch_deg, pitch_half_width(res.report)))
        for counts, what in ((nonfinite, "non-finite values (inf/NaN)"),  # which the counts above take as missing
                             (placeholders, "a writer's placeholders for joints not found (zeros, or a frame on one point)")):
            if counts:
                click.echo(nonfinite_line(counts, what=what))
        for f in findings:
            click.echo(f.terminal_line())
    except KeyboardInterrupt:
        _stop_after_writing(str(out_path))
    if strict:
        _strict_exit(sum(f.is_warning for f in findings))


#: Where pip finds torch's CPU build: without it pip fetches the CUDA build, several GB (a
#: plain-install trial followed the one-line hint literally).
TORCH_CPU = " --extra-index-url https://download.pytorch.org/whl/cpu (the CPU build)"


@main.command()
@click.option("--config", "config_path", type=click.Path(dir_okay=False), required=True)
@click.option("--no-resume", is_flag=True, help="Start again even if a checkpoint exists.")
@click.option("--seed", default=None, type=click.IntRange(0, 2**31 - 1),
              help="Seed instead of the config's (several runs of one recipe).")
@click.option("--out-dir", default=None, type=click.Path(file_okay=False),
              help="Write the run here instead of the config's out_dir.")
def train(config_path, no_resume, seed, out_dir):
    """Train 3DPCNet (needs the [train] extra: torch)."""
    import_extra("torch", f'pcnet train needs torch: pip install "pcnet[train]"{TORCH_CPU}')
    from pcnet.models.train import load_config, train as run_train

    overrides = {k: v for k, v in (("seed", seed), ("out_dir", out_dir)) if v is not None}
    best = run_train(dataclasses.replace(load_config(config_path), **overrides), resume=not no_resume)
    click.echo(f"best checkpoint: {best}")


@main.command()
@click.option("--checkpoint", type=click.Path(dir_okay=False), required=True,
              help="A pcnet train checkpoint (best.pt or last.pt), read with torch.load(weights_only=True).")
@click.option("--out", "out_path", type=click.Path(dir_okay=False), required=True,
              help="The .onnx file to write; its metadata goes beside it as .json.")
@click.option("--overwrite", is_flag=True, help="Replace an existing --out file (and its .json).")
def export(checkpoint, out_path, overwrite):
    """Export a 3DPCNet checkpoint to ONNX (dynamic batch) with its .json metadata beside
    it (needs the [train] extra: torch)."""
    import_extra("torch", f'pcnet export needs torch: pip install "pcnet[train]"{TORCH_CPU}')
    from pcnet.models.export import export_checkpoint

    _new_output_file(out_path, "--out", overwrite, inputs=(checkpoint,), companions=(".json",),
                     written_by_pcnet=_exported_model)
    click.echo(f"wrote {export_checkpoint(checkpoint, out_path, replace=overwrite)}")


EXAMPLE_DIR = Path(__file__).parent / "example_data"


def _run_and_report(cfg, strict: bool = False) -> None:
    from pcnet.pipeline.runner import run_pipeline

    result = run_pipeline(cfg)
    try:
        click.echo(result.summary())
    except KeyboardInterrupt:  # a file-safety trial read "nothing half-written" for a complete output
        _stop_after_writing(f"--out {short_path(cfg.out)}", " (its report.md holds the summary)")
    if strict:
        _strict_exit(sum(f.is_warning for f in result.ranked_findings))


@main.command()
@click.option("--config", "config_path", type=click.Path(dir_okay=False), default=None,
              help="TOML file with the same fields; command-line options override it.")
@click.option("--video", type=click.Path(dir_okay=False), default=None, callback=_existing,
              help="The recorded video; alone (no --lifter-output), the embedded MediaPipe estimator makes the poses "
                   '(pip install "pcnet[video]").')
@click.option("--keypoints2d", type=click.Path(), default=None, callback=_existing,
              help="2D keypoint file (or OpenPose folder).")
@click.option("--keypoints2d-format", type=_RegisteredChoice(keypoint_formats), default=None,
              help="Which 2D detector wrote --keypoints2d (needed with it).")
@click.option("--lifter", type=_RegisteredChoice(lifter_names), default=None,
              help="Which 3D lifter wrote --lifter-output.")
@click.option("--lifter-output", type=click.Path(dir_okay=False), default=None, callback=_existing,
              help="The 3D lifter's output file (camera-frame poses).")
@click.option("--method", type=click.Choice(METHODS), default=None, help="Rectification method [pcnet].")
@click.option("--weights", type=click.Path(dir_okay=False), default=None, help="ONNX weights [shipped].")
@click.option("--mode", type=click.Choice(MODES), default=None,
              help="frame | sequence (static camera) | smooth (moving camera) | auto (static or moving by the "
                   "spread of the per-frame up) [sequence].")
@_heading_option
@_camera_prior_option
@_posture_option
@click.option("--height", type=_NUMBER, default=None, help="Subject height in metres: every lifter's output is scaled to it (normalised output gets metres; metric output is rescaled to this subject), by one factor from the median ankle-to-head chain, taken as H36M's share of stature (an individual's differs by several per cent); a skeleton without that chain's joints (Kinect v1 has no nose) cannot be, and a depth sensor's is in metres already.")
@click.option("--fps", type=_NUMBER, default=None,
              help="Frame rate when neither the video nor the input files give it.")
@click.option("--fps-override", is_flag=True, default=None,
              help="Use --fps even though it differs from the video's own rate.")
@click.option("--person", cls=_PersonOption, type=int, default=None)
@click.option("--confidence-threshold", type=_NUMBER, default=None, help="2D confidence below which 3D joints become NaN [0.3].")
@click.option("--cutoff-hz", type=_NUMBER, default=None, help="Butterworth low-pass cutoff [6 Hz].")
@click.option("--residual-cutoff", is_flag=True, default=None,
              help="Choose the cutoff by Winter's residual analysis of the recording instead of --cutoff-hz.")
@click.option("--align", type=click.Choice(ALIGN), default=None, help="How to match differing frame counts [none = error; an AlphaPose file that "
              "ends before the video and the 3D output is padded with undetected frames either way].")
@click.option("--pixel", is_flag=True, default=None, help="MotionBERT output made with --pixel.")
@click.option("--hypothesis", default=None, help="DDHPose: 'mean' or a hypothesis index.")
@click.option("--layout", default=None, help="generic lifter: joint layout of the file (h36m17, coco17, ...); kinect_v1: utd (UTD-MHAD's "
                   "order, a .npy's default) or sdk (the Kinect SDK's).")
@click.option("--axes", default=None, help="generic lifter: axis letters of the file, e.g. RDF (OpenCV), RUB.")
@click.option("--units", default=None, help="generic lifter: m, cm, mm, normalised or px.")
@click.option("--key", default=None, help="generic, kinect_v1 and azure_kinect lifters: array name inside an npz.")
@click.option("--delimiter", default=None, help="generic lifter: the CSV's column separator [,].")
@click.option("--measured-root", is_flag=True, default=None,
              help="generic lifter: the file's pelvis positions are a measured camera-frame path (metric units): "
                   "keep it and one floor for the recording.")
@click.option("--focal-px", type=_NUMBER, default=None,
              help="The camera's focal length in pixels: places the pelvis path from the 2D keypoints and turns "
                   "MediaPipe landmarks into the camera [a MediaPipe file's K, else a phone's 26 mm equivalent]. "
                   "From a 35 mm equivalent f35 on a WxH video: f35 * sqrt(W^2 + H^2) / 43.27 (docs/video.md).")
@click.option("--image-size", default=None,
              help="WIDTHxHEIGHT of the frames the 2D keypoints came from, without --video when the keypoint file "
                   "does not state it (AlphaPose, OpenPose): needed for the pelvis path from the 2D keypoints.")
@click.option("--roi", default=None,
              help="X,Y,W,H in pixels of the video as displayed, with --video alone: the embedded estimator follows "
                   "the person inside this region, not another one in view.")
@_camera_up_option
@click.option("--camera-up-from", type=click.Path(), default=None,
              help="DIR: an earlier `pcnet run` output folder of the same static camera, unmoved (a standing trial "
                   "before a floor exercise): its up, as --camera-up, with its 95 % interval.")
@click.option("--out", type=click.Path(), default=None, help="Output folder [pcnet_out].")
@click.option("--overwrite", is_flag=True, default=None, help="Replace an existing output folder.")
# on / off pairs, so that the command line overrides a --config file either way (a trial could not
# turn a file's `recording = false` back on)
@click.option("--recording/--no-recording", default=None, help="Write the rerun recording [on].")
@click.option("--plots/--no-plots", default=None,
              help="Write the PNG plots (wrists.png, angles.png, speeds.png) [on]; off speeds up batches of short "
                   "recordings.")
@click.option("--c3d/--no-c3d", default=None,
              help="Also write the markers as C3D (world.c3d or canonical.c3d; metric poses; "
                   "pip install \"pcnet[c3d]\") [off].")
@click.option("--opensim/--no-opensim", default=None,
              help="Also scale an OpenSim model and solve IK on the world-frame TRC (as `pcnet opensim OUT`), "
                   "published with the run's output [off].")
@click.option("--mass", type=_NUMBER, default=None, help="With --opensim: subject mass in kg.")
@click.option("--strict", is_flag=True, help=_STRICT_HELP)
def run(config_path, pixel, hypothesis, layout, axes, units, key, delimiter, measured_root, mass, strict, **options):
    """Run the pipeline on one recording: a video alone (the embedded MediaPipe estimator), or
    2D keypoints + a lifter's 3D output -> canonical poses, kinematics in the recording's world
    frame, CSV/TRC/NPZ/PNG exports and a rerun recording (with --opensim also OpenSim scaling
    and inverse kinematics)."""
    from pcnet.pipeline.config import (COMMAND_LINE, ESTIMATOR_LIFTER, check_lifter_options, load_run_config,
                                       parse_hypothesis, RunConfig)

    lifter_options = {k: v for k, v in (("pixel", pixel), ("layout", layout), ("axes", axes), ("units", units),
                                        ("key", key), ("delimiter", delimiter), ("measured_root", measured_root))
                      if v}
    if hypothesis is not None:
        lifter_options["hypothesis"] = parse_hypothesis(hypothesis)
    options["mass"] = mass
    if config_path:
        cfg = load_run_config(config_path, **options)
        if lifter_options:  # named as the flags they came from, then together with the file's
            cfg.lifter_options.update(check_lifter_options(COMMAND_LINE, cfg.lifter or ESTIMATOR_LIFTER,
                                                           lifter_options))
            cfg.validate(f"{config_path} with the command line's options")
    else:
        given = {k: v for k, v in options.items() if v is not None}
        cfg = RunConfig.from_values(COMMAND_LINE, {**given, "lifter_options": lifter_options})
    _run_and_report(cfg, strict)


@main.command()
@click.argument("page", required=False)
def docs(page):
    """The documentation's pages, as installed: without PAGE a list of them; with PAGE (as the
    outputs cite it, docs/guide/limits.md, or guide/limits, or limits) its text (Markdown)."""
    from pcnet.pipeline.doc_pages import find_page, pages, title

    if page is None:
        shipped = pages()
        width = max(map(len, shipped))
        for name, file in shipped.items():
            click.echo(f"{name:<{width}}  {title(file)}")
        click.echo("\npcnet docs PAGE prints one (pcnet docs guide/limits | less); the outputs cite them as "
                   "docs/PAGE.md")
        return
    _, file = find_page(page)
    click.echo(file.read_text(encoding="utf-8"), nl=False)


@main.command()
@click.option("--out", type=click.Path(), default="pcnet_demo", show_default=True)
@click.option("--method", type=click.Choice(METHODS), default="pcnet", show_default=True, help=_METHOD_HELP)
@click.option("--overwrite", is_flag=True, help="Replace an existing --out folder written by pcnet.")
def demo(out, method, overwrite):
    """The whole pipeline on the bundled real example (boxing video, AlphaPose Halpe-26,
    MotionBERT); scaled to an assumed 1.75 m subject."""
    from pcnet.pipeline.config import RunConfig
    from pcnet.pipeline.outdir import check_out_folder

    cfg = RunConfig(
        video=str(EXAMPLE_DIR / "boxing2.mp4"), keypoints2d=str(EXAMPLE_DIR / "alphapose-results.json"),
        keypoints2d_format="alphapose", lifter="motionbert", lifter_output=str(EXAMPLE_DIR / "X3D.npy"),
        out=out, method=method, height=1.75, overwrite=overwrite,
    )
    check_out_folder(out, (EXAMPLE_DIR,), overwrite)  # before the banner: a refusal is the only line
    click.echo("pcnet demo: boxing_motionbert (MotionBERT repository, Apache-2.0), subject height assumed 1.75 m")
    _run_and_report(cfg)


@main.command()
@click.argument("manifest", type=click.Path(dir_okay=False))
@click.option("--engine", type=click.Choice(ENGINES), default="local", show_default=True,
              help="local: worker processes on this machine; ray: one Ray task per row (pip install \"pcnet[ray]\")")
@click.option("--address", default=None, metavar="ADDR",
              help="with --engine ray: a running Ray cluster (host:port printed by `ray start --head`, or auto); "
                   "without it a local Ray instance is started")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="rows run at once  [default: this machine's CPU cores; with --address: the cluster's CPUs]")
@click.option("--retries", type=click.IntRange(min=0), default=0, show_default=True,
              help="times a row is started again when its worker process died (killed by the OS, out of memory)")
@click.option("--overwrite", is_flag=True, help="run every row again, replacing previous pcnet outputs")
@click.option("--retry-failed", is_flag=True,
              help="run only the rows that did not succeed in the previous run (read from its JSON summary)")
@click.option("--summary-json", type=click.Path(dir_okay=False), default=None,
              help="the JSON summary to write (and, with --retry-failed, to read); the Markdown report goes beside it, "
                   "its suffix .md  [default: MANIFEST + .pcnet_batch.json, e.g. runs.csv.pcnet_batch.json]")
def batch(manifest, engine, address, workers, retries, overwrite, retry_failed, summary_json):
    """Process many recordings: one CSV row each, columns named like the fields of
    `pcnet run` (lifter, lifter_output, keypoints2d, keypoints2d_format, video, out, ...).

    The whole manifest is checked before any row runs (one line per problem, exit 1). A
    failing row is reported and does not stop the others; a row whose output is complete
    and whose inputs, settings and pcnet version are unchanged is skipped. Prints a line per
    row and per warning as rows end, then the counts, the failed rows and the warnings one line
    each; writes a JSON summary and, beside it, a Markdown report with every row in full
    (runs.csv.pcnet_batch.md). Exit 0 when every row succeeded or was skipped, 1 when a row
    failed, 130 on Ctrl-C (running rows are stopped, nothing half-written is left).
    """
    from pcnet.pipeline.batch import BatchOptions, ManifestError, format_summary, run_batch
    from pcnet.pipeline.batch_ray import import_ray

    if address and engine != "ray":
        raise InputError(f"--address {address}: expected together with --engine ray, got --engine {engine}")
    if engine == "ray":
        import_ray()  # before any work: without Ray, one line saying how to get it
    options = BatchOptions(engine=engine, workers=workers, retries=retries, address=address, overwrite=overwrite,
                           retry_failed=retry_failed, summary_json=summary_json)
    try:
        report = run_batch(manifest, options, progress=lambda line: click.echo(line, err=True))
    except ManifestError as err:
        for line in err.lines:
            click.echo(f"Error: {line}", err=True)
        raise click.exceptions.Exit(1) from None
    click.echo(format_summary(report))
    if report.exit_code:
        raise click.exceptions.Exit(report.exit_code)


@main.command()
@click.argument("out_dir", type=click.Path())
@click.option("--height", type=_NUMBER, default=None,
              help="Subject height in metres, recorded in opensim_fit.json; default the run's `--height`, which scaled "
                   "the markers (another value, or one where the run had none, is refused).")
@click.option("--mass", type=_NUMBER, default=None, help="Subject mass in kg (sets the scaled model's total mass).")
@click.option("--static-trial", type=click.Path(), default=None,
              help="Scale on this static trial of the same subject instead of the recording: another `pcnet run` "
                   "output folder (its world.trc, e.g. the subject standing still; its --height must be the "
                   "recording's) or a marker file (.trc; one from elsewhere is taken at its own scale, unchecked).")
@click.option("--overwrite", is_flag=True, help="Replace earlier OpenSim outputs of pcnet in OUT_DIR.")
def opensim(out_dir, height, mass, static_trial, overwrite):
    """Scale an OpenSim model to the subject and solve inverse kinematics on OUT_DIR/world.trc
    (a `pcnet run` output with a static camera; pip install "pcnet[opensim]"). The model is
    scaled on the recording itself, or on a separate static trial (--static-trial).

    Writes OUT_DIR/scaled_model.osim, ik.mot, ik_marker_errors.sto and opensim_fit.json (the
    marker errors and the fit's warning, if any) and prints the marker RMS / max error and the
    IK speed, one line per warning and the outputs (stages/opensim_ik.py); the fit and its
    warnings in full go into the run's report.md.
    """
    from pcnet.pipeline.outdir import register_files, stale_staging
    from pcnet.stages.flags import note_finding, opensim_fit_findings, ranked
    from pcnet.stages.opensim_ik import import_opensim, opensim_fit_line, opensim_notes, OUTPUTS, scale_and_ik

    folder = Path(out_dir)
    if folder.is_file():  # an OpenSim user's reflex: the TRC itself
        raise InputError(f"{out_dir}: expected a `pcnet run` output folder, got a file: give its folder, "
                         f"{shlex.quote(str(folder.parent))}")
    if not folder.is_dir():
        raise InputError(f"{out_dir}: expected a `pcnet run` output folder, got no folder")
    trc = folder / "world.trc"
    if not trc.is_file():
        if (folder / "canonical.trc").is_file():
            raise InputError(f"{out_dir}: expected world.trc, got only canonical.trc: the run's frame or smooth mode "
                             f"(a moving camera) has no fixed world frame for IK; if the camera stood still, rerun "
                             f"`pcnet run` with --mode sequence (a camera that moved has no route to IK)")
        raise InputError(f"{out_dir}: expected world.trc (from `pcnet run` with a static camera and metric poses: "
                         f"a metric lifter or --height), got none")
    height = _subject_height(folder, height)
    static_trc = None if static_trial is None else _static_trial_trc(Path(static_trial), height)
    import_opensim()  # before any work: without OpenSim, one line saying how to get it

    for leftover in stale_staging(folder):  # of a killed `pcnet opensim` here
        shutil.rmtree(leftover, ignore_errors=True)
    # scale_and_ik refuses earlier outputs without --overwrite; with it, only pcnet's own go
    if overwrite:
        _refuse_foreign_outputs(out_dir, folder, OUTPUTS, "OpenSim")
    result = scale_and_ik(trc, folder, height, mass, static_trc=static_trc, overwrite=overwrite)
    details = _opensim_into_report(folder, result)
    # so that `pcnet run --overwrite` still recognises the whole folder as pcnet's output
    register_files(folder, (*OUTPUTS, details.name))
    click.echo(f"{'fit':<17} {opensim_fit_line(result, short=True)}")
    for f in ranked(opensim_fit_findings(result)):
        click.echo(f.terminal_line())
    for note in opensim_notes(result):
        click.echo(f"note     {note_finding(note).headline}")
    for name in OUTPUTS:
        click.echo(f"{name:<17} {result['outputs'][name]}")
    click.echo(f"details: {details}")


@main.command()
@click.argument("out_dirs", nargs=-1, required=True, type=click.Path(), metavar="OUT_DIR...")
@click.option("--table", type=click.Path(), default=None,
              help="Also write one row per OUT_DIR into this CSV (cadence, speed, per-foot means; why a recording "
                   "was refused): a study's table.")
@click.option("--overwrite", is_flag=True, help="Replace earlier gait outputs of pcnet in OUT_DIR (and --table).")
def gait(out_dirs, table, overwrite):
    """Gait events (foot strike, foot off) and spatiotemporal parameters of a walk or run in
    each OUT_DIR, a `pcnet run` output with a static camera (stages/gait.py: Zeni et al.
    2008's coordinate method on the world-frame ankles).

    Writes OUT_DIR/gait_events.csv (every event, with step and stride times, stance and step
    length), gait.json (per-foot means, cadence, walking speed), gait_cycles.csv and
    gait_cycles.png (hip and knee angles over each stride, 0-100 %), adds a Gait section to the
    run's report.md and prints cadence, speed and per-foot step length and stance. Step
    lengths and speed need the pelvis path (2D keypoints or a measured root) and metric poses.
    A folder that fails gets one line and the others go on; the exit status is then 1.
    """
    from pcnet.pipeline.gait import summary_row, TABLE_COLUMNS, table_written_by_pcnet

    if table is not None:
        _new_output_file(table, "--table", overwrite, written_by_pcnet=table_written_by_pcnet)
    rows, failed = [], 0
    for out_dir in out_dirs:
        if len(out_dirs) > 1:
            click.echo(f"{out_dir}:")
        try:
            result = _gait_of(Path(out_dir), overwrite)
            rows.append(summary_row(out_dir, result, None))
        except (InputError, OSError) as err:
            if len(out_dirs) == 1 and table is None:
                raise
            failed += 1
            click.echo(f"Error: {one_line(err)}", err=True)
            rows.append(summary_row(out_dir, None, one_line(err)))
    if table is not None:
        import csv
        import io

        from pcnet.stages.core.atomic import write_text

        text = io.StringIO()
        writer = csv.DictWriter(text, TABLE_COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        click.echo(f"{'table':<17} {write_text(table, text.getvalue())}")
    if failed:
        raise click.exceptions.Exit(1)


def _gait_of(folder: Path, overwrite: bool):
    """``pcnet gait`` on one run folder: analyse, write, report, print. Returns the
    :class:`pcnet.pipeline.gait.GaitResult`."""
    from pcnet.pipeline.gait import analyse, gait_markdown, OUTPUTS, REPORT_SECTION, write_gait
    from pcnet.pipeline.outdir import register_files

    if not folder.is_dir():
        raise InputError(f"{folder}: expected a `pcnet run` output folder, got "
                         + ("a file" if folder.exists() else "no folder"))
    result = analyse(folder)
    existing = [name for name in OUTPUTS if (folder / name).exists()]
    if existing and not overwrite:
        raise InputError(f"{folder}: expected no earlier gait outputs, got {', '.join(existing)}: pass --overwrite "
                         f"to replace them")
    _refuse_foreign_outputs(folder, folder, existing, "gait")
    written = write_gait(folder, result)
    details = _section_into_report(folder, REPORT_SECTION, gait_markdown(result)) or written["gait.json"]
    register_files(folder, (*OUTPUTS, details.name))
    summary, unit = result.summary, result.run.units
    click.echo(f"{'cadence':<17} {summary.cadence_steps_per_min:.1f} steps/min (stride {summary.stride_period_s:.2f} s)")
    if result.length_empty_because:
        click.echo(f"{'speed':<17} empty: {result.length_empty_because}")
    else:
        click.echo(f"{'speed':<17} {summary.walking_speed:.2f} {unit}/s")
    for side in ("left", "right"):
        s = getattr(summary, side)
        # an empty value as gait.json's null says it, not "nan" (a gait trial)
        stance = f"{s.stance_percent:.1f} %" if math.isfinite(s.stance_percent) else "empty"
        length = f"{s.step_length:.3f} {unit}" if math.isfinite(s.step_length) else "empty"
        click.echo(f"{side + ' foot':<17} {s.strikes} strikes, stance {stance} of stride, step length {length}")
    if result.backward_note:
        click.echo(f"{'note':<17} {result.backward_note}")
    for name, path in written.items():
        click.echo(f"{name:<17} {path}")
    click.echo(f"details: {details}")
    return result


def _refuse_foreign_outputs(shown, folder: Path, names, what: str) -> None:
    """Refuse ``--overwrite`` of a command's outputs ``names`` in the run folder ``folder``
    (named as ``shown``) where one exists that pcnet did not write or that changed since: it
    replaces only its own files."""
    from pcnet.pipeline.outdir import is_owned

    foreign = [name for name in names if (folder / name).exists() and not is_owned(folder, name)]
    if foreign:
        raise InputError(f"{shown}: --overwrite replaces only {what} outputs pcnet wrote, got {', '.join(foreign)} "
                         f"written or changed by someone else; move them away")


#: Two subject heights (m) no further apart than this are one height (heights are typed to the centimetre).
HEIGHT_AGREEMENT_M = 0.005


def _static_trial_trc(path: Path, height: float | None) -> Path:
    """The marker file of ``pcnet opensim --static-trial``: ``path`` itself (a ``.trc``) or a
    `pcnet run` output folder's ``world.trc``, whose run (where its ``canonical.npz`` says) must
    have scaled its markers to the recording's subject height ``height`` (m, ``None``: the
    recording's run had none). A ``.trc`` in a `pcnet run` output folder is that run's and is
    checked the same way (a study trial's folder was refused and its world.trc taken).

    Raises:
        InputError: neither exists, or the static run's height is not ``height``.
    """
    if path.is_file() and path.suffix.lower() == ".trc" and (path.parent / "canonical.npz").is_file():
        if path.name != "world.trc":
            raise InputError(f"--static-trial {path}: expected the run's world.trc (its world frame), got "
                             f"{path.name}; give the run's folder, {shlex.quote(str(path.parent))}")
        return _static_trial_trc(path.parent, height)
    if path.is_dir():
        if not (path / "world.trc").is_file():
            raise InputError(f"--static-trial {path}: expected a `pcnet run` output folder with world.trc (a static "
                             f"camera, metric poses), got a folder without one")
        if not (path / "canonical.npz").is_file():  # no run record: its height is unknown, as a .trc's
            return path / "world.trc"
        static_height = _subject_height(path, None)
        agree = static_height is None if height is None else (
            static_height is not None and abs(static_height - height) <= HEIGHT_AGREEMENT_M)
        if not agree:
            said, found = ("none" if h is None else f"{h:g} m" for h in (height, static_height))
            raise InputError(f"--static-trial {path}: expected a run scaled to the recording's subject height "
                             f"({said}: pcnet run --height), got {found}; re-run one of them with the other's --height")
        return path / "world.trc"
    if path.suffix.lower() != ".trc" or not path.is_file():
        raise InputError(f"--static-trial {path}: expected a `pcnet run` output folder or a .trc marker file, got "
                         + ("no such file or folder" if not path.exists() else f"a {path.suffix or 'suffix-less'} file"))
    return path


def _subject_height(folder: Path, height: float | None) -> float | None:
    """The subject height for ``pcnet opensim``: the run's (``canonical.npz``
    ``subject_height_m``, which scaled world.trc's markers), or ``None`` where the run had
    none. A ``height`` that contradicts the run's, or one given where the run had none, is
    refused: opensim_fit.json would record a subject the markers are not scaled to (user
    trials, sessions 58 and 60)."""
    import numpy as np

    from pcnet.adapters.validate import NumpyArchive, open_numpy

    npz = folder / "canonical.npz"
    run_height = float("nan")
    if npz.is_file():
        arrays = open_numpy(npz)  # a damaged or foreign file: one line naming it
        if not isinstance(arrays, NumpyArchive):
            raise InputError(f"{npz}: expected pcnet's canonical.npz archive, got a single .npy array")
        with arrays:
            if "subject_height_m" in arrays.files:
                value = arrays["subject_height_m"]
                if value.shape != () or value.dtype.kind not in "fiu":
                    raise InputError(f"{npz}: field 'subject_height_m': expected one number (metres), got shape "
                                     f"{value.shape} of {value.dtype}")
                run_height = float(value)
    if not np.isfinite(run_height):
        if height is not None:
            raise InputError(f"{folder}: --height: expected no height, as the run was given none (world.trc's markers "
                             f"keep the lifter's own scale), got {height:g}; re-run pcnet run --height {height:g} to "
                             f"scale them, or leave --height out")
        return None
    if height is not None and abs(height - run_height) > HEIGHT_AGREEMENT_M:
        raise InputError(f"{folder}: --height: expected the run's subject height, {run_height:g} m (pcnet run --height "
                         f"scaled world.trc's markers to it), got {height:g}; re-run pcnet run --height {height:g}, or "
                         f"leave --height out")
    return run_height


def _section_into_report(folder: Path, heading: str, markdown: str) -> Path | None:
    """``markdown`` (starting with the line ``heading``) as the last section of the run's
    report.md, replacing an earlier section of that heading (up to the next ``## ``); ``None``
    where that file is missing or not pcnet's (edited since), and the caller's own output
    holds the details. Returns the report's path."""
    from pcnet.pipeline.outdir import is_owned
    from pcnet.stages.core.atomic import write_text
    from pcnet.stages.sinks.report import REPORT_NAME

    report = folder.resolve() / REPORT_NAME
    if not is_owned(folder, REPORT_NAME):
        return None
    before, found, after = report.read_text(encoding="utf-8").partition(f"\n{heading}\n")
    later_sections = after[after.find("\n## "):] if found and "\n## " in after else ""
    return write_text(report, (before.rstrip() + "\n" + later_sections).rstrip() + "\n\n" + markdown)


def _opensim_into_report(folder: Path, result: dict) -> Path:
    """The fit and its warnings in full (:func:`pcnet.stages.opensim_ik.opensim_markdown`)
    as the last section of the run's report.md (:func:`_section_into_report`); where that
    file is missing or not pcnet's, opensim_fit.json, which holds the fit and its warnings,
    is the details' place. Returns the file holding the details."""
    from pcnet.stages.opensim_ik import opensim_markdown, REPORT_SECTION

    return (_section_into_report(folder, REPORT_SECTION, opensim_markdown(result))
            or Path(result["outputs"]["opensim_fit.json"]))


if __name__ == "__main__":
    sys.exit(main())
