"""The benchmark scripts, run from the repository root as ``python -m benchmarks.NAME``.

Not part of the installed ``pcnet`` package: the index of what each script measures, the data
it needs and the result file it writes is benchmarks/README.md (docs/benchmarks/scripts.md).
"""
