"""pcnet.stages: pure array transforms (conventions, rotation maths, canonical frame,
geometric baseline, metrics, remap, rectify, kinematics, exports, rerun logging)."""
