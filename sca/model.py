"""The nonlinear measurement model of eq 15 and its Jacobian, for the estimator.

x = (C, a_CDOM(440), w) with w in R^z (eq 9). The path coefficient c(x) and dc/dx come from
:class:`forward.WaterTerms` (built by :meth:`forward.Water.on_grid`); nothing is re-derived
here:

    k(x) = exp(-L c(x)),   L = depth + distance                       (eqs 4-14)
    G(x) = P^T diag(i) diag(k(x)) R,   vec(G) = B k  with B = (P (x) R) diag(i)   (eq 15)
"""

from __future__ import annotations

import copy

import numpy as np

from forward.imaging import ChartSetup, path_length
from forward.water import Water, resolve_water

#: Floor of C (mg m^-3) at which the derivatives of C^0.627 and C^0.724 are evaluated: both
#: are infinite at C = 0 (DECISIONS.md).
CHL_DERIVATIVE_FLOOR = 1e-6


def chl_weights_u(water: Water, chl):
    """Phi (N, 4), the weights of the chlorophyll shapes of :meth:`forward.Water.chl_terms`, and
    dPhi/du with u = C^e0 (eq 10's exponent), as the batch kernels take them. In u every term's
    derivative is finite down to C = 0: the C derivatives are evaluated at the smallest normal
    float, which keeps the products exact in the limit."""
    chl = np.asarray(chl, float)
    e0 = float(water.phyto_exponent)
    tiny = np.finfo(float).tiny
    cf = np.maximum(chl, tiny)
    phi, dphi = water.chl_weights(chl, derivative=True, floor=tiny)
    return phi, dphi * (cf ** (1.0 - e0) / e0)[:, None]


