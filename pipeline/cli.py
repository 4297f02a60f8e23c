"""The ``pcnet`` command line."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from pcnet.stages.rectify import METHODS


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
def main() -> None:
    """pcnet: rectify monocular 3D human poses into a gravity-aligned, body-centred frame."""


def _fail(message: str) -> None:
    raise click.ClickException(message)


@main.command()
@click.option("--method", type=click.Choice(METHODS), required=True)
@click.option("--data", type=click.Path(dir_okay=False), required=True, help="Mocap .npz (shared mocap format).")
@click.option("--split", type=click.Choice(["train", "val", "test", "all"]), default="test", show_default=True)
@click.option("--views", type=click.Choice(["paper", "wide"]), default="paper", show_default=True)
@click.option("--camera", type=click.Choice(["per-frame", "per-clip"]), default="per-frame", show_default=True)
@click.option("--noise/--no-noise", default=False, show_default=True, help="Upstream-like noise on the inputs.")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--max-frames", type=int, default=None, help="Evaluate at most N evenly spaced frames.")
@click.option("--weights", type=click.Path(dir_okay=False), default=None, help="ONNX weights (default: shipped).")
@click.option("--json", "json_out", type=click.Path(dir_okay=False), default=None, help="Also write the numbers here.")
def evaluate(method, data, split, views, camera, noise, seed, max_frames, weights, json_out):
    """Rotation/tilt/heading error and MPJPE/PA-MPJPE on mocap seen by synthetic cameras."""
    from pcnet.pipeline.evaluate import evaluate as run_eval, format_table
    from pcnet.stages.atomic import write_text

    try:
        result = run_eval(method, data, split, views, seed, max_frames, weights, camera, noise)
    except (OSError, ValueError) as err:
        _fail(str(err))
    click.echo(format_table(result))
    if json_out:
        write_text(json_out, json.dumps(result, indent=2) + "\n")


@main.command()
@click.argument("input_path", type=click.Path(dir_okay=False))
@click.option("--out", "out_path", type=click.Path(dir_okay=False), required=True)
@click.option("--method", type=click.Choice(METHODS), default="pcnet", show_default=True)
@click.option("--key", default=None, help="Array name inside an .npz input.")
@click.option("--weights", type=click.Path(dir_okay=False), default=None)
def rectify(input_path, out_path, method, key, weights):
    """Rectify (T,17,3) H36M-17 camera-frame poses (OpenCV axes) from a .npy/.npz file."""
    import numpy as np

    from pcnet.pipeline.io import load_pose_array
    from pcnet.stages.exports import write_npz
    from pcnet.stages.rectify import rectify as run_rectify

    try:
        joints = load_pose_array(input_path, key)
        res = run_rectify(joints, method, weights)
    except (OSError, ValueError) as err:
        _fail(str(err))
    write_npz(out_path, rotation=res.rotation, canonical=res.canonical, up=res.up, valid=res.valid,
              method=np.array(method))
    click.echo(f"{out_path}: {len(res.valid)} frames, {int(res.valid.sum())} valid, method {method}")


@main.command()
@click.option("--config", "config_path", type=click.Path(exists=True, dir_okay=False), required=True)
@click.option("--no-resume", is_flag=True, help="Start again even if a checkpoint exists.")
def train(config_path, no_resume):
    """Train 3DPCNet (needs the [train] extra: torch)."""
    from pcnet.models.train import load_config, train as run_train

    best = run_train(load_config(config_path), resume=not no_resume)
    click.echo(f"best checkpoint: {best}")


@main.command()
@click.option("--checkpoint", type=click.Path(exists=True, dir_okay=False), required=True)
@click.option("--out", "out_path", type=click.Path(dir_okay=False), required=True)
def export(checkpoint, out_path):
    """Export a checkpoint to ONNX (dynamic batch)."""
    from pcnet.models.export import export_onnx
    from pcnet.models.train import load_checkpoint

    path = export_onnx(load_checkpoint(checkpoint), out_path, {"checkpoint": str(checkpoint)})
    click.echo(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
