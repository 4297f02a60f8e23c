"""pcnet's geometry core: joint layout and frames (docs/CONVENTIONS.md), rotations, the
canonical frame, metrics, the geometric baseline, the error type and atomic writes.

Every room imports it; it imports nothing else of pcnet (docs/architecture.md,
tests/test_architecture.py).
"""
