"""OpenSim scaling of the pelvis: by the hip width on every axis (A, shipped until decision 0087)
or by the hip width across and the trunk's hip-to-shoulder length up and forward (B, shipped).

    python -m benchmarks.opensim_pelvis_scaling [--data ../shared/data] [--clips 20] [--max-frames 300]

Why. ``Scaling_Setup_H36M17.xml`` scaled the ``pelvis`` and ``sacrum`` bodies on X, Y and Z by
the hip-centre distance, and the ``torso`` by the hip-to-shoulder distance. A lifter whose hip
centres lie wider apart than the model's (VideoPose3D and MotionBERT on real video: hip width /
hip-to-shoulder 0.5-0.6 against the model's 0.32, a user trial) gets a pelvis 1.5 times too
tall, so the model's hip-to-shoulder chain is longer than the subject's and inverse kinematics
can only shorten it by folding at L5_S1: ``pelvis_tilt`` +28 deg, ``L5_S1_Flex_Ext`` -57 deg on a
standing Tadasana, with a marker RMS under 2 cm and no warning. The alternative arm (B) scales
the pelvis and sacrum across (Z) by the hip width only, and up and forward (X, Y) by the
torso's own hip-to-shoulder measurement, so the chain keeps the subject's length.

Recordings (each written once as a TRC, then fitted by both setups with the shipped
:func:`pcnet.stages.opensim_ik.scale_and_ik`; arm A is written from the shipped setup file by
:func:`hip_width_setup`, everything else in it the shipped one):
- real lifter output (validation: looked at in the user trial): ``pcnet demo`` (boxing,
  MotionBERT) and every real VideoPose3D Tadasana and Trikonasana file (standing on both feet,
  a world frame), each through ``pcnet run --lifter videopose3d --fps 30`` (its world.trc);
- mocap: the Bandai motion-style test clips and the CMU validation subjects of
  ``benchmarks/isb_opensim_agreement.py`` (same clips, frames and floor frame).

Per set, for the thigh-to-thorax flexion (pcnet's ``hip_flexion + trunk_flexion_to_pelvis``
against OpenSim's ``hip_flexion - L5_S1_Flex_Ext``, both sides pooled; the one sagittal angle
both tools measure from joint centres, docs/benchmarks/kinematics.md): MAE (deg), the median
over recordings of the recording's |bias|, the centred MAE; the medians of ``pelvis_tilt`` and
``L5_S1_Flex_Ext``; the median IK marker RMS (cm).

Rule (decision 0087, written before the run): B ships if (1) on the real lifter recordings the
thigh-to-thorax MAE is lower than A's, and (2) on each mocap set B's thigh-to-thorax MAE is at
most A's + 1.0 deg, its centred MAE at most A's + 0.5 deg, and on every set the median marker
RMS at most A's + 0.5 cm.

Writes benchmarks/results/opensim_pelvis_scaling.txt.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.isb_opensim_agreement import PAIRS, _wrap, compare_recording, mocap_trcs, pair_values, run_demo
from benchmarks.report import SHARED_DATA, print_and_save

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "opensim_pelvis_scaling.txt"
ASANAS = ("Tadasana", "Trikonasana")
THIGH_THORAX = [p for p in PAIRS if p[0].startswith("thigh / thorax")]


def hip_width_setup(shipped: Path, out: Path) -> Path:
    """A copy of the shipped setup folder (arm B since decision 0087) whose scaling file is
    arm A, the setup before it: the ``pelvis`` measurement scales ``pelvis`` and ``sacrum`` on
    X, Y and Z, and the ``torso`` measurement scales neither."""
    out.mkdir(parents=True)
    for f in shipped.iterdir():
        if f.is_file():
            (out / f.name).write_bytes(f.read_bytes())
    setup = out / "Scaling_Setup_H36M17.xml"
    text = setup.read_text()
    pelvis = re.search(r'<Measurement name="pelvis">.*?</Measurement>', text, re.S)
    torso = re.search(r'<Measurement name="torso">.*?</Measurement>', text, re.S)
    if pelvis is None or torso is None:
        raise RuntimeError(f"{setup}: no pelvis or torso measurement")
    old_pelvis = pelvis.group(0).replace("<axes> Z</axes>", "<axes> X Y Z</axes>")
    old_torso = re.sub(r'\s*<BodyScale name="(?:pelvis|sacrum)">\s*<axes> X Y</axes>\s*</BodyScale>', "", torso.group(0))
    if old_pelvis.count("<axes> X Y Z</axes>") != 2 or "pelvis" in old_torso or "sacrum" in old_torso:
        raise RuntimeError(f"{setup}: its layout changed; arm A could not be written")
    setup.write_text(text.replace(pelvis.group(0), old_pelvis).replace(torso.group(0), old_torso))
    return out


def real_trcs(data: Path, tmp: Path) -> list[tuple[str, Path]]:
    """``(name, world.trc)``: the demo, then every real VideoPose3D file of :data:`ASANAS`."""
    recs = [("demo", run_demo(tmp)[0])]
    folder = data / "real" / "yoga_videopose3d"
    for asana in ASANAS:
        for f in sorted(folder.glob(f"export_*_{asana}.npy")):
            out = tmp / f.stem
            subprocess.run([sys.executable, "-m", "pcnet.pipeline.entry", "run", "--lifter", "videopose3d",
                            "--lifter-output", str(f), "--fps", "30", "--no-recording", "--out", str(out)],
                           check=True, capture_output=True, text=True)
            if (out / "world.trc").is_file():
                recs.append((f.stem.removeprefix("export_"), out / "world.trc"))
    return recs


def fit(osim, trc: Path, work: Path) -> dict:
    """One recording under the setup now in ``pcnet.stages.opensim_ik.DATA_DIR``: the
    thigh-to-thorax differences (deg, both sides), the median pelvis tilt and L5_S1 flexion
    (deg) and the marker RMS (cm)."""
    pc, ov, res = compare_recording(osim, trc, work)
    d = np.concatenate([_wrap(a - b) for a, b in (pair_values(pc, ov, col, coord, sign)
                                                   for _, col, coord, sign in THIGH_THORAX)])
    return {"d": d, "pelvis_tilt": float(np.nanmedian(ov["pelvis_tilt"])), "L5": float(np.nanmedian(ov["L5_S1_Flex_Ext"])),
            "rms_cm": 100 * res["marker_rms_m"]}


def summary(fits: list[dict]) -> dict[str, float]:
    d = np.concatenate([f["d"] for f in fits])
    centred = np.concatenate([f["d"] - f["d"].mean() for f in fits])
    return {"mae": float(np.mean(np.abs(d))), "bias": float(np.median([abs(f["d"].mean()) for f in fits])),
            "centred": float(np.mean(np.abs(centred))), "pelvis_tilt": float(np.median([f["pelvis_tilt"] for f in fits])),
            "L5": float(np.median([f["L5"] for f in fits])), "rms_cm": float(np.median([f["rms_cm"] for f in fits]))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(SHARED_DATA))
    ap.add_argument("--clips", type=int, default=20, help="clips per mocap data set (as isb_opensim_agreement)")
    ap.add_argument("--max-frames", type=int, default=300)
    args = ap.parse_args()
    from pcnet.stages import opensim_ik
    from pcnet.stages.opensim_ik import import_opensim

    data = Path(args.data)
    if not (data / "real" / "yoga_videopose3d").is_dir():
        sys.exit(f"--data {data}: expected real/yoga_videopose3d in it, got no such folder")
    t0 = time.perf_counter()
    osim = import_opensim()
    shipped = opensim_ik.DATA_DIR
    command = "python -m benchmarks.opensim_pelvis_scaling" + "".join(f" {a}" for a in sys.argv[1:])
    lines = [f"    {command}", "",
             "A: pelvis and sacrum scaled on X Y Z by the hip width (the setup before decision 0087); B: on Z by the "
             "hip width, on X Y by the torso's hip-to-shoulder measurement. Thigh-to-thorax flexion, pcnet - OpenSim "
             "(deg): MAE, median |recording bias|, centred MAE; medians of pelvis_tilt and L5_S1_Flex_Ext (deg) and "
             "of the IK marker RMS (cm).", ""]
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        arms = {"A": hip_width_setup(shipped, tmp / "setup_A"), "B": shipped}
        sets = [("real lifter output (demo, VideoPose3D Tadasana and Trikonasana)", real_trcs(data, tmp))]
        sets += mocap_trcs(data, args.clips, args.max_frames, tmp)
        verdicts = []
        for label, recs in sets:
            fits = {}
            for arm, folder in arms.items():
                opensim_ik.DATA_DIR = folder
                try:
                    fits[arm] = [fit(osim, trc, tmp / f"ik_{arm}_{label.split()[0]}_{k}") for k, (_, trc) in enumerate(recs)]
                finally:
                    opensim_ik.DATA_DIR = shipped
            block = [f"## {label}: {len(recs)} recordings", "",
                     "| arm | MAE | median abs bias | centred MAE | pelvis_tilt | L5_S1_Flex_Ext | marker RMS cm |",
                     "|---|---:|---:|---:|---:|---:|---:|"]
            s = {arm: summary(f) for arm, f in fits.items()}
            for arm, v in s.items():
                block.append(f"| {arm} | {v['mae']:.2f} | {v['bias']:.2f} | {v['centred']:.2f} | {v['pelvis_tilt']:+.1f} | "
                             f"{v['L5']:+.1f} | {v['rms_cm']:.2f} |")
            block += ["", "Per recording, bias A / B (deg), pelvis_tilt A / B: " + "; ".join(
                f"{name} {a['d'].mean():+.1f} / {b['d'].mean():+.1f}, {a['pelvis_tilt']:+.0f} / {b['pelvis_tilt']:+.0f}"
                for (name, _), a, b in zip(recs, fits["A"], fits["B"])), ""]
            a, b = s["A"], s["B"]
            rms_ok = b["rms_cm"] <= a["rms_cm"] + 0.5
            if label.startswith("real"):
                ok = b["mae"] < a["mae"] and rms_ok
                verdicts.append((label, ok, f"MAE {a['mae']:.2f} -> {b['mae']:.2f} (must fall), marker RMS "
                                            f"{a['rms_cm']:.2f} -> {b['rms_cm']:.2f} (<= +0.5)"))
            else:
                ok = b["mae"] <= a["mae"] + 1.0 and b["centred"] <= a["centred"] + 0.5 and rms_ok
                verdicts.append((label, ok, f"MAE {a['mae']:.2f} -> {b['mae']:.2f} (<= +1.0), centred {a['centred']:.2f} -> "
                                            f"{b['centred']:.2f} (<= +0.5), marker RMS {a['rms_cm']:.2f} -> "
                                            f"{b['rms_cm']:.2f} (<= +0.5)"))
            print(f"{label}: done ({time.perf_counter() - t0:.0f} s)", flush=True)
            lines += block
    lines += ["## Verdict (decision 0087's rule)", ""] + [f"- {label}: {'met' if ok else 'FAILED'}: {why}"
                                                         for label, ok, why in verdicts]
    lines += ["", f"B ships: {'yes' if all(ok for _, ok, _ in verdicts) else 'no'}", "",
              f"Runtime: {time.perf_counter() - t0:.0f} s"]
    print_and_save(lines, RESULTS)


if __name__ == "__main__":
    main()
