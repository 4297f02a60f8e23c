"""Skeleton vs wrist IMU: does the gravity estimate give the right wrist's specific force?

    python -m benchmarks.imu_check --data ../shared/data [--max-seqs N] [--cutoff 3]

Data: ``real/utd_mhad_imu/`` (UTD-MHAD, research licence, evaluation only: nothing of it is
copied into the repository; see ../shared/data/README.md): Kinect v1 skeletons (about 19 fps
effective) with a synchronised right-wrist accelerometer (50 Hz, +-8 g), 671 sequences,
21 actions, subjects standing about 3 m in front of a fixed sensor.

Per sequence:
1. the skeleton through the ``kinect_v1`` adapter (``adapters/kinect.py``) to H36M-17 in the
   OpenCV camera frame, pelvis subtracted for the up estimates (what the networks read);
2. the up direction in the camera frame per method:
   (a) ``level``: a level camera, up = -y_cv (what one assumes without rectification);
   (b) ``geometric``: ``rectify(method="geometric", mode="frame")`` (paper 2.3, per frame);
   (c) ``pcnet frame``: ``rectify(method="pcnet", mode="frame")`` (shipped weights, per frame);
   (d) ``pcnet sequence``: ``rectify(method="pcnet", mode="sequence")`` (static camera: one up);
3. the right wrist's acceleration ``a`` from the same code ``pcnet run`` uses
   (``compute_kinematics``: zero-phase 4th-order Butterworth at ``--cutoff`` Hz (default 3), then
   central differences) on the camera-frame poses; the camera is static, so this is an
   inertial frame and, for a fixed up, ``|a - g|`` is the same as in pcnet's world frame
   (``world_frame``/``to_world``: a rotation, +Y up). With ``g = -9.81 up`` (world: (0, -9.81, 0))
   the specific force is ``f = a - g`` and ``|f| / 9.81`` (g units) is what a wrist
   accelerometer reads in magnitude (1 g at rest). For the per-frame methods the up of
   each frame is used;
4. the IMU: ``|acc_g|`` after the same Butterworth on each axis;
5. the skeleton's ``|f|`` interpolated onto the IMU's 50 Hz time grid, shifted by the lag in
   [-0.2, 0.2] s (step 0.01 s) that maximises Pearson r for that method and sequence
   (the skeleton lags the IMU by about 0.03-0.06 s per the data README); the first and last
   0.2 s and samples within 0.1 s of a saturated IMU sample (|acc| >= 7.99 g on any axis)
   are excluded; then Pearson r and RMS difference (g).

Per action: the median over its sequences; overall: the median over all sequences. Also
``pcnet run``'s own world path for (d): ``world_frame`` + ``to_world`` with the sensor's
measured pelvis (``pcnet run --lifter kinect_v1`` keeps it: one floor for the recording) +
``compute_kinematics``, reported in
the JSON as ``pcnet sequence (to_world)``. And the angle between each method's up and
Kinect's approximate up (-y_cv; the sensor's tilt was not recorded, so this is a sanity
check, not an error).

Caveat: ``|a - g|`` depends on the up direction only through the cross term ``a . g``
(``|a - g|^2 = |a|^2 + g^2 - 2 a . g``), so an up error of a few degrees changes it little;
the methods are expected to differ little here. The IMU's orientation on the wrist is
unknown, so only magnitudes are compared.

Writes ``benchmarks/results/imu_check.json`` and ``docs/figures/imu_check.png`` and prints a
markdown table.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from benchmarks.report import SHARED_DATA
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = SHARED_DATA
RESULT = ROOT / "benchmarks" / "results" / "imu_check.json"
FIGURE = ROOT / "docs" / "figures" / "imu_check.png"

G = 9.81
METHODS = ("level", "geometric", "pcnet frame", "pcnet sequence")
LABELS = {"level": "(a) level camera", "geometric": "(b) geometric", "pcnet frame": "(c) pcnet frame",
          "pcnet sequence": "(d) pcnet sequence", "pcnet sequence (to_world)": "(d) via to_world"}
LAG_WINDOW_S = 0.2
LAG_STEP_S = 0.01
TRIM_S = 0.2
SATURATION_GUARD_S = 0.1
KINECT_UP = np.array([0.0, -1.0, 0.0])


def load_sequence(path: Path) -> dict:
    """One UTD-MHAD file: H36M-17 root-relative camera-frame joints ``(T, 17, 3)`` float64
    (metres, via :func:`pcnet.adapters.kinect.load_kinect_v1`), the sensor's measured pelvis
    ``root`` ``(T, 3)`` (camera frame, metres), ``fps`` (the effective skeleton rate), ``acc_g``
    ``(N, 3)`` (g), ``imu_fps``, ``saturated`` ``(N,)`` bool, and ids."""
    from pcnet.adapters.kinect import load_kinect_v1
    from pcnet.stages.core.conventions import PELVIS, fill_pelvis_from_hips, root_relative

    poses = load_kinect_v1(path)
    joints, _ = root_relative(poses.joints)
    root = fill_pelvis_from_hips(np.asarray(poses.joints, np.float64))[0][:, PELVIS]
    with np.load(path) as d:
        return {"name": path.stem, "joints": joints, "root": root, "fps": float(poses.fps), "acc_g": d["acc_g"].astype(np.float64),
                "imu_fps": float(d["imu_fps"]), "saturated": d["acc_saturated"].astype(bool),
                "action": int(d["action"]), "action_name": str(d["action_name"])}


def up_estimates(joints: np.ndarray, fps: float) -> dict[str, dict]:
    """Per method: ``up`` ``(T, 3)`` unit up in the camera frame (NaN where not valid) and the
    rotations ``R`` ``(T, 3, 3)`` / ``valid`` ``(T,)`` where a rectification ran; the same
    :func:`pcnet.pipeline.rectification.rectify` calls as ``pcnet run`` (default heading, camera prior)."""
    from pcnet.pipeline.rectification import rectify

    T = len(joints)
    out = {"level": {"up": np.tile(KINECT_UP, (T, 1)), "valid": np.ones(T, bool)}}
    for name, method, mode in (("geometric", "geometric", "frame"), ("pcnet frame", "pcnet", "frame"),
                               ("pcnet sequence", "pcnet", "sequence")):
        res = rectify(joints, method, mode=mode, fps=fps)
        out[name] = {"up": np.where(res.valid[:, None], res.up, np.nan), "R": res.rotation, "valid": res.valid}
    return out


def wrist_specific_force(joints: np.ndarray, up: np.ndarray, fps: float, cutoff_hz: float) -> np.ndarray:
    """``|a - g| / 9.81`` ``(T,)`` of the right wrist, g units: ``a`` from
    :func:`pcnet.stages.kinematics.filtered_derivatives` (``compute_kinematics``' Butterworth
    ``cutoff_hz`` and central differences, which take Y-up poses) of camera-frame ``joints``
    ``(T, 17, 3)`` (static camera), ``g = -9.81 up`` with ``up`` ``(T, 3)`` or ``(3,)`` in the
    camera frame. NaN where either is missing."""
    from pcnet.stages.core.conventions import R_WRIST
    from pcnet.stages.kinematics import filtered_derivatives

    a = filtered_derivatives(np.asarray(joints, np.float64)[:, R_WRIST], fps, cutoff_hz)[3]
    return np.linalg.norm(a + G * np.asarray(up, np.float64), axis=-1) / G


def wrist_specific_force_world(joints: np.ndarray, root: np.ndarray, R: np.ndarray, valid: np.ndarray, fps: float,
                               cutoff_hz: float) -> np.ndarray:
    """The same through ``pcnet run``'s world path: :func:`pcnet.stages.world_frame.world_frame`
    and :func:`~pcnet.stages.world_frame.to_world` with the measured pelvis ``root`` ``(T, 3)``
    (+Y up, one floor at y = 0), then ``compute_kinematics``; ``|a - (0, -9.81, 0)| / 9.81`` ``(T,)``."""
    from pcnet.stages.core.conventions import R_WRIST
    from pcnet.stages.kinematics import compute_kinematics
    from pcnet.stages.world_frame import to_world, world_frame

    world = to_world(joints, world_frame(R, valid, fps), root_cam=root)
    a = compute_kinematics(world, fps, cutoff_hz, check_up=False).acceleration[:, R_WRIST]
    return np.linalg.norm(a - np.array([0.0, -G, 0.0]), axis=-1) / G


def imu_magnitude(acc_g: np.ndarray, imu_fps: float, cutoff_hz: float) -> np.ndarray:
    """``|acc|`` ``(N,)`` in g after the same Butterworth on each axis."""
    from pcnet.stages.kinematics import butterworth_lowpass

    return np.linalg.norm(butterworth_lowpass(acc_g, imu_fps, cutoff_hz), axis=-1)


def compare(skel: np.ndarray, fps: float, imu: np.ndarray, imu_fps: float, saturated: np.ndarray) -> dict:
    """Best-lag comparison of a skeleton signal ``(T,)`` at ``fps`` with an IMU signal
    ``(N,)`` at ``imu_fps``: the skeleton is linearly interpolated at ``t + lag`` on the IMU
    grid for each lag in +-:data:`LAG_WINDOW_S`; the lag with the largest Pearson r wins.

    Returns:
        ``{"r", "rms_g", "lag_s", "samples", "t", "skeleton", "imu"}``: r and RMS of
        ``skeleton - imu`` at the best lag over the kept samples (trimmed ends, saturation
        guard, finite), and the aligned series (for the figure). NaN r when fewer than 20
        samples remain.
    """
    t_sk = np.arange(len(skel)) / fps
    t_imu = np.arange(len(imu)) / imu_fps
    guard = int(round(SATURATION_GUARD_S * imu_fps))
    sat = np.convolve(saturated.astype(float), np.ones(2 * guard + 1), mode="same") > 0
    keep_base = (t_imu >= TRIM_S) & (t_imu <= t_imu[-1] - TRIM_S) & ~sat
    ok = np.isfinite(skel)
    best = {"r": np.nan, "rms_g": np.nan, "lag_s": np.nan, "samples": 0}
    if ok.sum() < 4:
        return best
    for lag in np.arange(-LAG_WINDOW_S, LAG_WINDOW_S + 1e-9, LAG_STEP_S):
        ts = t_imu + lag
        s = np.interp(ts, t_sk[ok], skel[ok], left=np.nan, right=np.nan)
        # no interpolation across a missing (NaN) skeleton sample
        near = np.interp(ts, t_sk, (~ok).astype(float), left=1.0, right=1.0) == 0
        keep = keep_base & near & np.isfinite(s) & np.isfinite(imu)
        if keep.sum() < 20:
            continue
        r = float(np.corrcoef(s[keep], imu[keep])[0, 1])
        if not np.isfinite(best["r"]) or r > best["r"]:
            best = {"r": r, "rms_g": float(np.sqrt(np.mean((s[keep] - imu[keep]) ** 2))), "lag_s": float(round(lag, 3)),
                    "samples": int(keep.sum()), "t": t_imu[keep], "skeleton": s[keep], "imu": imu[keep]}
    return best


def evaluate_sequence(seq: dict, cutoff_hz: float) -> dict:
    """All methods for one loaded sequence (:func:`load_sequence`): per method r, RMS (g),
    lag (s), samples, up angle to -y_cv (deg, median over frames) and the aligned series."""
    from pcnet.stages.core.rotations import angle_between

    ups = up_estimates(seq["joints"], seq["fps"])
    imu = imu_magnitude(seq["acc_g"], seq["imu_fps"], cutoff_hz)
    out = {}
    for name in METHODS:
        u = ups[name]["up"]
        f = wrist_specific_force(seq["joints"], u, seq["fps"], cutoff_hz)
        row = compare(f, seq["fps"], imu, seq["imu_fps"], seq["saturated"])
        good = np.isfinite(u).all(axis=1)
        row["up_vs_kinect_deg"] = float(np.median(np.degrees(angle_between(u[good], KINECT_UP[None])))) if good.any() else np.nan
        row["valid_frames"] = int(good.sum())
        out[name] = row
    seq_est = ups["pcnet sequence"]
    if seq_est["valid"].any():
        f = wrist_specific_force_world(seq["joints"], seq["root"], seq_est["R"], seq_est["valid"], seq["fps"], cutoff_hz)
        out["pcnet sequence (to_world)"] = compare(f, seq["fps"], imu, seq["imu_fps"], seq["saturated"])
    return out


def _jsonable(x):
    """Floats rounded to 4 decimals, NaN as None (strict JSON), recursively."""
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return round(float(x), 4) if np.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    return x


def _median(values) -> float:
    v = np.asarray([x for x in values if np.isfinite(x)], float)
    return float(np.median(v)) if len(v) else float("nan")


def summarise(rows: list[dict], methods) -> dict:
    """Per action and overall medians over sequences of r, RMS and lag per method."""
    summary: dict = {"per_action": {}, "overall": {}}
    actions = sorted({(r["action"], r["action_name"]) for r in rows})
    groups = [(f"{a:02d} {n}", [r for r in rows if r["action"] == a]) for a, n in actions] + [("overall", rows)]
    for label, group in groups:
        entry = {"sequences": len(group)}
        for m in methods:
            res = [g["methods"][m] for g in group if m in g["methods"]]
            entry[m] = {"r": _median([x["r"] for x in res]), "rms_g": _median([x["rms_g"] for x in res]),
                        "lag_s": _median([x["lag_s"] for x in res]),
                        "mean_r": float(np.nanmean([x["r"] for x in res])) if res else float("nan")}
            if "up_vs_kinect_deg" in (res[0] if res else {}):
                ang = [x["up_vs_kinect_deg"] for x in res]
                entry[m]["up_vs_kinect_deg_median"] = _median(ang)
                entry[m]["up_vs_kinect_deg_p95"] = float(np.nanpercentile(ang, 95))
        if label == "overall":
            summary["overall"] = entry
        else:
            summary["per_action"][label] = entry
    return summary


def markdown_table(summary: dict, methods=METHODS) -> str:
    """Per-action rows, r and RMS (g) per method, then the overall median row."""
    head = "| action | n | " + " | ".join(f"r {LABELS[m]} | RMS {LABELS[m]}" for m in methods) + " |"
    sep = "|---|---:|" + "---:|---:|" * len(methods)
    lines = [head, sep]
    items = list(summary["per_action"].items()) + [("**overall (median)**", summary["overall"])]
    for label, e in items:
        cells = " | ".join(f"{e[m]['r']:.2f} | {e[m]['rms_g']:.3f}" for m in methods)
        lines.append(f"| {label} | {e['sequences']} | {cells} |")
    return "\n".join(lines)


def plot_clip(name: str, clip: dict, path: Path, cutoff_hz: float) -> None:
    """Normalised (z-scored) |f| per method and the IMU's |acc| of one clip, each method at
    its own best lag (IMU time axis)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 4.2), dpi=120)
    colours = {"level": "tab:blue", "geometric": "tab:green", "pcnet frame": "tab:red", "pcnet sequence": "tab:orange"}
    imu_plotted = False
    for m in METHODS:
        row = clip[m]
        if "t" not in row:
            continue
        z = lambda x: (x - x.mean()) / (x.std() or 1.0)  # noqa: E731
        if not imu_plotted:
            ax.plot(row["t"], z(row["imu"]), "--", color="tab:purple", lw=2.0, label="IMU |acc| (right wrist)")
            imu_plotted = True
        ax.plot(row["t"], z(row["skeleton"]), color=colours[m], lw=1.3,
                label=f"{LABELS[m]}: r {row['r']:.2f}, lag {row['lag_s']:+.2f} s")
    ax.set_xlabel("time (s, IMU clock)")
    ax.set_ylabel("normalised |specific force| (z-score, unitless)")
    ax.set_title(f"UTD-MHAD {name}: right-wrist |a - g| from the Kinect skeleton vs IMU (low-pass {cutoff_hz:g} Hz)",
                 fontsize=9)
    ax.legend(fontsize=7, loc="upper right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def select_files(folder: Path, max_seqs: int | None) -> list[Path]:
    """The sequence files, evenly spaced over the sorted list when ``max_seqs`` is given."""
    files = sorted(folder.glob("a*_s*_t*.npz"))
    if max_seqs is not None and max_seqs < len(files):
        keep = np.unique(np.linspace(0, len(files) - 1, max_seqs).round().astype(int))
        files = [files[i] for i in keep]
    return files


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT, help="the shared data folder (holds real/utd_mhad_imu)")
    ap.add_argument("--max-seqs", type=int, default=None, help="evenly spaced subset (default: all 671)")
    ap.add_argument("--cutoff", type=float, default=3.0, help="Butterworth -3 dB cutoff (Hz) for skeleton and IMU")
    ap.add_argument("--clip", default="a05_s1_t1", help="sequence drawn in the figure")
    ap.add_argument("--out", type=Path, default=RESULT)
    ap.add_argument("--figure", type=Path, default=FIGURE)
    args = ap.parse_args(argv)
    folder = args.data / "real" / "utd_mhad_imu"
    if not folder.is_dir():
        sys.exit(f"{folder} not found: this benchmark needs ../shared/data (UTD-MHAD, evaluation only)")
    files = select_files(folder, args.max_seqs)
    if args.clip and (folder / f"{args.clip}.npz").exists() and args.clip not in {f.stem for f in files}:
        files.append(folder / f"{args.clip}.npz")
    t0 = time.perf_counter()
    rows, clip = [], None
    for i, path in enumerate(files):
        seq = load_sequence(path)
        res = evaluate_sequence(seq, args.cutoff)
        if path.stem == args.clip:
            clip = res
        rows.append({"name": seq["name"], "action": seq["action"], "action_name": seq["action_name"],
                     "methods": {m: {k: v for k, v in r.items() if k not in ("t", "skeleton", "imu")}
                                 for m, r in res.items()}})
        if (i + 1) % 50 == 0:
            print(f"  {i + 1}/{len(files)} sequences, {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    all_methods = METHODS + ("pcnet sequence (to_world)",)
    summary = summarise(rows, all_methods)
    wall = time.perf_counter() - t0
    command = "python -m benchmarks.imu_check --data ../shared/data" + (
        f" --max-seqs {args.max_seqs}" if args.max_seqs else "") + (f" --cutoff {args.cutoff:g}" if args.cutoff != 3.0 else "")
    table = markdown_table(summary)
    ov = summary["overall"]
    lines = [f"    {command}", "",
             f"{len(rows)} sequences, low-pass {args.cutoff:g} Hz, lag window +-{LAG_WINDOW_S} s; "
             "median over sequences of Pearson r and RMS (g) between the skeleton's right-wrist |a - g| and the IMU's |acc|.",
             "", table, "",
             "Best lag (s, median; + = skeleton later): " + ", ".join(
                 f"{LABELS[m]} {ov[m]['lag_s']:+.2f}" for m in all_methods),
             "pcnet run's own world path for (d) (to_world with the measured pelvis, one floor): "
             f"r {ov['pcnet sequence (to_world)']['r']:.2f}, RMS {ov['pcnet sequence (to_world)']['rms_g']:.3f} g",
             "Up vs Kinect's approximate up (-y_cv), deg, median [p95] over sequences: " + ", ".join(
                 f"{LABELS[m]} {ov[m]['up_vs_kinect_deg_median']:.1f} [{ov[m]['up_vs_kinect_deg_p95']:.1f}]"
                 for m in METHODS),
             f"run time {wall:.0f} s"]
    print("\n".join(lines))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    meta = {"command": command, "cutoff_hz": args.cutoff, "lag_window_s": LAG_WINDOW_S, "lag_step_s": LAG_STEP_S,
            "trim_s": TRIM_S, "saturation_guard_s": SATURATION_GUARD_S, "sequences": len(rows),
            "wall_s": round(wall, 1), "methods": {m: LABELS[m] for m in all_methods},
            "data": "UTD-MHAD real/utd_mhad_imu (research licence, evaluation only; not redistributed)",
            "notes": "medians over sequences; r = Pearson, rms_g = RMS(|f|_skeleton - |acc|_imu) in g; lag_s > 0: "
                     "skeleton later; per_sequence holds metrics only, no data arrays; NaN written as null",
            "summary": _jsonable(summary)}
    # the per-sequence metrics one line each, so the file stays small and diffable
    text = json.dumps(meta, indent=1)[:-2] + ',\n "per_sequence": [\n' + ",\n".join(
        "  " + json.dumps(_jsonable(r), separators=(",", ":")) for r in rows) + "\n ]\n}\n"
    args.out.write_text(text)
    if clip is not None:
        plot_clip(args.clip, clip, args.figure, args.cutoff)
        print(f"wrote {args.out} and {args.figure}")
    else:
        print(f"wrote {args.out} (figure clip {args.clip} not found)")


if __name__ == "__main__":
    main()
