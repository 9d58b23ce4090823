"""The one model function of every estimator: predicted patch values and their Jacobian.

For named parameters theta (:data:`PARAMS`) the chart model of eq 15 is

    M(theta) = gain G(x) + s 1^T,   G(x) = P^T diag(i) diag(k(x)) R,   k = exp(-L c(x)),
    L = depth + distance,   vec(G) = B k  with B = (P (x) R) diag(i)

with c(x) and dc/dx from :meth:`forward.WaterTerms.path_coefficient` (eqs 4-12, each term beside
its derivative). :meth:`ChartModel.predict` returns M and dM/dtheta for any subset of the names;
the cvxpy loop's linearisation, the scipy path, the batched Levenberg-Marquardt, the
profile-likelihood intervals and :func:`sca.precision`'s Fisher information all call it.
Nothing here is re-derived elsewhere.

Units: chl mg m^-3, cdom m^-1 (a_CDOM at 440 nm), depth and distance m, gain and backscatter in
the units of the measurements (model units: a white reflector in air = 1).
"""

from __future__ import annotations

import copy
import functools
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from forward.imaging import ChartSetup, camera_response
from forward.water import COEFFICIENT_PARAMS, PATH_LEGS, Water, resolve_water

from .parameters import (BALANCE_MIN, CDOM_MAX, CHL_MAX, CONSTANT_SPAN,  # noqa: F401 - re-exported
                         LENGTH_MAX, PARAMETERS, default, lower_bound, upper_cap)
from .problem import TINY, chl_from_u, du_chain, u_from_chl, with_priors  # noqa: F401 - re-exported
from .projection import linear_part_stats
from forward.errors import InputError

__all__ = ["PARAMS", "SPECTRAL", "GEOMETRY", "LINEAR", "CAMERA", "LIGHT", "PER_CHANNEL", "CHL_DERIVATIVE_FLOOR", "CHL_MAX",
           "CDOM_MAX", "LENGTH_MAX", "ChartModel", "Prediction", "lower_bound", "upper_cap",
           "check_names", "curve_shift_derivative", "linear_part", "linear_part_stats", "covariance", "covariance_from_information", "information", "profiled_covariance", "profiled_information", "chl_from_u", "u_from_chl",
           "du_chain"]

def curve_shift_derivative(P, wavelengths) -> np.ndarray:
    """d P(lambda - delta) / d delta at delta = 0, i.e. -dP/dlambda (q, m): the camera curves'
    shift to first order, P(lambda - delta) ~ P + delta (-dP/dlambda) (the budget's
    ``camera_shift``; the one place this term is computed).

    Parameters
    ----------
    P : array_like, (q, m)
        Sensitivities on ``wavelengths``.
    wavelengths : array_like, (q,)
        Their grid, nm.

    Returns
    -------
    numpy.ndarray, (q, m)
        -dP/dlambda, per nm (zeros on a one-node grid).
    """
    P = np.asarray(P, float)
    wl = np.asarray(wavelengths, float)
    return -np.gradient(P, wl, axis=0) if wl.size > 1 else 0 * P


#: Geometry of the path (eqs 3, 14), m.
GEOMETRY = ("depth", "distance")
#: Parameters that enter M linearly (profiled out in closed form by the batch).
LINEAR = ("gain", "backscatter")
#: The camera's curves as measured: 'balance', relative errors beta of each channel's
#: sensitivity, and 'camera_shift', a wavelength shift delta (nm) of each channel's curve
#: (m values each; M = gain diag(1 + beta) (B + sum_c delta_c dB/dlambda_c) k + s 1^T, the
#: shift to first order): nuisance parameters of the uncertainty budget.
CAMERA = ("balance", "camera_shift")
#: Names with one value per camera channel (the parameter table's per-channel rows).
PER_CHANNEL = tuple(n for n, p in PARAMETERS.items() if p.per_channel)
#: The surface light's colour: 'daylight', its temperature's change from the given
#: illuminant's, mired (:class:`forward.daylight.DaylightTilt`): the light at the chart is
#: i (lambda) r(lambda) k(lambda), r = S_D(T) / S_D(T_ref), normalised so that a white
#: reflector in air stays 1 in the reference channel (a nuisance of the uncertainty budget).
LIGHT = ("daylight",)
#: Parameters of c(x): C, a_CDOM(440), the phytoplankton weights w of eq 9 and any
#: coefficient field of :class:`forward.Water`.
SPECTRAL = ("chl", "cdom", "w") + COEFFICIENT_PARAMS
#: Every name the model differentiates by.
PARAMS = SPECTRAL + GEOMETRY + LINEAR + CAMERA + LIGHT
#: Inputs of the model function that are never free: the chart's response measured in air,
#: one factor per (channel, patch) row (:meth:`ChartModel.with_response`).
PER_ROW = ("response",)

