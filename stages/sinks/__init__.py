"""pcnet's output sinks, in one place. :mod:`.result`: :class:`~.result.RecordingResult`, the one
object every sink reads, and the sinks as functions of it (``write_kinematics_table``,
``write_arrays``, ``write_motion_files``, ``write_figures``, ``write_rerun``). Beneath them the
array-level writers, each atomic and in blocks of frames for long recordings: NPZ, kinematics
CSV, TRC and C3D (:mod:`.exports`), BVH (:mod:`.bvh`), PNG plots (:mod:`.plots`), the rerun
recording (:mod:`.rerun_log`). docs/outputs.md describes every file, column and key."""
