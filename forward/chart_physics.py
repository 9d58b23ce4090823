"""Optional real-camera physics of a chart underwater (issue 39), each opt-in, none in the paper.

The paper's model images the chart's in-air reflectance R, lit by the downwelling light i k,
seen along a clear path. Three effects of a real photograph that it leaves out, each with its
literature model and values (no constant here was fitted to any photograph):

* **The chart's reflectance in water** (:func:`in_water_reflectance`). A painted patch is a
  scattering body under a binder surface; its reflectance measured in air includes the surface's
  Fresnel losses on the way in (k1, external) and the internal reflection that traps light on
  the way out (k2, internal diffuse). Saunderson (1942): R = (1 - k1)(1 - k2) R_inf /
  (1 - k2 R_inf), specular reflection excluded (the chart's measurement geometry, 45/0 or d/8
  SCE). In water the index step at the surface is n_binder / n_water instead of n_binder: k1
  falls from 0.040 to 0.003 and k2 from 0.60 to about 0.2, so less light is trapped and the
  chart's darker patches rise relative to the white. R_inf is found from the air measurement,
  then put under water.
* **Forward scattering along the path** (:func:`forward_scatter_mixing`,
  :func:`forward_scatter_reflectance`). The paper's c = a + b_w + b_bp (eq 12 with Table 1 is
  the particles' *back*scattering, REALWATER.md) keeps the forward-scattered light in the beam,
  as Jaffe (1990) and McGlamery (1980) do at zero spatial frequency (their G); what it leaves
  out is the blur: a fraction phi = 1 - exp(-b_fp L) of the light reaching the camera from the
  chart was scattered forward on the way (b_fp = b_p - b_bp, b_p = b_bp / B with Petzold's
  backscattering ratio B = 0.0183) and lands displaced on the chart's image. The displacement
  of light scattered by angle theta at s metres from the chart is s tan(theta) on the chart's
  plane; theta follows the Fournier-Forand phase function with Petzold's ratio (Mobley,
  Sundman & Boss 2002), s is uniform along the path. Its effect on patch means: each patch's
  value mixes with its neighbours' and the card's (a 24 x 25 matrix, by Monte Carlo on the
  ColorChecker Classic's geometry).
* **The light on a tilted chart** (:func:`tilted_chart_light`). The model lights the chart with
  the downwelling irradiance on a horizontal plane, attenuated straight down. Daylight under
  water is a direct beam (the refracted sun, zenith theta_w) and a diffuse part (mean cosine
  0.859 below a flat surface, Kirk 2011); on a chart tilted by tau towards the sun the direct
  part falls with cos(theta_w - tau) / cos(theta_w) and the diffuse part with (1 + cos tau) /
  2, each attenuated along its own slant path (c z / mu). The direct fraction at the surface
  comes from the Rayleigh optical depth (Bodhaine et al. 1999) with half the scattered light
  reaching the ground as diffuse light.

Units: wavelengths nm; coefficients m^-1; lengths m; angles degrees.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = [
    "N_BINDER",
    "N_SEAWATER",
    "PETZOLD_BACKSCATTER_RATIO",
    "FF_N",
    "FF_MU",
    "CHART_PITCH_M",
    "PATCH_SIDE",
    "SAMPLE_SIDE",
    "CARD_MARGINS",
    "FRAME_REFLECTANCE",
    "DIFFUSE_MEAN_COSINE",
    "SUN_ZENITH_DEG",
    "fresnel",
    "diffuse_fresnel",
    "saunderson_constants",
    "in_water_reflectance",
    "fournier_forand",
    "forward_scatter_fraction",
    "forward_scatter_mixing",
    "forward_scatter_reflectance",
    "rayleigh_optical_depth",
    "tilted_chart_light",
]

#: Refractive index of a paint's binder (alkyd and acrylic binders 1.48-1.52; Saunderson 1942
#: used 1.5, which gives his k1 = 0.04 and k2 = 0.6 in air)
N_BINDER = 1.5
#: Refractive index of sea water in the visible (1.339-1.345 over 400-700 nm at 20 C and 35 PSU:
#: Quan & Fry 1995, Appl. Opt. 34:3477)
N_SEAWATER = 1.34
#: Petzold's average particle backscattering ratio b_bp / b_p (Mobley 1994, "Light and Water",
#: table 3.10)
PETZOLD_BACKSCATTER_RATIO = 0.0183
#: Fournier-Forand parameters (real index n, slope mu of the Junge distribution) whose
#: backscattering ratio is Petzold's 0.0183 (Mobley, Sundman & Boss 2002, Appl. Opt. 41:1035)
FF_N, FF_MU = 1.10, 3.5835
#: The X-Rite ColorChecker Classic: patch pitch (about 279 x 216 mm around a 6 x 4 grid of
#: ~44 mm pitch), painted square side and the measured central square (fractions of the pitch;
#: :data:`measure.chart.LAYOUTS` samples half the pitch), the card's margins beyond the grid (in
#: pitches: 0.17 left/right, 0.45 top/bottom) and the black card's reflectance (roughly)
CHART_PITCH_M = 0.044
PATCH_SIDE = 0.9
SAMPLE_SIDE = 0.5
CARD_MARGINS = (0.17, 0.45)
FRAME_REFLECTANCE = 0.03
#: Mean cosine of diffuse (uniform-sky) light just below a flat sea surface (Kirk 2011, "Light
#: and Photosynthesis in Aquatic Ecosystems", 3rd ed., sec. 2.6: 0.859)
DIFFUSE_MEAN_COSINE = 0.859
#: Sun zenith angle in air of the tilted-chart option, degrees (an assumption: a mid-morning
#: or mid-afternoon sun; the photographs' times are not recorded)
SUN_ZENITH_DEG = 30.0


# --------------------------------------------------------------------------- (a) Fresnel
def fresnel(cos_i, n):
    """Unpolarised Fresnel reflectance at incidence cosine ``cos_i`` from a medium into one of
    relative index ``n`` (> 1: into the denser; total internal reflection gives 1).

    Parameters
    ----------
    cos_i : array_like
        Cosine of the angle of incidence, in [0, 1].
    n : float
        Relative refractive index n_2 / n_1.

    Returns
    -------
    numpy.ndarray
        Reflectance, same shape.
    """
    ci = np.clip(np.asarray(cos_i, float), 0.0, 1.0)
    si2 = 1.0 - ci * ci
    ct2 = 1.0 - si2 / (n * n)
    out = np.ones_like(ci)
    ok = ct2 > 0
    ct = np.sqrt(ct2[ok])
    c = ci[ok]
    rs = ((c - n * ct) / (c + n * ct)) ** 2
    rp = ((n * c - ct) / (n * c + ct)) ** 2
    out[ok] = 0.5 * (rs + rp)
    return out


def diffuse_fresnel(n, points: int = 4000) -> float:
    """Hemispherical (diffuse, Lambertian) Fresnel reflectance of an interface of relative index
    ``n``, from the side light comes from: int R(theta) 2 sin(theta) cos(theta) dtheta.

    Parameters
    ----------
    n : float
        Relative index (< 1 from the denser side: total internal reflection counted).
    points : int, optional
        Quadrature points in cos^2(theta).

    Returns
    -------
    float
    """
    u = (np.arange(points) + 0.5) / points  # u = cos^2(theta): 2 sin cos dtheta = du
    return float(np.mean(fresnel(np.sqrt(u), n)))


def saunderson_constants(n_binder: float = N_BINDER, n_medium: float = 1.0) -> tuple:
    """Saunderson's k1 (external, normal incidence) and k2 (internal diffuse) for a binder of
    index ``n_binder`` facing a medium of index ``n_medium``.

    Parameters
    ----------
    n_binder, n_medium : float
        Refractive indices (default 1.5 and air).

    Returns
    -------
    tuple of float
        (k1, k2): k1 = ((n - 1) / (n + 1))^2, k2 = the diffuse reflectance of the interface seen
        from inside, 1 - (1 - r_d(n)) / n^2 with r_d the diffuse external reflectance (light
        leaving the denser side in a cone: Stokes' relation), n = n_binder / n_medium.
    """
    n = n_binder / n_medium
    k1 = ((n - 1.0) / (n + 1.0)) ** 2
    k2 = 1.0 - (1.0 - diffuse_fresnel(n)) / (n * n)
    return k1, k2


def in_water_reflectance(reflectance_air, *, n_binder: float = N_BINDER,
                         n_water: float = N_SEAWATER) -> np.ndarray:
    """The chart's reflectance under water from its reflectance measured in air (Saunderson).

    Parameters
    ----------
    reflectance_air : array_like
        Reflectance factors measured in air (specular excluded), in [0, 1).
    n_binder : float, optional
        The binder's refractive index (default :data:`N_BINDER`).
    n_water : float, optional
        The water's (default :data:`N_SEAWATER`).

    Returns
    -------
    numpy.ndarray
        The reflectance factors under water, same shape.

    References
    ----------
    J. L. Saunderson, "Calculation of the color of pigmented plastics", J. Opt. Soc. Am. 32
    (1942) 727-736; Fresnel's equations for k1 and k2 (e.g. Judd & Wyszecki, "Color in
    Business, Science and Industry", 1975).
    """
    R = np.asarray(reflectance_air, float)
    k1a, k2a = saunderson_constants(n_binder, 1.0)
    k1w, k2w = saunderson_constants(n_binder, n_water)
    r_inf = R / ((1.0 - k1a) * (1.0 - k2a) + k2a * R)
    return (1.0 - k1w) * (1.0 - k2w) * r_inf / (1.0 - k2w * r_inf)


# --------------------------------------------------------------------------- (b) forward scattering
def fournier_forand(theta, n: float = FF_N, mu: float = FF_MU) -> np.ndarray:
    """The Fournier-Forand phase function (sr^-1) at scattering angles ``theta`` (radians).

    Parameters
    ----------
    theta : array_like
        Scattering angles, radians, in (0, pi].
    n, mu : float, optional
        Real refractive index of the particles and slope of their Junge size distribution
        (default: Petzold's backscattering ratio, :data:`FF_N`, :data:`FF_MU`).

    Returns
    -------
    numpy.ndarray
        The phase function, normalised over the sphere.

    References
    ----------
    C. D. Mobley, L. K. Sundman and E. Boss, "Phase function effects on oceanic light fields",
    Appl. Opt. 41 (2002) 1035-1050, eq. 5.
    """
    psi = np.asarray(theta, float)
    nu = (3.0 - mu) / 2.0
    s2 = np.sin(psi / 2.0) ** 2
    d = 4.0 / (3.0 * (n - 1.0) ** 2) * s2
    d180 = 4.0 / (3.0 * (n - 1.0) ** 2)
    dn = d ** nu
    first = (nu * (1 - d) - (1 - dn) + (d * (1 - dn) - nu * (1 - d)) / s2) / (
        4 * np.pi * (1 - d) ** 2 * dn)
    second = (1 - d180 ** nu) / (16 * np.pi * (d180 - 1) * d180 ** nu) * (3 * np.cos(psi) ** 2 - 1)
    return first + second


@functools.cache
def _ff_inverse_cdf(points: int = 20000):
    """(cdf, theta): the Fournier-Forand phase function's cumulative distribution over the
    scattering angle, on a logarithmic grid of theta from 1e-6 rad to pi."""
    theta = np.geomspace(1e-6, np.pi, points)
    dens = 2 * np.pi * np.sin(theta) * fournier_forand(theta)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(theta))])
    cdf /= cdf[-1]
    return cdf, theta


def forward_scatter_fraction(particle_backscattering, path_m: float, *,
                             ratio: float = PETZOLD_BACKSCATTER_RATIO) -> np.ndarray:
    """phi(lambda): the fraction of the light reaching the camera from the chart that was
    scattered forward on the way (and lands displaced on the chart's image).

    Parameters
    ----------
    particle_backscattering : array_like
        b_bp (m^-1): eq 12 with Table 1 (:func:`forward.water.particle_scattering`).
    path_m : float
        The camera-to-chart distance, m.
    ratio : float, optional
        b_bp / b_p (default :data:`PETZOLD_BACKSCATTER_RATIO`).

    Returns
    -------
    numpy.ndarray
        1 - exp(-(b_p - b_bp) path), b_p = b_bp / ratio.
    """
    bbp = np.asarray(particle_backscattering, float)
    return -np.expm1(-(bbp / ratio - bbp) * float(path_m))


def _card_geometry():
    """Patch centres (24, 2), the painted and sampled half-sides and the card's half-size, in
    pitches, the chart's centre at 0 (x right, y down; patch 1 top left)."""
    cols, rows = 6, 4
    cx = (np.arange(24) % cols) - (cols - 1) / 2.0
    cy = (np.arange(24) // cols) - (rows - 1) / 2.0
    half = (cols / 2.0 + CARD_MARGINS[0], rows / 2.0 + CARD_MARGINS[1])
    return np.stack([cx, cy], axis=1), PATCH_SIDE / 2.0, SAMPLE_SIDE / 2.0, half


def _patch_of(points, centres, half):
    """Index (0-23) of the patch square (half-side ``half``) holding each point, -1 if none."""
    col = np.floor(points[:, 0] + 3.0).astype(int)
    row = np.floor(points[:, 1] + 2.0).astype(int)
    inside = (col >= 0) & (col < 6) & (row >= 0) & (row < 4)
    idx = np.where(inside, row * 6 + col, 0)
    d = np.abs(points - centres[idx])
    ok = inside & (d[:, 0] <= half) & (d[:, 1] <= half)
    return np.where(ok, idx, -1)


@functools.cache
def forward_scatter_mixing(path_m: float, samples: int = 40000, seed: int = 0) -> np.ndarray:
    """Where forward-scattered light lands on the ColorChecker's image.

    W[i, j] is the share of the forward-scattered light in the measured square of patch i that
    left source j (j < 24 a patch's painted square, j = 24 the black card around them); light
    from beyond the card (open water) adds nothing (its radiance is the veiling light, fitted
    apart), so rows sum to less than 1 near the card's edges. Monte Carlo with a fixed seed:
    source points uniform over each source, a scattering point uniform along the path, the
    angle from the forward hemisphere of the Fournier-Forand phase function (backward
    scattering does not reach the camera), a uniform azimuth; displacement s tan(theta) on the
    chart's plane.

    Parameters
    ----------
    path_m : float
        Camera-to-chart distance, m.
    samples : int, optional
        Samples per source (default 40 000).
    seed : int, optional
        The generator's seed.

    Returns
    -------
    numpy.ndarray, (24, 25)
        W (read-only), dimensionless.
    """
    rng = np.random.default_rng(seed)
    centres, painted, sampled, card = _card_geometry()
    cdf, theta = _ff_inverse_cdf()
    forward_share = float(np.interp(np.pi / 2, theta, cdf))
    W = np.zeros((24, 25))
    area_sampled = (2 * sampled) ** 2
    for j in range(25):
        if j < 24:
            src = centres[j] + rng.uniform(-painted, painted, size=(samples, 2))
            area = (2 * painted) ** 2
        else:  # the card around the painted squares
            src = rng.uniform([-card[0], -card[1]], [card[0], card[1]], size=(3 * samples, 2))
            src = src[_patch_of(src, centres, painted) < 0][:samples]
            area = 4 * card[0] * card[1] - 24 * (2 * painted) ** 2
        th = np.interp(rng.uniform(0.0, forward_share, src.shape[0]), cdf, theta)
        s = rng.uniform(0.0, float(path_m), src.shape[0])
        az = rng.uniform(0.0, 2 * np.pi, src.shape[0])
        rho = s * np.tan(th) / CHART_PITCH_M
        land = src + rho[:, None] * np.stack([np.cos(az), np.sin(az)], axis=1)
        hit = _patch_of(land, centres, sampled)
        counts = np.bincount(hit[hit >= 0], minlength=24) * forward_share
        W[:, j] = counts / src.shape[0] * area / area_sampled
    W.setflags(write=False)
    return W


def forward_scatter_reflectance(reflectances, phi, path_m: float) -> np.ndarray:
    """The chart's effective reflectance with forward scattering's blur on its patch means.

    R_eff(lambda, i) = (1 - phi) R_i + phi (sum_j W_ij R_j + W_i,card R_card): the share phi of
    the light from the chart that was scattered forward is spread by :func:`forward_scatter_mixing`.

    Parameters
    ----------
    reflectances : array_like, (q, 24)
        The chart's reflectances.
    phi : array_like, (q,)
        :func:`forward_scatter_fraction`.
    path_m : float
        Camera-to-chart distance, m.

    Returns
    -------
    numpy.ndarray, (q, 24)
    """
    R = np.asarray(reflectances, float)
    phi = np.asarray(phi, float)[:, None]
    W = forward_scatter_mixing(float(path_m))
    mixed = R @ W[:, :24].T + FRAME_REFLECTANCE * W[:, 24][None, :]
    return (1.0 - phi) * R + phi * mixed


# --------------------------------------------------------------------------- (c) tilted chart
def rayleigh_optical_depth(wavelengths) -> np.ndarray:
    """The atmosphere's Rayleigh optical depth at sea level (Bodhaine et al. 1999, eq. 30).

    Parameters
    ----------
    wavelengths : array_like
        nm.

    Returns
    -------
    numpy.ndarray
        tau_R (dimensionless).

    References
    ----------
    B. A. Bodhaine, N. B. Wood, E. G. Dutton and J. R. Slusser, "On Rayleigh optical depth
    calculations", J. Atmos. Oceanic Technol. 16 (1999) 1854-1861.
    """
    lam = np.asarray(wavelengths, float) / 1000.0  # micrometres
    return 0.0021520 * (1.0455996 - 341.29061 * lam ** -2 - 0.90230850 * lam ** 2) / (
        1.0 + 0.0027059889 * lam ** -2 - 85.968563 * lam ** 2)


def tilted_chart_light(wavelengths, beam_coefficient, depth: float, tilt_deg: float, *,
                       sun_zenith_deg: float = SUN_ZENITH_DEG) -> np.ndarray:
    """The light on a chart tilted by ``tilt_deg`` towards the sun, relative to the model's
    (the downwelling irradiance on a horizontal plane attenuated straight down, exp(-c z)).

    T = [f0 exp(-c z / mu_w) cos(theta_w - tau) / mu_w + (1 - f0) exp(-c z / mu_d) (1 + cos
    tau) / 2] / exp(-c z): the direct beam (zenith theta_w = asin(sin(theta_s) / n_water),
    mu_w = cos(theta_w)) and the diffuse light (mean cosine :data:`DIFFUSE_MEAN_COSINE`) each
    along its own slant path; f0, the direct share of the surface irradiance, from the Rayleigh
    optical depth: direct mu_s exp(-tau / mu_s), diffuse mu_s (1 - exp(-tau / mu_s)) / 2.

    Parameters
    ----------
    wavelengths : array_like
        nm.
    beam_coefficient : array_like
        c (m^-1) on the grid (the model's, :meth:`forward.WaterTerms.beam_coefficient`).
    depth : float
        The chart's depth, m.
    tilt_deg : float
        The chart's tilt from horizontal (0: facing up, 90: vertical, facing the sun's azimuth).
    sun_zenith_deg : float, optional
        Sun zenith angle in air (default :data:`SUN_ZENITH_DEG`).

    Returns
    -------
    numpy.ndarray
        T(lambda), the factor on the model's light at the chart.
    """
    c = np.asarray(beam_coefficient, float)
    mu_s = np.cos(np.radians(sun_zenith_deg))
    theta_w = np.arcsin(np.sin(np.radians(sun_zenith_deg)) / N_SEAWATER)
    mu_w = np.cos(theta_w)
    tau_r = rayleigh_optical_depth(wavelengths)
    direct = mu_s * np.exp(-tau_r / mu_s)
    diffuse = mu_s * -np.expm1(-tau_r / mu_s) / 2.0
    f0 = direct / (direct + diffuse)
    t = np.radians(tilt_deg)
    on_dir = max(np.cos(theta_w - t), 0.0) / mu_w
    on_dif = (1.0 + np.cos(t)) / 2.0
    z = float(depth)
    return (f0 * np.exp(-c * z * (1 / mu_w - 1)) * on_dir
            + (1 - f0) * np.exp(-c * z * (1 / DIFFUSE_MEAN_COSINE - 1)) * on_dif)
