"""The uncertainty budget's defaults and their sources, as plain data.

They live apart from :mod:`sca.budget` (which re-exports them) so that the command line can
state them in its help without importing numpy or the physics (decision 0007-start-up).
"""

__all__ = ["DEFAULT_UNCERTAIN", "BUDGET_SOURCES", "CHART_PATCH", "MEASURED_CHART_PATCH",
           "REAL_WATER_UNCERTAIN"]

#: Real water's chlorophyll-specific absorption about eqs 10 and 8 (NASA NOMAD v2 a_phi(443)/C
#: and a_d(443)/C: ln sd 0.49 and 1.07 on the even stations, i.e. 49 % and 107 % of 0.0378 and
#: 0.0124; the odd stations test it: REALWATER.md). Not in the default: the joint fit of a dive
#: does not yet converge reliably in the valley of C against the two scales (decision
#: 0042-real-water-scales); a single chart's fit does (``uncertain={**DEFAULT_UNCERTAIN,
#: **REAL_WATER_UNCERTAIN}``).
REAL_WATER_UNCERTAIN = {"phyto_scale": 0.0185, "nap_scale": 0.0133}
#: The default budget (decision 0011-default-budget gives the sources):
#: depth 0.2 m (a dive computer's depth reading: the issue's 0.1-0.3 m); distance 5 % (a
#: measured camera-to-chart distance); eq 6's slope 0.0025 nm^-1 and eq 7's 0.0025 nm^-1 (the
#: paper's ranges 0.014-0.019 and 0.006-0.014 lie within 2 sd of its values 0.014 and 0.011);
#: the camera's channel balance 1 % (a profile from another day); each channel's curve shifted
#: by 1 nm (the wavelength scale of a measured sensitivity); the surface daylight's colour
#: temperature 30 mired about the illuminant given (D65, 154 mired: 5500-8000 K within one
#: sd, a D50 sky 1.5 sd away, a low sun of 4000 K 3.2 sd; global daylight's CCT runs from
#: ~4000 K to beyond 10 000 K, 5700 K the most typical, Hernandez-Andres et al. 2001); per-patch
#: 1 % (a ColorChecker's reflectance tolerance, 0.1-0.7 %, camera-curve error of about 1 nm and
#: the daylight's spectral variation beyond its colour, in quadrature). Real water's scatter about eqs 8 and 10
#: (:data:`REAL_WATER_UNCERTAIN`) is not in it yet (decision
#: 0042-real-water-scales).
DEFAULT_UNCERTAIN = {
    "depth": 0.2,
    "distance": "5%",
    "cdom_slope": 0.0025,
    "nap_slope": 0.0025,
    "balance": 0.01,
    "camera_shift": 1.0,
    "daylight": 30.0,
    "patch": 0.01,
}
#: Where each default comes from (recorded with every result's budget).
BUDGET_SOURCES = {
    "depth": "dive computer depth reading, 0.1-0.3 m",
    "distance": "camera-to-chart distance measured to about 5 %",
    "cdom_slope": "Blasinski & Farrell eq 6: 0.014-0.019 nm^-1",
    "nap_slope": "Blasinski & Farrell eq 7: 0.006-0.014 nm^-1",
    "balance": "camera channel balance from a profile of another day, ~1 %",
    "camera_shift": "wavelength scale of measured camera curves, ~1 nm per channel",
    "daylight": "surface daylight's colour temperature, 30 mired (global daylight 4000 K to "
                "beyond 10 000 K, 5700 K typical: Hernandez-Andres et al., JOSA A 18 (2001) 1325)",
    "patch": "chart reflectance tolerance, camera-curve error and daylight, ~1 % per patch",
}
#: The chart's own part of the default per-patch term, relative: its reflectance tolerance
#: (0.1-0.7 %, the upper end). It is the same error in every photo of a dive; the rest of
#: ``patch`` (the camera curves' error and the daylight's spectrum beyond its colour, which act
#: through the spectrum of the light at the chart and so change with each photo's path) is each
#: photo's own: the joint fit's default ``patch_correlation`` is (CHART_PATCH / patch)^2
#: (decision 0054-patch-correlation).
CHART_PATCH = 0.007
#: The per-patch term of the default budget when the chart's own spectra were measured with a
#: spectrometer (``measure.measure(chart_reflectance=...)``, ``--chart-reflectance``): 0.7 %,
#: the default's 1 % with the chart's reflectance tolerance at its upper end (0.7 %) taken out
#: in quadrature (sqrt(1.0^2 - 0.7^2) = 0.71 %); what stays is the camera curves' error beyond
#: their shift, the daylight's spectral variation beyond its colour and the spectrometer's own
#: reading. Between the 0.5 % at which the independent renderer's clean world (the chart known
#: exactly) is covered at the nominal rate and the 1 % kept for a chart known only nominally
#: (decision 0051-measured-chart). A camera profile's measured ``patch_sd`` raises it, never
#: lowers it (``measure.budget_for``; decision 0053-patch-floor).
MEASURED_CHART_PATCH = 0.007
