"""pcnet's output sinks, each a function of arrays and a path, written atomically and in blocks
of frames for long recordings: NPZ, kinematics CSV, TRC and C3D (:mod:`.exports`), BVH
(:mod:`.bvh`), PNG plots (:mod:`.plots`), the rerun recording (:mod:`.rerun_log`).
docs/outputs.md describes every file, column and key."""
