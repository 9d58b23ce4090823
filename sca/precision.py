"""How precisely can a camera measure the water? The Cramér-Rao bound of the chart model.

For each condition (C, a_CDOM(440), depth, distance) the noise-free chart M0 = g (G(x) + s 1^T)
is computed with :mod:`forward` (camera, illuminant, chart, :class:`forward.Water`), its noise
sigma with the sensor's own noise model (:func:`forward.sensor.noise_model`), and the Fisher
information F = J^T diag(1 / sigma^2) J of the parameters theta = (C, a_CDOM, s_1..s_m [, gain])
with the analytic Jacobian J = dM0/dtheta (:class:`forward.WaterTerms`). The covariance bound is
F^-1: the standard deviations of C and a_CDOM, their correlation, and (delta method) the expected
RRMSE of the attenuation k (eq 19 on the paper's 31 bands of 10 nm).

``gain``: 'known' (the exposure is known: data in model units), 'free' (one unknown scalar
gain: a photograph's exposure) or 'channels' (an unknown gain per channel: a camera whose R:G:B
balance is not calibrated). ``fix``: parameters held known ({'cdom'} and/or {'backscatter'}).

Where the bound is not attained: near a bound (the 95 % interval would reach C = 0 or a_CDOM =
0: the estimator's constraint makes its error distribution one-sided; flag ``near-bound-chl``
/ ``near-bound-cdom``), for charts too dark for the noise (``dark``) or clipped
(``saturated``), and where the problem is so nonlinear that the linearised bound is only
indicative (large relative sd: ``weak``, when the 95 % half-width exceeds the value). These
flags come with every result; the validation (``experiments/instrument.py``, tests) compares
the bound with the estimator's spread where none is raised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forward import validate
from forward.imaging import ChartSetup, length, resolve_setup, veiling_light
from forward.sensor import SensorSettings, noise_model
from forward.spectra import DEFAULT_CAMERA
from forward.water import Water, resolve_water

from .assess import flag_tuples, input_flag_table
from .estimate import RRMSE_BANDS_NM
from .model import CHL_DERIVATIVE_FLOOR, WaterModel

GAINS = ("known", "free", "channels")
FIXABLE = ("cdom", "backscatter")
Z95 = 1.959963984540054


@dataclass
class Precision:
    """The bound for N conditions (arrays of length N)."""

    chl: np.ndarray
    cdom: np.ndarray
    depth: np.ndarray
    distance: np.ndarray
    chl_sd: np.ndarray  # mg m^-3
    cdom_sd: np.ndarray  # m^-1
    correlation: np.ndarray  # corr(C, a_CDOM) of the bound
    rrmse: np.ndarray  # expected RRMSE of k (eq 19, 31 bands of 10 nm)
    attained: np.ndarray  # bool: no flag raised
    flags: list  # N tuples
    gain: str
    fixed: tuple

    @property
    def chl_rel95(self) -> np.ndarray:
        """95 % half-width of C relative to C (1.96 sd / C)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return Z95 * self.chl_sd / self.chl

    @property
    def cdom_rel95(self) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return Z95 * self.cdom_sd / self.cdom

    def __len__(self):
        return self.chl.size