#: Floor of C (mg m^-3) at which the derivatives of C^0.627 and C^0.724 are evaluated by the
#: cvxpy loop: both are infinite at C = 0 (decision 0024-sca-loop).
CHL_DERIVATIVE_FLOOR = 1e-6
#: Values (charts x wavelengths) per block of :meth:`ChartModel.predict`: its temporaries
#: then fit in the cache; at least PREDICT_BLOCK_MIN charts per block.
PREDICT_BLOCK_VALUES, PREDICT_BLOCK_MIN = 300_000, 256
#: Threads for the blocks (at most the machine's cores).
PREDICT_THREADS = 8
#: Largest condition number of the (unit-diagonal) information matrix that is inverted.
COND_MAX = 1e14

def check_names(name: str, names, allowed=PARAMS) -> tuple:
    """``names`` as a tuple of parameter names, or ``ValueError`` naming the argument.

    Parameters
    ----------
    name : str
        The argument's name (e.g. ``'free'``), used at the start of every error message.
    names : str or iterable of str
        The parameter names; a single string is one name.
    allowed : sequence of str, optional
        The names accepted (default :data:`PARAMS`).

    Returns
    -------
    tuple of str
        ``names`` in the order given.

    Raises
    ------
    ValueError
        If ``names`` is not iterable, names a parameter outside ``allowed`` or names one twice.
    """
    if isinstance(names, str):
        names = (names,)
    try:
        names = tuple(names)
    except TypeError:
        raise InputError(name, f"expected parameter names, got {names!r}") from None
    bad = [n for n in names if n not in allowed]
    if bad:
        raise InputError(name, f"unknown parameter(s) {bad}; choose from {tuple(allowed)}")
    if len(set(names)) != len(names):
        raise InputError(name, f"a parameter is named twice: {names}")
    return names


def response_factors(factors, rows: int) -> np.ndarray:
    """The chart's response measured in air as positive factors, one per (channel, patch) row
    (shape ``... + (rows,)``).

    Raises
    ------
    forward.errors.InputError
        Naming "uncertain['response']" for another shape or a factor not finite and positive.
    """
    f = np.asarray(factors, float)
    f = f.reshape(f.shape[:-2] + (-1,)) if f.ndim >= 2 and f.shape[-1] * f.shape[-2] == rows \
        and f.shape[-1] != rows else f
    if f.shape[-1:] != (rows,) or not np.all(np.isfinite(f) & (f > 0)):
        raise InputError("uncertain['response']", f"expected {rows} positive factors, one per "
                         f"channel and patch, got shape {np.shape(factors)}")
    return f


def _as_rows(factor) -> np.ndarray:
    """The model's scale (:meth:`ChartModel.scaled`) as a column that divides B."""
    return np.reshape(np.asarray(factor, float), (-1, 1))


def _in_pool() -> bool:
    """True in a thread of :func:`_pool` (a block is never split again there)."""
    return threading.current_thread().name.startswith("uw3p-predict")


@functools.lru_cache(maxsize=1)
def _pool() -> ThreadPoolExecutor:
    """Threads for the blocks of a large prediction (one per core; stateless, thread-safe)."""
    return ThreadPoolExecutor(max_workers=max(1, min(os.cpu_count() or 1, PREDICT_THREADS)),
                              thread_name_prefix="uw3p-predict")


# The coordinate u = C^e0 of the fits (every C-dependent term is smooth in u at C = 0, where
# d/dC is infinite) is the inference layer's (sca.problem): a change of variable, not physics.


@dataclass
class Prediction:
    """Output of :meth:`ChartModel.predict` (leading shape S of the parameters).

    Attributes
    ----------
    values : ndarray, S + (m n,)
        vec(gain G + s 1^T), row-major over (channel, patch).
    signal : ndarray, S + (m n,)
        vec(G) at unit gain, without backscatter.
    attenuation : ndarray, S + (q,)
        k = exp(-L c).
    coefficient : ndarray, S + (q,)
        The path coefficient c (m^-1; a for the 'absorption' path model, the path-averaged
        (depth K_d + distance c) / (depth + distance) for 'split').
    jacobian : ndarray, S + (m n, p) or None
        d values / d theta, columns in the order of ``columns``.
    columns : tuple of str
        One name per Jacobian column ('w' repeats z times, 'backscatter' m times).
    jacobian_rows : ndarray, S + (p, m n) or None
        The same numbers, one row per column (contiguous).
    """

    values: np.ndarray
    signal: np.ndarray
    attenuation: np.ndarray
    coefficient: np.ndarray
    jacobian: np.ndarray | None
    columns: tuple
    #: the Jacobian's columns as rows, S + (p, m n) (contiguous; ``jacobian`` is its transpose)
    jacobian_rows: np.ndarray | None = None

    @classmethod
    def concatenate(cls, parts) -> "Prediction":
        """One prediction from predictions of consecutive blocks of charts."""
        def cat(name):
            vals = [getattr(p, name) for p in parts]
            return None if vals[0] is None else np.concatenate(vals, axis=0)
        rows = cat("jacobian_rows")
        return cls(cat("values"), cat("signal"), cat("attenuation"), cat("coefficient"),
                   None if rows is None else np.swapaxes(rows, -1, -2), parts[0].columns, rows)

    def column(self, name: str) -> np.ndarray:
        """The Jacobian columns of ``name``, S + (m n, count)."""
        idx = [i for i, c in enumerate(self.columns) if c == name]
        return self.jacobian[..., idx]


