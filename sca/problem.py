"""The inference layer's problem: N independent units of a penalised least-squares fit.

A problem knows no physics. Each unit (one chart of a batch, one dive, one K_d spectrum) has
free parameters theta (columns named by :attr:`Problem.names`; a name of several values, such
as a camera's per-channel ``balance``, repeats), and the objective

    f(theta) = ||r(theta)||^2 + sum_j w_j (theta_j - mu_j)^2,

r the unit's whitened residual (the layout's :meth:`Problem.data_terms`: its model function
called by name, its noise, its closed-form linear unknowns) and the Gaussian priors of the
uncertainty budget (:attr:`Problem.prior_mean`, :attr:`Problem.prior_weight`; added here, the one
place they are). A column may be iterated in a power coordinate u = x^e (C in u = C^e0, eq 10's
exponent: every C term is smooth in u at C = 0; :attr:`Problem.powers`): :func:`undo_powers`
(for :meth:`Problem.params`, and for interval ends through :func:`sca.intervals.own_units`) and
the chain rule :meth:`Problem.chain` are the one place it is undone.

Everything that fits, bounds or assesses a problem takes one of these: the Levenberg-Marquardt of
:mod:`sca.lm`, the profile-likelihood ends of :mod:`sca.intervals` and the covariance of
:func:`sca.model.covariance` (Cramér-Rao bounds included). The layouts are
:class:`sca.charts.ChartProblem` (a chart, or a batch of them), :class:`sca.diveproblem.DiveProblem`
(the photographs of a dive, sharing the water) and :class:`sca.spectral.SpectrumProblem` (a
measured K_d spectrum).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from forward.errors import InputError

__all__ = ["Evaluation", "Observation", "Problem", "chl_from_u", "du_chain", "u_from_chl",
           "observation_terms", "undo_powers", "with_priors"]

#: Smallest normal float: where C = 0, d/du is evaluated at C = TINY (finite, exact in the limit).
TINY = np.finfo(float).tiny


def u_from_chl(chl, e0):
    """The coordinate u = max(x, 0)^e0 of a power-coordinate parameter (C: eq 10's exponent).

    Parameters
    ----------
    chl : float or array_like
        The parameter (e.g. C, mg m^-3; negative values count as 0).
    e0 : float
        The exponent (> 0; ``Water.phyto_exponent``, 0.627 in the paper, for C).

    Returns
    -------
    ndarray
        u, same shape as ``chl``.
    """
    return np.maximum(np.asarray(chl, float), 0.0) ** e0


def chl_from_u(u, e0):
    """x = u^(1 / e0): the inverse of :func:`u_from_chl`.

    Parameters
    ----------
    u : float or array_like
        The coordinate; values <= 0 (and NaN) give 0.
    e0 : float
        The exponent, > 0.

    Returns
    -------
    ndarray or numpy.float64
        x, same shape as ``u`` (a scalar for a scalar ``u``).
    """
    return np.fmax(u, 0.0) ** (1.0 / e0)


def undo_powers(x, powers):
    """Values in their own units from theta's coordinates: :func:`chl_from_u` where a column's
    exponent is > 0 (a power coordinate), the value itself where it is 0.

    Parameters
    ----------
    x : ndarray
        Values in theta's coordinates (columns, or interval ends, of a problem).
    powers : ndarray, broadcastable to ``x``
        Each value's exponent (:attr:`Problem.powers`; 0: its own coordinate).

    Returns
    -------
    ndarray
        The values in their own units (a power coordinate's values <= 0 give 0).
    """
    return np.where(powers > 0, chl_from_u(x, np.where(powers > 0, powers, 1.0)), x)


def with_priors(F, prior_weight):
    """F + diag(prior_weight): an information (Gauss-Newton) matrix with Gaussian priors'
    information 1 / sd^2 on its diagonal, the one place priors enter one
    (:meth:`Problem.evaluate`, :func:`sca.model.information`).

    Parameters
    ----------
    F : ndarray, (..., p, p)
    prior_weight : array_like, broadcastable to (..., p), or None (no priors: F itself)

    Returns
    -------
    ndarray, (..., p, p)
    """
    if prior_weight is None:
        return F
    return F + np.asarray(prior_weight, float)[..., None] * np.eye(F.shape[-1])


def du_chain(chl, e0):
    """dx/du = x^(1 - e0) / e0 at x, the chain-rule factor of the coordinate u = x^e0.

    Evaluated at max(x, :data:`TINY`), so that a derivative times it is finite at x = 0.

    Parameters
    ----------
    chl : float or array_like
        x (e.g. C, mg m^-3).
    e0 : float
        The exponent, > 0.

    Returns
    -------
    ndarray
        dx/du, same shape as ``chl``.
    """
    return np.maximum(chl, TINY) ** (1.0 - e0) / e0


@dataclass
class Observation:
    """An auxiliary measurement of a quantity derived from the parameters: y +- sd.

    It adds ((h(theta) - y) / sd)^2 to the objective of its unit, as the priors do (a prior is
    the observation of a parameter itself): a water sample's a_CDOM(440), a Secchi depth, a
    radiometer's K_d (:mod:`sca.auxiliary` builds them from the one physics).

    Attributes
    ----------
    name : str
        What was measured (for reports).
    value : ndarray, (N,)
        The measurement of every unit (NaN: none for that unit).
    sd : ndarray, (N,)
        Its standard deviation, in its units (> 0).
    function : callable
        ``function(params, wrt) -> (h (k,), {name: d h / d name (k,)})``: the quantity at the
        model's parameters of k units (their own units) and its derivatives by the names
        ``wrt``.
    """

    name: str
    value: np.ndarray
    sd: np.ndarray
    function: object

    def rows(self, idx) -> "Observation":
        """The observation of units ``idx`` (a value or sd given once for all units stays one)."""
        value, sd = np.asarray(self.value), np.asarray(self.sd)
        return Observation(self.name, value[idx] if value.ndim else value,
                           sd[idx] if sd.ndim else sd, self.function)


@dataclass
class Evaluation:
    """What :meth:`Problem.evaluate` returns for units ``idx``.

    Attributes
    ----------
    f : ndarray, (k,)
        The objective (chi^2 where the noise is known, plus the priors' terms).
    g : ndarray, (k, p) or None
        J^T r + W (theta - mu): half the gradient of f (None without ``grad``).
    H : ndarray, (k, p, p) or None
        J^T J + diag W: the Gauss-Newton matrix (None without ``grad``).
    extras : dict
        The layout's by-products (a chart's closed-form gain and backscatter, its unweighted
        sum of squares, its attenuation, ...).
    """

    f: np.ndarray
    g: np.ndarray | None
    H: np.ndarray | None
    extras: dict = field(default_factory=dict)


class Problem:
    """N units of a penalised least-squares fit (a base class: a layout supplies the data).

    Parameters
    ----------
    names : sequence of str
        Free parameters, in the order of theta's columns (a name of k values repeats k times).
    fixed : dict
        name -> (N,) or (N, k) values of every other parameter the layout's model needs.
    prior_mean : ndarray, (N, p), optional
        Centre of each column's Gaussian prior, in theta's coordinates (None: no priors).
    prior_weight : ndarray, (N, p), optional
        1 / sd^2 of each column's prior (0: none on that column).
    observations : sequence of Observation, optional
        Auxiliary measurements of derived quantities (added to the objective as the priors).

    Attributes
    ----------
    lower : ndarray, (p,)
        Lower bound of each column (:meth:`lower_bound`).
    powers : ndarray, (p,)
        The exponent e of a column iterated in u = x^e, 0 for its own coordinate
        (:meth:`power`).
    free : tuple of str
        The distinct names, in column order.

    Notes
    -----
    A layout sets its own attributes (those :meth:`lower_bound`, :meth:`power` and
    :attr:`size` read) before calling ``Problem.__init__``.
    """

    def __init__(self, names, fixed, prior_mean=None, prior_weight=None, observations=()):
        self.names = tuple(names)
        self.fixed = dict(fixed)
        self.prior_mean, self.prior_weight = prior_mean, prior_weight
        self.observations = [o if isinstance(o, Observation) else Observation(*o)
                             for o in observations]
        for o in self.observations:
            o.value = np.broadcast_to(np.asarray(o.value, float), (self.size,))
            o.sd = np.broadcast_to(np.asarray(o.sd, float), (self.size,))
            if np.any(~(o.sd[np.isfinite(o.value)] > 0)):
                raise InputError("observations", f"{o.name}'s sd must be > 0")
        self.lower = np.array([self.lower_bound(n) for n in self.names], float)
        self.powers = np.array([self.power(n) for n in self.names], float)
        self.free = tuple(dict.fromkeys(self.names))
        if (prior_mean is None) != (prior_weight is None):
            raise InputError("prior_mean, prior_weight", "give both or neither")
        if prior_mean is not None:
            shape = (self.size, len(self.names))
            for name in ("prior_mean", "prior_weight"):
                a = np.asarray(getattr(self, name), float)
                if a.shape != shape:
                    raise InputError(name, f"expected shape {shape}, got {a.shape}")
                setattr(self, name, a)

    # ------------------------------------------------------------------ a layout's choices
    def lower_bound(self, name: str) -> float:
        """The lower bound of parameter ``name`` (default: none)."""
        return -np.inf

    def power(self, name: str) -> float:
        """The exponent e of ``name``'s coordinate u = x^e, or 0 (its own coordinate)."""
        return 0.0

    @property
    def size(self) -> int:
        """N, the number of units."""
        raise NotImplementedError

    def rows(self, idx) -> dict:
        """The layout's own per-unit arrays of units ``idx`` (for :meth:`subset`)."""
        raise NotImplementedError

    def data_terms(self, idx, theta, params, chain, grad: bool) -> Evaluation:
        """The data's part of the objective of units ``idx``: ||r||^2, J^T r and J^T J in
        theta's coordinates (``chain`` (k, p): the factor of each column, :meth:`chain`)."""
        raise NotImplementedError

    # ------------------------------------------------------------------ the generic part
    def subset(self, idx) -> "Problem":
        """The units ``idx`` as a problem of their own."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.__dict__.update(self.rows(idx))
        new.fixed = {k: np.asarray(v)[idx] for k, v in self.fixed.items()}
        for name in ("prior_mean", "prior_weight"):
            a = getattr(self, name)
            setattr(new, name, None if a is None else a[idx])
        new.observations = [o.rows(idx) for o in self.observations]
        return new

    def params(self, idx, theta) -> dict:
        """The model's parameters of units ``idx`` at ``theta`` (k, p): name -> (k,) or (k, c)
        values in their own units (power coordinates undone), the fixed ones included."""
        out = {k: np.asarray(v)[idx] for k, v in self.fixed.items()}
        for name in self.free:
            cols = self.columns(name)
            x = theta[:, cols]
            power = self.powers[cols]
            if np.any(power > 0):
                x = undo_powers(x, power)
            out[name] = x if len(cols) > 1 else x[:, 0]
        return out

    def columns(self, name: str) -> list:
        """The columns of theta that hold ``name`` (in order)."""
        cache = self.__dict__.get("_columns")
        if cache is None or cache[0] is not self.names:  # built once per tuple of names
            cache = (self.names, {})
            for j, n in enumerate(self.names):
                cache[1].setdefault(n, []).append(j)
            self._columns = cache
        return list(cache[1].get(name, ()))

    def chain(self, params) -> np.ndarray:
        """(k, p) factors d x / d theta of every column: 1, or dx/du for a power coordinate."""
        k = len(next(iter(params.values()))) if params else 0
        out = np.ones((k, len(self.names)))
        for name in {self.names[j] for j in np.flatnonzero(self.powers > 0)}:
            cols = self.columns(name)
            x = np.asarray(params[name], float).reshape(k, len(cols))
            out[:, cols] = du_chain(x, self.powers[cols])
        return out

    def evaluate(self, idx, theta, grad: bool = True) -> Evaluation:
        """Objective, half gradient and Gauss-Newton matrix of units ``idx`` at ``theta``.

        Parameters
        ----------
        idx : array_like of int, (k,)
            The units.
        theta : ndarray, (k, p)
            Their parameters (theta's coordinates).
        grad : bool, optional
            Also g and H (default True).

        Returns
        -------
        Evaluation
        """
        idx = np.asarray(idx, np.int64)
        theta = np.asarray(theta, float)
        params = self.params(idx, theta)
        chain = self.chain(params) if grad or self.observations else None
        ev = self.data_terms(idx, theta, params, chain, grad)
        if self.prior_mean is not None:
            pw = self.prior_weight[idx]
            d = theta - self.prior_mean[idx]
            ev.f = ev.f + np.einsum("ip,ip->i", pw, d * d)
            if grad:
                ev.g = ev.g + pw * d
                ev.H = with_priors(ev.H, pw)
        for obs in self.observations:
            self._observe(obs, idx, params, chain, ev, grad)
        if not grad:
            ev.g = ev.H = None
        return ev

    def _observe(self, obs: Observation, idx, params, chain, ev: Evaluation, grad: bool):
        """An auxiliary measurement's term ((h - y) / sd)^2 (:func:`observation_terms`), its
        half gradient and Gauss-Newton matrix, added to ``ev``."""
        terms = observation_terms(obs, idx, params, self.columns, chain,
                                  self.free if grad else ())
        if terms is None:
            return
        r, J = terms
        ev.f = ev.f + np.einsum("kg,kg->k", r, r)
        if grad:
            ev.g = ev.g + np.einsum("kgp,kg->kp", J, r)
            ev.H = ev.H + np.einsum("kgp,kgq->kpq", J, J)


def observation_terms(obs: Observation, idx, params, columns, chain, wrt=()):
    """An auxiliary measurement's whitened residual and Jacobian: the one place its term is
    written (:meth:`Problem.evaluate` adds r^2, J^T r and J^T J; :func:`sca.precision` adds
    J^T J to its information).

    Units without a measurement (value NaN) add nothing. Where a unit holds G waters (a dive
    fitted with a (C, a_CDOM) per group of photos: 'chl' and 'cdom' repeat G times), h is
    (k, G) and the measurement is of each of them: one term per group, its derivatives on
    that group's columns (a name of one column, a shared nuisance, takes every group's).

    Parameters
    ----------
    obs : Observation
        The measurement (its value and sd one or one per unit).
    idx : array_like of int, (k,)
        The units.
    params : dict
        The model's parameters of the units (own units).
    columns : callable
        name -> the theta columns that hold it (:meth:`Problem.columns`).
    chain : ndarray, (k, p)
        d x / d theta of every column (:meth:`Problem.chain`; ones in the own units).
    wrt : sequence of str, optional
        The names to differentiate by (none: no Jacobian).

    Returns
    -------
    (r, J) or None
        r = (h - y) / sd (k, G); J = d r / d theta (k, G, p), None without ``wrt``; None
        where no unit has a measurement.
    """
    k = len(idx)
    sub = obs.rows(idx)
    y, sd = (np.broadcast_to(np.asarray(v, float), (k,)) for v in (sub.value, sub.sd))
    have = np.isfinite(y)
    if not have.any():
        return None
    h, dh = obs.function(params, wrt)
    h = np.asarray(h, float).reshape(k, -1)  # (k, G)
    r = np.where(have[:, None], (h - y[:, None]) / np.where(have, sd, 1.0)[:, None], 0.0)
    if not wrt:
        return r, None
    G = h.shape[1]
    J = np.zeros((k, G, chain.shape[1]))
    for n in dh:
        cols = columns(n)
        d = np.broadcast_to(np.asarray(dh[n], float).reshape(k, -1), h.shape)
        for g in range(G):
            for j in ([cols[g]] if G > 1 and len(cols) == G else cols):
                J[:, g, j] = np.where(have, d[:, g] * chain[:, j] / sd, 0.0)
    return r, J
