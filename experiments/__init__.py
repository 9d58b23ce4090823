"""The replication side of uw3p: one script per figure of the paper (``python -m experiments``),
the studies behind REPRODUCTION.md and INSTRUMENT.md, and the benchmark
(``python -m experiments.benchmark``, with :mod:`experiments.benchmark_report`).

It runs from the repository (``python -m experiments``, ``uw3p figures`` in a checkout), not
from the wheel: the installed package is ``forward``, ``sca``, ``measure``, ``uw3p`` and
``uw3p_data`` (decision 0082-installed-packages). What the library and the command line need
(the synthetic photographs of the doctests and ``uw3p warm``: :mod:`measure.synthetic_photo`)
lives in those packages and is imported from there.

Nothing is re-exported: import the modules themselves.
"""

__all__: list[str] = []
