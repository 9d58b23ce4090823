"""The replication side of uw3p: one script per figure of the paper (``python -m experiments``),
the studies behind REPRODUCTION.md and INSTRUMENT.md, and the benchmark
(``python -m experiments.benchmark``, with :mod:`experiments.benchmark_report`). Test and
benchmark helpers that need the ``[test]`` extra (:mod:`experiments.synthetic_photo`) live here,
not in the production packages.

Nothing is re-exported: import the modules themselves.
"""

__all__: list[str] = []