def precision(chl, cdom, depth, distance, *, camera=DEFAULT_CAMERA, illuminant=None,
              reflectances=None, wavelengths=None, sensor: SensorSettings | None = None,
              water: Water | None = None, gain: str = "known", fix=(),
              setup: ChartSetup | None = None) -> Precision:
    """The Cramér-Rao bound of C and a_CDOM(440) for every condition (see the module docstring).

    ``chl`` (mg m^-3), ``cdom`` (m^-1), ``depth`` and ``distance`` (m) broadcast to N
    conditions; ``sensor`` defaults to :class:`forward.SensorSettings`. Vectorised: 10 000
    conditions take about a second.
    """
    chl, cdom, depth, distance = np.broadcast_arrays(
        np.atleast_1d(validate.nonnegative("chl", chl)),
        np.atleast_1d(validate.nonnegative("cdom", cdom)),
        np.atleast_1d(length("depth", depth)), np.atleast_1d(length("distance", distance)))
    chl, cdom, depth, distance = (np.array(x, float) for x in (chl, cdom, depth, distance))
    if gain not in GAINS:
        raise ValueError(f"gain: must be one of {GAINS}, got {gain!r}")
    fix = tuple(fix or ())
    bad = set(fix) - set(FIXABLE)
    if bad:
        raise ValueError(f"fix: can hold {FIXABLE} known, got {sorted(bad)}")
    sensor = SensorSettings() if sensor is None else sensor
    if not isinstance(sensor, SensorSettings):
        raise ValueError("sensor: expected a forward.SensorSettings")
    setup = resolve_setup(setup, camera, illuminant, reflectances, wavelengths)
    water = resolve_water(water)
    mdl = WaterModel(setup, 0.0, 0.0, water=water)
    if mdl.z != 1:
        raise ValueError("basis: the bound is for one basis function (z = 1)")
    terms, B, m, n = mdl.terms, mdl.B, mdl.m, mdl.n
    N = chl.size
    L = depth + distance
    k = np.exp(-L[:, None] * terms.coefficient(chl, cdom))  # (N, q)
    dk = (-L[:, None, None] * k[:, :, None]) * terms.jacobian(chl, cdom, floor=CHL_DERIVATIVE_FLOOR)
    s = veiling_light(setup.wavelengths, chl, cdom, depth, distance, illuminant=setup.illuminant,
                      water=water) @ setup.sensitivities  # (N, m)
    G = k @ B.T  # (N, m n)
    M0 = G.reshape(N, m, n) + s[:, :, None]
    sigma, saturation, _, _ = noise_model(M0, setup, sensor)
    cols = [dk[:, :, 0] @ B.T]  # d M0 / dC (N, m n)
    names = ["chl"]
    if "cdom" not in fix:
        cols.append(dk[:, :, 1] @ B.T)
        names.append("cdom")
    if "backscatter" not in fix:
        for c in range(m):
            e = np.zeros((N, m, n))
            e[:, c, :] = 1.0
            cols.append(e.reshape(N, -1))
    if gain == "free":
        cols.append(M0.reshape(N, -1))
    elif gain == "channels":
        for c in range(m):
            e = np.zeros((N, m, n))
            e[:, c, :] = M0[:, c, :]
            cols.append(e.reshape(N, -1))
    J = np.stack(cols, axis=-1)  # (N, m n, p)
    Jw = J / sigma.reshape(N, -1, 1)
    F = np.einsum("nip,niq->npq", Jw, Jw)
    cov = _inverse(F)
    chl_sd = np.sqrt(np.maximum(cov[:, 0, 0], 0.0))
    if "cdom" in names:
        cdom_sd = np.sqrt(np.maximum(cov[:, 1, 1], 0.0))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov[:, 0, 1] / (chl_sd * cdom_sd)
        cov_x = cov[:, :2, :2]
        dkx = dk
    else:
        cdom_sd = np.zeros(N)
        corr = np.full(N, np.nan)
        cov_x = cov[:, :1, :1]
        dkx = dk[:, :, :1]
    bands = np.isin(setup.wavelengths, RRMSE_BANDS_NM)
    var_k = np.einsum("nlp,npq,nlq->nl", dkx[:, bands], cov_x, dkx[:, bands])
    rrmse = np.sqrt(var_k.sum(axis=1)) / (np.sqrt(bands.sum()) * np.linalg.norm(k[:, bands], axis=1))
    flags, attained = _flags(chl, cdom, chl_sd, cdom_sd, M0, sigma, saturation, "cdom" in names)
    return Precision(chl=chl, cdom=cdom, depth=depth, distance=distance, chl_sd=chl_sd,
                     cdom_sd=cdom_sd, correlation=corr, rrmse=rrmse, attained=attained,
                     flags=flags, gain=gain, fixed=fix)


def _inverse(F):
    """Batched inverse; a singular (undetermined) problem gives infinite variances."""
    out = np.full_like(F, np.inf)
    ok = np.linalg.cond(F) < 1e14
    if ok.any():
        out[ok] = np.linalg.inv(F[ok])
    return out


def _flags(chl, cdom, chl_sd, cdom_sd, M0, sigma, saturation, cdom_free):
    table = input_flag_table(M0, sigma, saturation)
    table = {k: table[k] for k in ("dark", "saturated")}
    table["near-bound-chl"] = Z95 * chl_sd >= chl
    table["near-bound-cdom"] = cdom_free & (Z95 * cdom_sd >= cdom)
    flags, _ = flag_tuples(table)
    return flags, ~np.column_stack(list(table.values())).any(axis=1)
