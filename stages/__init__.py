"""pcnet.stages: the geometry core (:mod:`pcnet.stages.core`: conventions, rotations,
canonical frame, metrics, geometric baseline) and the array stages and sinks built on it
(remap, sequence modes, heading, world frame, kinematics, ISB angles, flags, exports, BVH,
plots, rerun logging, OpenSim)."""