class ChartModel:
    """The chart model of eq 15 for one chart setup, water model and basis.

    Parameters
    ----------
    setup : forward.ChartSetup
        Camera P, illuminant i and chart R on one wavelength grid.
    water : forward.Water, optional
        Constants, tables and path model (default: the paper's).
    basis : array_like or str, optional
        Phytoplankton basis T of eq 9 replacing the water's table.

    Attributes
    ----------
    setup : forward.ChartSetup
        As given.
    water : forward.Water
        The resolved water model.
    wavelengths : ndarray, (q,)
        The grid, nm.
    terms : forward.WaterTerms
        The water's tables on the grid (``path_coefficient`` gives c(x) and dc/dx).
    T : ndarray, (q, z)
        Phytoplankton basis of eq 9 on the grid.
    t440 : ndarray, (z,)
        The basis at 440 nm (the row of eq 17).
    z, m, n : int
        Basis functions, camera channels, chart patches.
    B : ndarray, (m n, q)
        (P (x) R) diag(i): vec(G) = B k.
    Bt : ndarray, (q, m n)
        B transposed (contiguous).
    Dt, BDt : ndarray, (q, m n) and (q, 2 m n)
        d vec(G) / d (each channel's curve shift), and [Bt Dt] (built on first use).
    e0 : float
        The exponent of eq 10 (the batch's coordinate u = C^e0).

    References
    ----------
    Blasinski & Farrell, "A Three Parameter Underwater Image Formation Model", eq 15 (the
    chart model) with eqs 4-12 (the path coefficient).
    """

    def __init__(self, setup: ChartSetup, *, water: Water | None = None, basis=None):
        self.setup = setup
        self.water = water = resolve_water(water)
        self.wavelengths = setup.wavelengths
        self.terms = water.on_grid(self.wavelengths, basis=basis)
        self.T, self.t440 = self.terms.T, self.terms.t440
        self.z = self.T.shape[1]
        P, i, R = setup.sensitivities, setup.illuminant, setup.reflectances
        self.m, self.n = P.shape[1], R.shape[1]
        # B[(c, j), l] = P[l, c] i[l] R[l, j]: vec(G) = B @ k (row-major vec of the m x n matrix)
        self.Bt = response_matrix(P, i, R)
        self.B = np.ascontiguousarray(self.Bt.T)
        #: where :attr:`Dt` comes from: None (this setup's curves) or (model, factor) for a
        #: :meth:`scaled` copy (the model's Dt / factor)
        self._dt_source = None
        #: a white reflector in air's signal in the reference channel (the one P is scaled
        #: by), per wavelength: its sum is 1 (the normalisation of model units)
        ref = int(np.argmax(P.T @ i))
        self.white = np.ascontiguousarray(P[:, ref] * i)
        #: d M / d s: one row per channel, 1 on that channel's patches (read-only)
        self._indicators = np.repeat(np.eye(self.m), self.n, axis=1)
        self._indicators.setflags(write=False)
        #: the exponent of eq 10: the batch's coordinate u = C^e0 (see :func:`du_chain`)
        self.e0 = float(water.phyto_exponent)
        #: the model on its full grid (itself, or the model a :meth:`reduced` copy came from)
        self.full = self
        #: the quadrature rule of a :meth:`reduced` model (None on the full grid)
        self.rule = None
        #: the factor this model's signals are divided by (:meth:`scaled`)
        self._factor = 1.0
        self.response = None  # the chart's response measured in air, (m n,) (with_response)

    def scaled(self, factor) -> "ChartModel":
        """A copy whose signals are divided by ``factor`` (the data's scale, a number: each
        chart's response measured in air is the model function's ``response``, not this); shares
        the rest and keeps a reference to this model
        (its Dt, when needed, is this model's / factor). It is its own full-grid model: its
        :meth:`reduced` is this model's, scaled."""
        new = copy.copy(self)
        new.B = self.B / _as_rows(factor)
        new.Bt = np.ascontiguousarray(new.B.T)
        for name in ("Dt", "BDt", "_reduced"):  # computed for the copy when needed
            new.__dict__.pop(name, None)
        new._dt_source = (self, factor)
        new.full, new.rule = new, None
        new._factor = self._factor * np.asarray(factor, float)
        return new

    def with_response(self, factors) -> "ChartModel":
        """A copy whose every (channel, patch) row of the direct signal (and of the curves'
        shift) is times ``factors`` (m, n) or (m n,): the chart's response measured in air by
        a reference shot (:func:`sca.reference.patch_response`); the veiling light is not
        scaled. The factor is the model function's ``response`` where ``params`` gives none
        (one per chart of a batch: ``params['response']``). ``None``: this model."""
        if factors is None:
            return self
        new = copy.copy(self)
        new.response = response_factors(factors, self.m * self.n)
        new.__dict__.pop("_reduced", None)
        # its own full-grid model (and so its own certified quadrature)
        new.full = new if self.full is self else self.full.with_response(new.response)
        return new

    @functools.cached_property
    def _reduced(self) -> "ChartModel":
        from .quadrature import quadrature_rule

        rule = quadrature_rule(self)
        if rule is None or self.full is not self:
            return self
        new = copy.copy(self)
        new.__dict__.pop("BDt", None)
        new.__dict__.pop("_reduced", None)
        new.wavelengths = self.wavelengths[rule.index]
        new.terms = self.terms.subset(rule.index)
        new.T, new.t440 = new.terms.T, new.terms.t440
        new.B = rule.B / _as_rows(self._factor)
        new.Bt = np.ascontiguousarray(new.B.T)
        new.__dict__["Dt"] = np.ascontiguousarray(rule.D.T / _as_rows(self._factor).T)
        new.__dict__.pop("daylight_tilt", None)
        new.white = rule.white
        new._dt_source = None
        new.rule = rule
        return new

    def reduced(self) -> "ChartModel":
        """This model on the nodes of its certified spectral quadrature
        (:mod:`sca.quadrature`): the same parameters and outputs, eq 1's integral on every 5th
        wavelength with fitted weights; itself where its grid is not reduced (coarse grids).

        Returns
        -------
        ChartModel
            Its ``full`` is this model, ``rule`` the :class:`sca.quadrature.QuadratureRule`.
        """
        return self._reduced

    @functools.cached_property
    def daylight_tilt(self):
        """The surface light's change with its colour temperature on this model's grid
        (:class:`forward.daylight.DaylightTilt`, reference the setup's ``daylight_cct``)."""
        from forward.daylight import DaylightTilt

        return DaylightTilt(self.wavelengths, self.setup.daylight_cct)

    def _light(self, k, shift, derivative: bool):
        """The light at the chart relative to the given illuminant's, k r, its normalisation
        n = white . r (S,) and, with ``derivative``, d ln r / d shift (S + (q,)) and dn."""
        out = self.daylight_tilt.log_ratio(np.asarray(shift, float), derivative=derivative)
        lnr, dlnr = out if derivative else (out, None)
        r = np.exp(lnr)
        n = r @ self.white
        if not derivative:
            return k * r, n, None, None
        return k * r, n, dlnr, (r * dlnr) @ self.white

    @functools.cached_property
    def Dt(self) -> np.ndarray:
        """d vec(G) / d lambda-shift of each channel's curve, (q, m n) contiguous: P(lambda -
        delta) ~ P - delta dP/dlambda. Built on first use (only a camera shift needs it)."""
        if self._dt_source is not None:
            model, factor = self._dt_source
            return model.Dt / _as_rows(factor).T
        P, i, R = self.setup.sensitivities, self.setup.illuminant, self.setup.reflectances
        return response_matrix(curve_shift_derivative(P, self.wavelengths), i, R)

    @functools.cached_property
    def BDt(self) -> np.ndarray:
        """[Bt Dt]: both projections by one matrix product where the curves' shift is
        modelled."""
        return np.hstack([self.Bt, self.Dt])

    def default(self, name: str):
        """The value a parameter takes when it is not given: the water's constant, gain 1,
        no backscatter."""
        value = default(name, self.water)  # the parameter table's (sca.parameters)
        return np.full(self.m, value) if PARAMETERS[name].per_channel else value

    # ------------------------------------------------------------------ the model function
    def predict(self, params: dict, free=(), *, chl_floor: float = 0.0,
                jacobian: bool = True) -> Prediction:
        """M(theta) and d M / d theta for the parameters named in ``free``.

        Parameters
        ----------
        params : dict
            name -> value, each of leading shape S (or broadcastable): 'chl' (mg m^-3), 'depth'
            and 'distance' (m) are required; 'cdom' (m^-1, default 0), 'gain' (default 1),
            'backscatter' (S + (m,), default 0), 'balance' (S + (m,), relative channel
            sensitivity errors, default 0), 'camera_shift' (S + (m,), nm, default 0), 'w' (S + (z,), free phytoplankton weights of
            eq 9; default w on eq 17) and any :data:`forward.water.COEFFICIENT_PARAMS` field
            (default: the water's constant) are optional.
        free : sequence of str
            Names (:data:`PARAMS`) whose derivative columns are returned, in this order.
        chl_floor : float
            d/dC is evaluated at max(C, chl_floor) (infinite at C = 0 for chl_floor = 0).
        jacobian : bool
            False: values only (``free`` is ignored).

        Returns
        -------
        Prediction
        """
        free = check_names("free", free) if jacobian else ()
        n_lead = self._batch_size(params)
        size = max(PREDICT_BLOCK_MIN, PREDICT_BLOCK_VALUES // self.wavelengths.size)
        if n_lead > size and not _in_pool():  # in blocks: the temporaries stay in the cache
            def block(i):
                return self._predict(self._rows_of(params, n_lead, slice(i, i + size)),
                                     free, chl_floor, jacobian)
            # numpy releases the GIL in its array loops and BLAS: blocks run on every core
            return Prediction.concatenate(list(_pool().map(block, range(0, n_lead, size))))
        return self._predict(params, free, chl_floor, jacobian)

    def _predict(self, params, free, chl_floor, jacobian) -> Prediction:
        """:meth:`predict` of one block of charts (``free`` checked)."""
        unknown = set(params) - set(PARAMS) - set(PER_ROW)
        if unknown:
            raise InputError("params", f"unknown parameter(s) {sorted(unknown)}")
        for need in ("chl", "depth", "distance"):
            if need not in params:
                raise InputError("params", f"'{need}' is required")
        chl = np.asarray(params["chl"], float)
        cdom = np.asarray(params.get("cdom", 0.0), float)
        L = np.asarray(params["depth"], float) + np.asarray(params["distance"], float)
        gain = np.asarray(params.get("gain", 1.0), float)
        s = np.asarray(params.get("backscatter", np.zeros(self.m)), float)
        w = params.get("w")
        balance, shift = params.get("balance"), params.get("camera_shift")
        if balance is not None:
            balance = np.asarray(balance, float)
        if shift is not None:
            shift = np.asarray(shift, float)
        if "w" in free and w is None:
            raise InputError("free", "'w' needs the weights in params['w']")
        response = params.get("response", self.response)  # the chart's response in air
        if response is not None:
            response = response_factors(response, self.m * self.n)
        consts = {k: v for k, v in params.items() if k in COEFFICIENT_PARAMS}
        spectral = tuple(n for n in free if n in SPECTRAL)
        legs = len(PATH_LEGS[self.water.path_model]) > 1
        if legs:  # 'split': tau = depth K_d + distance c (forward.WaterTerms.optical_depth)
            tau, dtau = self.terms.optical_depth(
                chl, cdom, params["depth"], params["distance"], w=w, values=consts,
                wrt=spectral + tuple(n for n in free if n in GEOMETRY), floor=chl_floor)
            k = np.exp(-tau)
            with np.errstate(divide="ignore", invalid="ignore"):
                c = tau / L[..., None]  # the path-averaged coefficient
        else:
            c, dc = self.terms.path_coefficient(chl, cdom, w=w, values=consts, wrt=spectral,
                                                floor=chl_floor)
            k = np.exp(-L[..., None] * c)
        lead = k.shape[:-1]
        q, mn = self.wavelengths.size, self.m * self.n
        # the light at the chart: k, or k r where the surface light's colour is a parameter
        day = params.get("daylight")
        with_day = day is not None or "daylight" in free
        kl, norm, dlnr, dnorm = (k, None, None, None) if not with_day else self._light(
            k, 0.0 if day is None else day, jacobian and "daylight" in free)
        if with_day and np.ndim(norm) < len(lead):
            norm = np.broadcast_to(norm, lead)
        if not jacobian:
            if shift is not None:  # both projections by one product, as with the Jacobian
                both = kl @ self.BDt
                G = both[..., :mn] + np.repeat(shift, self.n, axis=-1) * both[..., mn:]
            else:
                G = kl @ self.Bt
            if response is not None:
                G = G * response
            if with_day:
                G = G / norm[..., None]
            if balance is not None:
                G = G * np.repeat(1.0 + balance, self.n, axis=-1)
            values = gain[..., None] * G + np.repeat(s, self.n, axis=-1)
            return Prediction(values, G, k, c, None, ())
        count = {name: self.z if name == "w" else self.m if name in PER_CHANNEL else 1
                 for name in free}
        # k and every column of dk/dtheta stacked (S, 1 + p_q, q) and projected onto the
        # patches by one matrix product: dk = -L k dc/dtheta (spectral), -c k (path length)
        in_q = [name for name in free if name in SPECTRAL or name in GEOMETRY or name in LIGHT]
        stack = np.empty(lead + (1 + sum(count[n] for n in in_q), q))
        stack[..., 0, :] = kl
        minus_Lk = -L[..., None] * kl
        row = 1
        for name in in_q:
            if name in LIGHT:  # d (k r) / d shift = k r d ln r / d shift
                stack[..., row, :] = kl * dlnr
            elif legs:  # dk = -k d tau / d theta
                d = dtau[name]
                stack[..., row:row + count[name], :] = (
                    -kl[..., None, :] * np.swapaxes(d, -1, -2) if name == "w" else -kl * d
                ).reshape(lead + (count[name], q))
            elif name == "w":
                stack[..., row:row + self.z, :] = minus_Lk[..., None, :] * np.swapaxes(dc["w"], -1, -2)
            elif name in GEOMETRY:
                stack[..., row, :] = -c * kl
            else:
                stack[..., row, :] = minus_Lk * dc[name]
            row += count[name]
        GD = None
        if shift is not None or "camera_shift" in free:  # the curves' shift, to first order
            both = (stack.reshape(-1, q) @ self.BDt).reshape(lead + (stack.shape[-2], 2 * mn))
            proj, projD = both[..., :mn], both[..., mn:]
            GD = projD[..., 0, :]
            if shift is not None:
                proj = proj + np.repeat(shift, self.n, axis=-1)[..., None, :] * projD
        else:
            proj = (stack.reshape(-1, q) @ self.Bt).reshape(lead + (stack.shape[-2], mn))
        if response is not None:  # every row of the direct signal, and of the curves' shift
            proj = proj * response[..., None, :]
            GD = None if GD is None else GD * response
        if with_day:  # the normalisation of model units: a white in air stays 1
            proj = proj / norm[..., None, None]
            if GD is not None:
                GD = GD / norm[..., None]
            if "daylight" in free:
                j = 1 + sum(count[n] for n in in_q[:in_q.index("daylight")])
                proj[..., j, :] -= proj[..., 0, :] * (dnorm / norm)[..., None]
        G_raw = proj[..., 0, :]
        if balance is not None:  # every row of channel c times 1 + beta_c
            G_raw = G_raw.copy()
            proj = proj * np.repeat(1.0 + balance, self.n, axis=-1)[..., None, :]
        G = proj[..., 0, :]
        values = gain[..., None] * G + np.repeat(s, self.n, axis=-1)
        if list(free) == in_q and np.ndim(gain) == 0 and gain == 1.0:
            # only columns of k at unit gain (the batch's case): a view, no copy
            rows = proj[..., 1:, :]
            names = [name for name in free for _ in range(count[name])]
            return Prediction(values, G, k, c, np.swapaxes(rows, -1, -2), tuple(names), rows)
        rows = np.empty(lead + (sum(count.values()), mn))
        at, src, names = 0, 1, []
        for name in free:
            width = count[name]
            if name in in_q:
                rows[..., at:at + width, :] = proj[..., src:src + width, :] * gain[..., None, None]
                src += width
            elif name == "gain":
                rows[..., at, :] = G
            elif name == "balance":  # d M / d beta_c = gain G on channel c's patches
                rows[..., at:at + width, :] = (self._indicators * G_raw[..., None, :]
                                               * gain[..., None, None])
            elif name == "camera_shift":  # d M / d delta_c = gain (1 + beta_c) (D k)_c
                fac = gain[..., None] if balance is None else \
                    gain[..., None] * np.repeat(1.0 + balance, self.n, axis=-1)
                rows[..., at:at + width, :] = self._indicators * (fac * GD)[..., None, :]
            else:  # backscatter: one indicator per channel
                rows[..., at:at + width, :] = self._indicators
            names += [name] * width
            at += width
        return Prediction(values, G, k, c, np.swapaxes(rows, -1, -2), tuple(names), rows)

    def _batch_size(self, params) -> int:
        """N where every parameter has at most one leading axis of length N (else 0)."""
        n = 0
        for name, v in params.items():
            if isinstance(v, (list, tuple)):
                v = np.asarray(v)
            if not isinstance(v, np.ndarray):
                continue
            nd = v.ndim - (1 if name in PER_CHANNEL + ("w",) + PER_ROW else 0)
            if nd > 1:
                return 0
            if nd == 1:
                size = v.shape[0]
                if n and size != n:
                    return 0
                n = size
        return n

    @staticmethod
    def _rows_of(params, n, sl) -> dict:
        out = {}
        for name, v in params.items():
            nd = np.ndim(v) - (1 if name in PER_CHANNEL + ("w",) + PER_ROW else 0)
            out[name] = np.asarray(v)[sl] if nd == 1 else v
        return out

    # ------------------------------------------------------------------ eq 17
    def phyto_scale(self, chl, derivative=False):
        """(T w)(440) required by eq 17: 0.0378 C^0.627 (and its derivative at the floor)."""
        return self.water.phytoplankton_440(chl, derivative=derivative, floor=CHL_DERIVATIVE_FLOOR)

    def feasible_w(self, chl, w_shape=None) -> np.ndarray:
        """w on the eq 17 manifold: ``w_shape`` rescaled so that t440 . w = 0.0378 C^0.627."""
        shape = np.full(self.z, 1.0 / self.z) if w_shape is None else np.asarray(w_shape, float)
        t = float(self.t440 @ shape)
        if not t > 0:
            shape = np.full(self.z, 1.0 / self.z)
            t = float(self.t440 @ shape)
        return shape * (float(self.phyto_scale(chl)) / t)


# ------------------------------------------------------------------ the linear unknowns
def linear_part(M3, G3, w2, fixed_s=None, free_gain: bool = True):
    """The closed-form linear unknowns of M = gain G + s 1^T for given signals.

    gain >= 0 (when ``free_gain``; else 1) and s >= 0 minimise sum w2 (M - gain G - s 1^T)^2
    (the compiled active set of :func:`sca.projection.linear_part_stats`).

    Parameters
    ----------
    M3 : ndarray, broadcastable to (N, m, n)
        Measurements (one chart's (1, m, n) against N signals, or one per signal).
    G3 : ndarray, (N, m, n)
        Unit-gain signals.
    w2 : ndarray, broadcastable to (N, m, n)
        Weights 1 / sigma^2 (ones: unweighted).
    fixed_s : ndarray, (N, m), optional
        Backscatter held at these values.
    free_gain : bool
        Estimate the gain (else it is 1).

    Returns
    -------
    gain : ndarray, (N,)
        The gain (units of ``M3`` per unit of ``G3``); 1 where it is not free.
    s : ndarray, (N, m)
        The backscatter, units of ``M3`` (``fixed_s`` where it is held).
    active : ndarray of bool, (N, m)
        True where s is free and positive (its channel mean is projected out of a Jacobian).

    References
    ----------
    L. Kaufman, "A variable projection method for solving separable nonlinear least squares
    problems", BIT 15 (1975) 49-57.
    """
    M3 = np.asarray(M3, float)
    lead = G3.shape[:-1]
    w2 = np.asarray(w2, float)
    # the weights' own leading shape, but every patch of the last axis (a scalar or a
    # per-channel weight counts n times in sum w)
    w2 = np.broadcast_to(w2, np.broadcast_shapes(w2.shape, G3.shape[-1:]))
    # sum w and sum w M do not depend on G: summed once where w and M are shared (a grid of
    # signals against one chart), the same sums as over their broadcast copies
    sw = np.broadcast_to(w2.sum(-1), lead).copy()
    sM = np.broadcast_to((w2 * M3).sum(-1), lead).copy()
    wG = w2 * G3
    sG = wG.sum(-1)
    if free_gain:
        sGG, sGM = (wG * G3).sum(-1), (wG * np.broadcast_to(M3, G3.shape)).sum(-1)
    else:  # the gain is 1: s needs sum w, sum w M and sum w G alone (the kernel reads no more)
        sGG = sGM = sG
    return linear_part_stats(sw, sM, sG, sGG, sGM, fixed_s=fixed_s, free_gain=free_gain)


def response_matrix(P, i, R) -> np.ndarray:
    """Eq 15 as a linear map of the transmittance: Bt (q, m n) with vec(G) = Bt^T k.

    Row l is the chart's response to the light of wavelength l alone (k the l-th unit vector)
    by :func:`forward.imaging.camera_response`, the one place eq 15 is written.

    Parameters
    ----------
    P : ndarray, (q, m)
        Camera sensitivities (or their derivative by a wavelength shift).
    i : ndarray, (q,)
        The illuminant.
    R : ndarray, (q, n)
        The patches' reflectances.

    Returns
    -------
    ndarray, (q, m n), contiguous
        Bt[l, (c, j)] = P[l, c] i[l] R[l, j] (row-major vec of the m x n matrix).

    References
    ----------
    Blasinski & Farrell, eq 15.
    """
    q = np.shape(P)[0]
    return np.ascontiguousarray(camera_response(P, i, np.eye(q), R).reshape(q, -1))


def covariance(J, sigma2=1.0, *, cond_max: float = COND_MAX, prior_weight=None):
    """Gauss-Newton covariance sigma^2 (J^T J)^-1 of whitened Jacobians J (..., rows, p).

    The one covariance of the package (through :func:`profiled_covariance`): the estimators'
    standard errors and Wald intervals and :func:`sca.precision`'s Cramér-Rao bound (there J is
    whitened by the sensor's noise and sigma^2 = 1). The information is inverted after Jacobi
    scaling (unit diagonal), so whether it counts as singular does not depend on the units of
    the parameters; singular (undetermined) problems give infinite variances.

    Parameters
    ----------
    J : array_like, (..., rows, p)
        Whitened Jacobians (d residual / d theta divided by the noise standard deviation, or
        unweighted), any leading shape.
    sigma2 : float or array_like, broadcastable to the leading shape ``...``
        Noise variance in the units of the whitening (1 where J is whitened by the known
        noise; the residual variance where the noise is estimated).
    cond_max : float, optional
        Largest condition number of the unit-diagonal information matrix that is inverted
        (default :data:`COND_MAX`).
    prior_weight : array_like, broadcastable to (..., p), optional
        Information 1 / sd^2 of Gaussian priors on the parameters (0: none), added to the
        diagonal of J^T J (the uncertainty budget's nuisance parameters, :mod:`sca.budget`).

    Returns
    -------
    ndarray, (..., p, p)
        The covariance, in the units of the parameters. Every entry is ``inf`` for a problem
        whose information is singular, ill-conditioned (condition number >= ``cond_max``),
        non-finite or has a zero column.

    References
    ----------
    S. M. Kay, Fundamentals of Statistical Signal Processing: Estimation Theory, Prentice Hall
    (1993), ch. 3 (the inverse Fisher information as the Cramér-Rao bound).
    """
    return covariance_from_information(information(J, prior_weight), sigma2, cond_max=cond_max)


def information(J, prior_weight=None):
    """J^T J + diag(prior_weight): the information matrix of whitened Jacobians J (..., rows,
    p) with the priors' (:func:`sca.problem.with_priors`).

    The package's information matrices, and why there are three entries to it:

    * :meth:`sca.problem.Problem.evaluate`'s H: the same sum, built by each layout's
      :meth:`~sca.problem.Problem.data_terms` in theta's coordinates (C as u = C^e0) with the
      linear unknowns (gain, veiling light) projected out in closed form, plus the auxiliary
      measurements' terms: what the fit, the intervals and the derived quantities use;
    * :func:`profiled_information`: this sum in the parameters' own units (C itself) of a
      Jacobian from :meth:`ChartModel.predict`, the active channels' veiling light projected
      out of the columns (the single chart's covariance and :func:`sca.precision`'s bound,
      which have no problem to evaluate);
    * :func:`sca.budget.variance_shares`: this sum (through :func:`covariance`) with the veiling
      light as explicit indicator columns, not projected out, because each data row's and each
      prior's share of the variance is read from S Jw^T row by row.

    Parameters
    ----------
    J : array_like, (..., rows, p)
    prior_weight : array_like, broadcastable to (..., p), optional

    Returns
    -------
    ndarray, (..., p, p)
    """
    J = np.asarray(J, float)
    return with_priors(np.swapaxes(J, -1, -2) @ J, prior_weight)


def covariance_from_information(F, sigma2=1.0, *, cond_max: float = COND_MAX):
    """sigma^2 F^-1: the one rule by which an information matrix is inverted.

    F is scaled to unit diagonal (Jacobi) before it is inverted, so whether it counts as
    singular does not depend on the parameters' units; singular (undetermined) problems give
    infinite variances.

    Parameters
    ----------
    F : array_like, (..., p, p)
        Information matrices (J^T J plus the priors' weights: an evaluation's Gauss-Newton
        matrix, :meth:`sca.problem.Problem.evaluate`).
    sigma2 : float or array_like, broadcastable to the leading shape ``...``
        Noise variance in the units of the whitening (1 where the noise is known).
    cond_max : float, optional
        Largest condition number of the unit-diagonal F that is inverted (default
        :data:`COND_MAX`).

    Returns
    -------
    ndarray, (..., p, p)
        The covariance; every entry ``inf`` where F is singular, ill-conditioned, non-finite
        or has a zero column.
    """
    F = np.asarray(F, float)
    if F.shape[-1] == 0:  # nothing free: nothing uncertain
        return np.zeros(F.shape)
    out = np.full(F.shape, np.inf)
    flat_F, flat_out = F.reshape(-1, *F.shape[-2:]), out.reshape(-1, *F.shape[-2:])
    if F.shape[-1]:
        with np.errstate(all="ignore"):
            d = np.sqrt(np.diagonal(flat_F, axis1=1, axis2=2))
            ok = np.isfinite(flat_F).all(axis=(1, 2)) & np.all(d > 0, axis=1)
            D = np.where(ok[:, None], d, 1.0)
            scaled = flat_F / (D[:, :, None] * D[:, None, :])
            ok[ok] = np.linalg.cond(scaled[ok]) < cond_max
            if ok.any():  # a tiny scale D overflows to an infinite variance, quietly
                flat_out[ok] = np.linalg.inv(scaled[ok]) / (D[ok][:, :, None] * D[ok][:, None, :])
    return out.reshape(F.shape) * np.asarray(sigma2, float)[..., None, None]


def profiled_covariance(J, w2, active, sigma2=1.0, *, gain_column=None, prior_weight=None):
    """Gauss-Newton covariance of parameters theta (and a free gain) with the backscatter of the
    ``active`` channels profiled out: the one covariance of the estimators' standard errors and
    Wald intervals and of :func:`sca.precision`'s Cramér-Rao bound.

    Parameters
    ----------
    J : ndarray, (N, m, n, p)
        d M / d theta (M = gain G + s, so already multiplied by the gain).
    w2 : ndarray, broadcastable to (N, m, n)
        Weights 1 / sigma^2.
    active : ndarray of bool, (N, m)
        Channels whose s is free (and inside its bound): their weighted mean is projected out
        of every column (equivalently, one indicator column per active channel).
    sigma2 : float or (N,)
        Noise variance in the units of ``w2`` (1 where the noise is known).
    gain_column : ndarray, (N, m, n), optional
        d M / d gain (= G) of a free gain; it becomes the last parameter.
    prior_weight : ndarray, (N, p [+ 1]), optional
        Information 1 / sd^2 of Gaussian priors on the parameters (0: none; see
        :func:`covariance`).

    Returns
    -------
    ndarray, (N, p [+ 1], p [+ 1])
        The covariance of theta (and the gain, last), in the parameters' units, from
        :func:`covariance` (``inf`` where the information is singular).

    References
    ----------
    L. Kaufman, "A variable projection method for solving separable nonlinear least squares
    problems", BIT 15 (1975) 49-57 (the linear unknowns projected out).
    """
    F = profiled_information(J, w2, active, gain_column=gain_column, prior_weight=prior_weight)
    if F.shape[-1] == 0:
        return F
    return covariance_from_information(F, sigma2)


def profiled_information(J, w2, active, *, gain_column=None, prior_weight=None):
    """The information matrix whose inverse is :func:`profiled_covariance`: J^T W J of the
    columns with the active channels' backscatter projected out, plus the priors' weights.

    Parameters
    ----------
    J, w2, active, gain_column, prior_weight :
        As :func:`profiled_covariance`.

    Returns
    -------
    ndarray, (N, p [+ 1], p [+ 1])
    """
    cols = J if gain_column is None else np.concatenate([J, gain_column[..., None]], axis=-1)
    if cols.shape[-1] == 0:
        return np.zeros(cols.shape[:1] + (0, 0))
    w2 = np.broadcast_to(np.asarray(w2, float), cols.shape[:-1])[..., None]
    a = np.asarray(active, bool)[..., None, None]
    cols = cols - a * (w2 * cols).sum(2, keepdims=True) / w2.sum(2, keepdims=True)
    N = cols.shape[0]
    return information((np.sqrt(w2) * cols).reshape(N, -1, cols.shape[-1]), prior_weight)