class WaterModel:
    """k(x), G(x) and their derivatives for one chart setup, water model, basis and path."""

    def __init__(self, setup: ChartSetup, depth, distance, *, basis=None,
                 water: Water | None = None):
        self.setup = setup
        self.water = water = resolve_water(water)
        self.wavelengths = wl = setup.wavelengths
        self.terms = water.on_grid(wl, basis=basis)
        self.T, self.t440 = self.terms.T, self.terms.t440
        self.z = self.T.shape[1]
        self.L = np.asarray(path_length(depth, distance), dtype=float)
        self.path_model = water.path_model
        P, i, R = setup.sensitivities, setup.illuminant, setup.reflectances
        self.m, self.n = P.shape[1], R.shape[1]
        # B[(c, j), l] = P[l, c] i[l] R[l, j]: vec(G) = B @ k (row-major vec of the m x n matrix)
        self.B = np.einsum("lc,lj->cjl", P, R).reshape(self.m * self.n, wl.size) * i
        #: whitening weights 1 / sigma of vec(M) (ones: the paper's unweighted eq 15)
        #: E maps s (m,) to every patch of its channel: vec(s 1^T) = E s
        self.E = np.kron(np.eye(self.m), np.ones((self.n, 1)))
        self.wt = np.ones(self.m * self.n)
        self.noise_known = False

    def scaled(self, factor: float, sigma=None) -> "WaterModel":
        """A copy whose signals are divided by ``factor`` (the data's scale) and, with ``sigma``
        (vec, data units), whose residuals are whitened by it (weighted least squares: the
        objective is then chi^2); shares the rest."""
        new = copy.copy(self)
        new.B = self.B / factor
        if sigma is not None:
            new.wt = factor / np.asarray(sigma, float)
            new.noise_known = True
        return new

    # --- eq 17 -----------------------------------------------------------------------------
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

    # --- attenuation -----------------------------------------------------------------------
    def coefficient(self, chl, cdom, w):
        """c(x) (or a(x) for the 'absorption' path model), m^-1, shape (..., q)."""
        return self.terms.coefficient(chl, cdom, w)

    def attenuation(self, chl, cdom, w):
        """k(x) = exp(-L c(x)), shape (..., q)."""
        return np.exp(-self.L * self.coefficient(chl, cdom, w))

    def attenuation_jacobian(self, chl, cdom, w):
        """k (q,) and dk/dx (q, 2 + z), columns (C, a_CDOM, w_1..w_z).

        The C column is evaluated at max(C, CHL_DERIVATIVE_FLOOR), so it is finite at C = 0.
        """
        k = self.attenuation(chl, cdom, w)
        dc = self.terms.jacobian(chl, cdom, w, floor=CHL_DERIVATIVE_FLOOR)
        return k, (-self.L * k)[:, None] * dc

    # --- measurements ----------------------------------------------------------------------
    def signal(self, k):
        """vec(P^T diag(i) diag(k) R), shape (..., m n)."""
        return np.asarray(k) @ self.B.T

    def best_backscatter(self, M_vec, G_vec, fixed=None):
        """Closed-form s >= 0 minimising ||W (M - G - s 1^T)||_F for fixed G: per channel, the
        clipped (weighted) mean residual. ``fixed`` (m,) returns that instead. Broadcasts over leading axes."""
        if fixed is not None:
            return np.broadcast_to(fixed, G_vec.shape[:-1] + (self.m,))
        w2 = (self.wt ** 2).reshape(self.m, self.n)
        resid = (M_vec - G_vec).reshape(G_vec.shape[:-1] + (self.m, self.n))
        return np.maximum((resid * w2).sum(axis=-1) / w2.sum(axis=-1), 0.0)

    def standard_errors(self, M_vec, chl, cdom, w, s, free=(True, True), fixed_s=None,
                        gain=None):
        """Standard errors (m^-1-scaled units of C and a_CDOM) from the Gauss-Newton covariance.

        The backscatter is profiled out (its closed form: where s > 0 the channel's weighted
        mean is projected out of the Jacobian), w follows C along eq 17 (its shape held), the
        Jacobian is whitened, and sigma^2 = 1 when the noise is known, else
        ||r||^2 / (m n - p - number of free s > 0). ``gain``: the fitted gain of a free-gain fit
        (M = gain G + s; its column G joins the Jacobian, so the errors include its
        uncertainty), None where it is known. Returns (se_chl, se_cdom); a fixed parameter
        gets 0, an undetermined one inf.
        """
        g = 1.0 if gain is None else float(gain)
        _, dk = self.attenuation_jacobian(chl, cdom, w)
        alpha, dalpha = self.phyto_scale(chl, derivative=True)
        dw_dchl = np.asarray(w, float) * (float(dalpha) / float(alpha)) if alpha > 0 else \
            np.full(self.z, float(dalpha) / float(np.sum(self.t440)))
        cols = [g * (dk[:, 0] + dk[:, 2:] @ dw_dchl), g * dk[:, 1]]
        free = tuple(free)
        if gain is not None:
            cols.append(self.attenuation(chl, cdom, w))
            free = free + (True,)
        p = len(cols)
        J = np.column_stack([self.signal(c) for c in cols]).reshape(self.m, self.n, p)
        n_s = 0
        w2 = (self.wt ** 2).reshape(self.m, self.n, 1)
        if fixed_s is None:
            active = np.asarray(s) > 0
            mean = (J * w2).sum(axis=1, keepdims=True) / w2.sum(axis=1, keepdims=True)
            J = J - active[:, None, None] * mean
            n_s = int(active.sum())
        J = (J * np.sqrt(w2)).reshape(self.m * self.n, p)[:, list(np.flatnonzero(free))]
        r = self.residual(M_vec, g * self.attenuation(chl, cdom, w), s)
        dof = self.m * self.n - J.shape[1] - n_s
        out = np.zeros(p)
        if J.shape[1] == 0 or dof <= 0:
            return tuple(np.where(np.asarray(free[:2]), np.inf, 0.0))
        sigma2 = 1.0 if self.noise_known else float(r @ r) / dof
        try:
            cov = sigma2 * np.linalg.inv(J.T @ J)
            se = np.sqrt(np.maximum(np.diag(cov), 0.0))
        except np.linalg.LinAlgError:
            se = np.full(J.shape[1], np.inf)
        out[list(np.flatnonzero(free))] = se
        return float(out[0]), float(out[1])

    def residual(self, M_vec, k, s):
        """vec(M - G(k) - s 1^T), whitened: divided by sigma where the noise is known."""
        return self.wt * (M_vec - self.signal(k) - np.repeat(np.asarray(s), self.n, axis=-1))
