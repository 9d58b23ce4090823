"""Build the caches a first run would otherwise build: ``python -m uw3p.warm`` (``make install``
runs it).

numba compiles the package's kernels on first use and caches them on disk (beside the modules,
or in numba's cache folder), and the certified quadrature of the default camera is fitted on first
use and cached on disk (:func:`sca.quadrature.cache_dir`); a first ``uw3p measure`` after an
install paid about a minute and a half for them. This runs the workloads that compile and build
them, small: one chart's fit and a batch (the serial and parallel kernels), and, where ``pidng``
can write a DNG (the ``[test]`` extra), a photograph measured whole. Every cache it fills is keyed
on the code and numbers it holds, so nothing it builds can be stale.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

__all__ = ["main", "warm"]


def warm(out=sys.stdout) -> float:
    """Run the small workloads that build the caches; returns the seconds taken.

    Parameters
    ----------
    out : text stream, optional
        Where a line per step is written.

    Returns
    -------
    float
    """
    import numpy as np

    import forward
    import sca
    from sca.projection import SERIAL_BELOW

    t0 = time.perf_counter()
    sim = forward.simulate_chart(1.0, 0.1, 5.0, 1.5, seed=0)
    sca.estimate(sim.rgb, depth=5.0, distance=1.5, sigma=sim.rgb_sigma, mode="lm")
    out.write(f"one chart: {time.perf_counter() - t0:.0f} s\n")
    n = SERIAL_BELOW + 2  # the parallel kernels too
    sca.estimate_batch(np.repeat(sim.rgb[None], n, 0), depth=5.0, distance=1.5,
                       sigma=np.repeat(sim.rgb_sigma[None], n, 0), gain="free")
    out.write(f"a batch: {time.perf_counter() - t0:.0f} s\n")
    import importlib.util

    if importlib.util.find_spec("pidng") is None:  # the [test] extra absent: no DNG to measure
        return time.perf_counter() - t0
    import measure
    from measure.synthetic_photo import Scene, default_corners, render_mosaic, write_dng

    with tempfile.TemporaryDirectory(prefix="uw3p-warm-") as tmp:
        W, H = 480, 320
        corners = default_corners(W, H)
        dng = write_dng(render_mosaic(Scene(chl=1.0, cdom=0.1, depth=5.0, distance=1.5,
                                            width=W, height=H, gain=20000, seed=1), corners),
                        Path(tmp) / "warm.dng")
        meas = measure.measure(dng, corners=None, depth=5.0, distance=1.5)
        measure.write_outputs(meas, Path(tmp) / "out")
    out.write(f"a photograph: {time.perf_counter() - t0:.0f} s\n")
    return time.perf_counter() - t0


def main(argv=None) -> int:
    """``python -m uw3p.warm``: build the caches (exit 0)."""
    took = warm()
    print(f"uw3p: caches built in {took:.0f} s")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
