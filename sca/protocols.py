"""Designs that reach a precision: which protocol (photos x depths x distances, with or without
an auxiliary measurement) measures C, a_CDOM(440) and the path's attenuation coefficient to the
95 % precision asked, and what one photo gives.

The space searched (small and documented):

* a **depth ladder** of n depths within the range given: the first n of a fixed sequence that
  starts at the best single depth (of the range's ends, middle and quarters, by the one-photo
  prediction of the targets) and goes on with the range's deepest and shallowest ends, its
  middle, then the middle of every gap in turn (:func:`ladder`). Every ladder holds the smaller
  ones, so adding a depth never loses information;
* each depth photographed from **one of the distances** given, or from each of two;
* **auxiliary measurements** (:data:`AUXILIARY_OPTIONS`): none, a Secchi depth, a water
  sample's a_CDOM(440), or both (:mod:`sca.auxiliary`; their sds :data:`SAMPLE_SD` and
  :data:`SECCHI_READING_REL` unless given);
* at most ``max_photos`` photos (:data:`MAX_PHOTOS`; depths x distances);
* with ``reference_shot``, a chart photographed in air at the site (:mod:`sca.reference`) in
  every protocol: the daylight's prior becomes the one a reference shot will measure
  (:func:`sca.reference.planned`), and the design without it is given beside
  (:attr:`Design.without_reference`).

**Cost**: fewest photos, then the auxiliary measurements in the order of
:data:`AUXILIARY_OPTIONS` (nothing; a Secchi disk, a minute at the surface; a water sample,
a laboratory's spectrophotometer; both), then the better precision.

**Prediction** of each protocol: the Cramér-Rao bound of the estimator that will be used
(:func:`sca.precision`: the joint estimate of a dive, each photo's exposure free; one photo with
the ``gain`` given), with the budget and the auxiliary measurements' information. Where a
budget applies the estimators compare path models and report the union of the intervals of
every model the data cannot reject (:mod:`sca.pathmodels`); the prediction includes that span:
each other path model is fitted to the protocol's noise-free photos (``sca.precision(...,
path_model=)``), and where its chi^2 there (the noncentrality of its misfit) is below
:data:`sca.pathmodels.PATH_MODEL_DELTA` the median dive will not reject it, so the predicted
interval is the union of both models' (C and a_CDOM: value +- 1.96 sd clipped at 0; the derived
quantities: the delta method on their logarithm, as the estimators build them). The predicted
95 % half-width of a quantity is half its predicted interval, relative to the truth. Without a
budget (``uncertain={}``, the camera-only bound) the estimators fit the water's own path model
only, and the prediction is the bound.

**Search**: the bound falls as photos or measurements are added to a protocol (nested
ladders), and a prediction is never narrower than its bound. So for every distance set and
auxiliary option the fewest depths whose bound meets every target are found by bisection, and
the predictions (with the span) are checked from there in the order of cost; the first that
meets every target is the design. Where none does, the design says so, with the most precise
protocol of the space and what limits it (:func:`design`'s ``limiting``).

References
----------
S. M. Kay, Fundamentals of Statistical Signal Processing: Estimation Theory (1993), ch. 3.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from forward import validate
from forward.imaging import ChartSetup, length, resolve_setup
from forward.sensor import SensorSettings
from forward.spectra import DEFAULT_CAMERA
from forward.water import PATH_MODELS, Water, resolve_water

from .bound import Z95, Precision, precision
from .budget import DEFAULT_UNCERTAIN
from .derived import BANDS_NM, QUANTITIES, is_optical_depth
from .pathmodels import PATH_MODEL_DELTA
from forward.errors import InputError

__all__ = ["AUXILIARY_OPTIONS", "C_BANDS", "MAX_PHOTOS", "SAMPLE_SD", "SECCHI_READING_REL",
           "TARGETS", "Design", "Prediction", "Protocol", "design", "ladder"]

#: The auxiliary options, cheapest first: nothing; a Secchi depth (a disk and a line, a
#: minute at the surface); a water sample's a_CDOM(440) (filtered, a laboratory's
#: spectrophotometer); both.
AUXILIARY_OPTIONS = ("none", "secchi", "sample", "sample+secchi")
#: Most photos of a protocol (a dive's worth of charts).
MAX_PHOTOS = 12
#: Default sd of a water sample's a_CDOM(440), m^-1: 0.015, the middle of 0.01-0.02 m^-1, what
#: a filtered sample in a 10 cm cuvette of a benchtop spectrophotometer gives (the README's
#: example ``--cdom-sample 0.12:0.02``); 0.0025 m^-1 is the precision of underway long-path
#: spectrophotometry against independent data (Dall'Olmo et al. 2017, Optics Express), which a
#: diver's sample rarely has (decision 0075-design-reference-shot).
SAMPLE_SD = 0.015
#: Default sd of a Secchi reading relative to the depth read (an assumption: the reading
#: itself; the relation's own scatter, :data:`sca.auxiliary.SECCHI_GAMMA_REL` = 20 %, is added
#: by :func:`sca.auxiliary.secchi_observation` and dominates).
SECCHI_READING_REL = 0.10
#: The bands of the target ``'c'``: every standard band of the path's attenuation
#: coefficient (:data:`sca.derived.BANDS_NM`).
C_BANDS = tuple(f"c_{b:.0f}" for b in BANDS_NM)
#: Names a target may have: C ('chl'), a_CDOM(440) ('cdom'), 'c' (the path's attenuation
#: coefficient at every standard band: the worst of them) and every derived quantity but the
#: optical depths (a photo's tau depends on its own depth and distance; a design's targets are
#: the water's).
TARGETS = ("chl", "cdom", "c") + tuple(q for q in QUANTITIES if not is_optical_depth(q))
#: Where the best single depth is looked for: these fractions of the depth range.
SINGLE_DEPTH_FRACTIONS = (1.0, 0.0, 0.5, 0.25, 0.75)


def ladder(lo: float, hi: float, n: int, first: float | None = None) -> tuple:
    """The first ``n`` depths of the design's sequence in [lo, hi].

    Parameters
    ----------
    lo, hi : float
        The depth range, m (``lo == hi``: every photo at that depth).
    n : int
        Depths (>= 1).
    first : float, optional
        The sequence's first depth (the best single depth); default ``hi``.

    Returns
    -------
    tuple of float
        ``first``, then hi, lo, (lo + hi) / 2 and the middle of every gap in turn (each depth
        once), the first ``n`` of them: every ladder holds the smaller ones.
    """
    if n < 1:
        raise InputError("n", f"a ladder has at least one depth, got {n}")
    if lo == hi:
        return (float(hi),) * n
    seq = [float(hi) if first is None else float(first)]
    gaps = [(float(lo), float(hi))]
    for d in (float(hi), float(lo)):
        if d not in seq:
            seq.append(d)
    while len(seq) < n:
        nxt = []
        for a, b in gaps:
            mid = 0.5 * (a + b)
            if mid not in seq:
                seq.append(mid)
            nxt += [(a, mid), (mid, b)]
        gaps = nxt
    return tuple(seq[:n])


@dataclass(frozen=True)
class Protocol:
    """What to do on the dive.

    Attributes
    ----------
    depths : tuple of float
        The depth ladder, m (each depth photographed from every distance).
    distances : tuple of float
        The camera-to-chart distances, m.
    auxiliary : str
        One of :data:`AUXILIARY_OPTIONS`.
    """

    depths: tuple
    distances: tuple
    auxiliary: str = "none"

    @property
    def n_photos(self) -> int:
        """Photos: depths x distances."""
        return len(self.depths) * len(self.distances)

    @property
    def photos(self) -> list:
        """(depth, distance) of every photo, m."""
        return [(d, r) for d in self.depths for r in self.distances]

    def describe(self) -> str:
        """The protocol in words, e.g. '4 photos: at 2, 6.3, 10.5 and 15 m, each from 1 and 3 m,
        with a water sample's a_CDOM(440)'."""
        depths = sorted(set(self.depths))
        ds = _words([f"{d:g}" for d in depths]) + " m"
        rs = _words([f"{r:g}" for r in self.distances]) + " m"
        n = self.n_photos
        if n == 1:
            where = f"1 photo at {ds} from {rs}"
        elif len(depths) == 1 and len(self.distances) == 1:
            where = f"{n} photos, all at {ds} from {rs}"
        elif len(self.distances) == 1:
            where = f"{n} photos at {ds}, from {rs}"
        else:
            where = f"{n} photos at {ds}, each from {rs}"
        aux = {"none": "", "secchi": ", with a Secchi depth",
               "sample": ", with a water sample's a_CDOM(440)",
               "sample+secchi": ", with a water sample's a_CDOM(440) and a Secchi depth"}
        return where + aux[self.auxiliary]


def _words(items) -> str:
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


@dataclass
class Prediction:
    """What a protocol is predicted to give.

    Attributes
    ----------
    protocol : Protocol
    rel95 : dict
        name -> the predicted 95 % half-width relative to the truth of 'chl', 'cdom', 'c'
        and every derived quantity (the estimators' interval: the union over the path models
        the median dive cannot reject).
    bound_rel95 : dict
        The same from the Cramér-Rao bound alone (the water's own path model).
    span : tuple of str
        The path models whose intervals the prediction unites (the water's own first).
    meets : bool
        Every target met by ``rel95``.
    precision : sca.Precision
        The bound (the water's own path model).
    """

    protocol: Protocol
    rel95: dict
    bound_rel95: dict
    span: tuple
    meets: bool
    precision: Precision

    def worst(self, targets: dict) -> float:
        """The largest ratio of predicted half-width to target (<= 1: every target met)."""
        return max(self.rel95[k] / v for k, v in targets.items())


@dataclass
class Design:
    """The answer of :func:`design`.

    Attributes
    ----------
    chl, cdom : float
        The water guessed: C (mg m^-3), a_CDOM(440) (m^-1).
    targets : dict
        name -> 95 % half-width asked for, relative (0.3: +-30 %).
    protocol : Prediction or None
        The cheapest protocol that meets every target (None: none of the space does).
    one_photo : Prediction
        What one photo gives (the best single depth and distance, no auxiliary measurement).
    best : Prediction
        ``protocol`` where one meets every target; else the most precise protocol of the space
        (the worst target's ratio the smallest).
    limiting : str
        Where no protocol meets the targets, what limits ``best``: a budget source (the one
        whose exact knowledge narrows the worst target most), 'path model' (the photos cannot
        tell the path models apart: the bound alone would meet the target), 'noise' (the
        camera-only bound) or 'no water' (depth and distance 0); '' where a protocol meets
        them.
    without_limiting : float
        The worst target's bound half-width of ``best`` with that source known exactly
        (relative; NaN for 'path model', 'noise' and '').
    depth_range : tuple of float
        (lo, hi), m.
    distances : tuple of float
        m.
    uncertain : dict
        The budget (name -> sd); {} for the camera-only bound.
    auxiliary_sd : dict
        'sample' (m^-1) and 'secchi' (m): the sds of the auxiliary measurements searched.
    searched : list of Prediction
        Every protocol whose prediction (with the span) was computed.
    bounds : int
        How many bounds the search evaluated.
    one_photo_budget : sca.Precision
        One photo's single-chart bound (its budget shares and limiting source).
    reference_shot : bool
        The protocols include a reference shot (the daylight's prior of
        :func:`sca.reference.planned`).
    without_reference : Design or None
        With ``reference_shot``, the same design without it (what the shot buys).
    """

    chl: float
    cdom: float
    targets: dict
    protocol: Prediction | None
    one_photo: Prediction
    best: Prediction
    limiting: str
    without_limiting: float
    depth_range: tuple
    distances: tuple
    uncertain: dict
    auxiliary_sd: dict
    searched: list = field(default_factory=list)
    bounds: int = 0
    one_photo_budget: Precision | None = None
    reference_shot: bool = False
    without_reference: "Design | None" = None

    @property
    def meets(self) -> bool:
        """A protocol of the space meets every target."""
        return self.protocol is not None

    @property
    def camera_only(self) -> bool:
        """The bound of photon and read noise alone (``uncertain={}``)."""
        return not self.uncertain


def _check_targets(targets) -> dict:
    if targets is None:
        return {"chl": 0.30}
    if not isinstance(targets, dict) or not targets:
        raise InputError("targets", "expected a dict like {'chl': 0.3} (relative 95 % "
                         "half-widths)")
    out = {}
    for k, v in targets.items():
        if k not in TARGETS:
            raise InputError("targets", f"unknown name {k!r}; choose from {TARGETS}")
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise InputError("targets", f"{k!r} must be a number, got {v!r}") from None
        if not np.isfinite(v) or v <= 0:
            raise InputError("targets", f"{k!r} must be a relative half-width > 0 (0.3 for "
                             f"+-30 %), got {v!r}")
        out[k] = v
    return out


def _range(name, value) -> tuple:
    try:
        v = np.atleast_1d(np.asarray(value, float))
    except (TypeError, ValueError):
        raise InputError(name, f"expected one length or two (m), got {value!r}") from None
    if v.ndim != 1 or not 1 <= v.size <= 2:
        raise InputError(name, f"expected one length or two (m), got {value!r}")
    return tuple(float(length(name, float(x))) for x in v)


def _intervals(p: Precision) -> dict:
    """name -> (lo, hi) of 'chl', 'cdom' and every quantity under the model of ``p`` (at its
    ``fitted`` optimum where another path model was fitted)."""
    out = {}
    for name, sd in (("chl", p.chl_sd), ("cdom", p.cdom_sd)):
        centre = float(p.fitted.get(name, getattr(p, name)))
        sd = float(sd)
        out[name] = (max(centre - Z95 * sd, 0.0), centre + Z95 * sd)
    for name, value in p.quantities.items():
        value, sd = float(value), float(p.quantity_sd[name])
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            r = Z95 * sd / value if value > 0 else np.inf
            out[name] = (value * np.exp(-r), value * np.exp(r)) if np.isfinite(r) else \
                (0.0, np.inf)
    return out


def _half_widths(intervals: list, truth: dict) -> dict:
    """name -> half the union's width relative to the truth; 'c': the worst band."""
    out = {}
    for name, value in truth.items():
        lo = min(iv[name][0] for iv in intervals)
        hi = max(iv[name][1] for iv in intervals)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[name] = float((hi - lo) / 2 / value) if value > 0 else float("inf")
        if not np.isfinite(out[name]):
            out[name] = float("inf")
    out["c"] = max(out[b] for b in C_BANDS)
    return out


def design(chl, cdom, *, reference_shot: bool = False, reference_minutes=None,
           uncertain=None, **kw) -> Design:
    """The cheapest protocol that measures the water to the precision asked; with
    ``reference_shot``, the protocols include a chart photographed in air at the site
    ``reference_minutes`` (default :data:`sca.reference.REFERENCE_MINUTES`) from the dive, and
    the design without it is given beside (:attr:`Design.without_reference`). The other
    arguments are :func:`_design`'s; ``uncertain={}`` (the camera-only bound) has no daylight
    for a reference shot to measure.

    Raises
    ------
    forward.errors.InputError
        Naming 'uncertain' for a budget that is not a dict, 'minutes' as
        :func:`sca.reference.sky_sd`, and :func:`_design`'s.
    """
    import dataclasses

    from .reference import REFERENCE_MINUTES, planned

    if not reference_shot:
        return _design(chl, cdom, uncertain=uncertain, **kw)
    if uncertain is not None and not isinstance(uncertain, dict):
        raise InputError("uncertain", "expected a dict name -> standard deviation, or {}")
    minutes = REFERENCE_MINUTES if reference_minutes is None else reference_minutes
    with_shot = planned(dict(DEFAULT_UNCERTAIN if uncertain is None else uncertain), minutes)
    without = _design(chl, cdom, uncertain=uncertain, **kw)
    return dataclasses.replace(_design(chl, cdom, uncertain=with_shot, **kw),
                               reference_shot=True, without_reference=without)


def _design(chl, cdom, *, depth, distance, targets=None, max_photos: int = MAX_PHOTOS,
            auxiliary=AUXILIARY_OPTIONS, sample_sd: float = SAMPLE_SD, secchi_sd=None,
            gain: str = "free", uncertain=None, camera=DEFAULT_CAMERA, illuminant=None,
            reflectances=None, wavelengths=None, sensor: SensorSettings | None = None,
            water: Water | None = None, setup: ChartSetup | None = None) -> Design:
    """The cheapest protocol that measures the water to the precision asked (:func:`design`
    without a reference shot).

    Parameters
    ----------
    chl : float
        The water's C guessed, mg m^-3 (> 0: targets are relative to it).
    cdom : float
        Its a_CDOM(440) guessed, m^-1 (> 0).
    depth : float or (float, float)
        The chart depth, or the range of depths the dive can use, m.
    distance : float or (float, float)
        The camera-to-chart distance, or two distances the dive can use, m.
    targets : dict, optional
        name (:data:`TARGETS`) -> the 95 % half-width asked for, relative to the value (0.3:
        +-30 %). Default ``{'chl': 0.3}``.
    max_photos : int, optional
        Most photos of a protocol (default :data:`MAX_PHOTOS`).
    auxiliary : sequence of str, optional
        The auxiliary options searched (of :data:`AUXILIARY_OPTIONS`; default all, ``('none',)``
        for photos alone).
    sample_sd : float, optional
        The sd of a water sample's a_CDOM(440), m^-1 (default :data:`SAMPLE_SD`).
    secchi_sd : float, optional
        The sd of a Secchi reading, m (default :data:`SECCHI_READING_REL` of the depth the
        guessed water predicts).
    gain : {'free', 'known', 'channels'}
        A single photo's exposure (:func:`sca.precision`); a dive's photos each have their own
        free exposure (the joint estimator's model). Default 'free' (a photograph).
    uncertain : dict, optional
        The uncertainty budget; default (None) :data:`sca.budget.DEFAULT_UNCERTAIN`, ``{}`` the
        camera-only bound (photon and read noise only).
    camera, illuminant, reflectances, wavelengths, sensor, water, setup :
        As :func:`sca.precision`.

    Returns
    -------
    Design

    Raises
    ------
    ValueError
        Naming the argument: C or a_CDOM not > 0, a depth or distance that is not one or two
        lengths >= 0 (distances: at most two), an unknown target, option or gain, a
        ``max_photos`` < 1, a sample or Secchi sd not > 0.
    """
    from .auxiliary import secchi_observation

    for name, v in (("chl", chl), ("cdom", cdom)):
        if not np.ndim(v) == 0:
            raise InputError(name, f"expected one number, got {v!r}")
        validate.nonnegative(name, v)
        if not float(v) > 0:
            raise InputError(name, f"must be > 0 (the precision is relative to it; give the "
                             f"smallest value you need to measure), got {v!r}")
    chl, cdom = float(chl), float(cdom)
    targets = _check_targets(targets)
    depths = _range("depth", depth)
    lo, hi = min(depths), max(depths)
    distances = tuple(dict.fromkeys(_range("distance", distance)))
    if int(max_photos) != max_photos or max_photos < 1:
        raise InputError("max_photos", f"an integer >= 1, got {max_photos!r}")
    max_photos = int(max_photos)
    auxiliary = (auxiliary,) if isinstance(auxiliary, str) else tuple(auxiliary)
    bad = [a for a in auxiliary if a not in AUXILIARY_OPTIONS]
    if bad or not auxiliary:
        raise InputError("auxiliary", f"expected options among {AUXILIARY_OPTIONS}, got "
                         f"{auxiliary!r}")
    auxiliary = tuple(a for a in AUXILIARY_OPTIONS if a in auxiliary)  # cheapest first
    if gain not in ("free", "known", "channels"):
        raise InputError("gain", f"must be one of ('free', 'known', 'channels'), got {gain!r}")
    for name, v in (("sample_sd", sample_sd), ("secchi_sd", secchi_sd)):
        if v is not None and not (np.isfinite(float(v)) and float(v) > 0):
            raise InputError(name, f"a standard deviation > 0, got {v!r}")
    if uncertain is not None and not isinstance(uncertain, dict):
        raise InputError("uncertain", "expected a dict name -> standard deviation, or {}")
    budget = dict(DEFAULT_UNCERTAIN if uncertain is None else uncertain)
    sensor = SensorSettings() if sensor is None else sensor
    setup = resolve_setup(setup, camera, illuminant, reflectances, wavelengths)
    water = resolve_water(water)
    kw = dict(setup=setup, sensor=sensor, water=water, uncertain=budget)
    if secchi_sd is None:
        z, _ = secchi_observation(1.0, 1.0, water).function(
            {"chl": np.array([chl]), "cdom": np.array([cdom])}, ())
        secchi_sd = SECCHI_READING_REL * float(np.asarray(z).reshape(-1)[0])
    aux_sd = {"sample": float(sample_sd), "secchi": float(secchi_sd)}
    aux_of = {"none": None, "secchi": {"secchi": (None, aux_sd["secchi"])},
              "sample": {"cdom": (None, aux_sd["sample"])},
              "sample+secchi": {"cdom": (None, aux_sd["sample"]),
                                "secchi": (None, aux_sd["secchi"])}}
    # the estimators compare path models where a budget applies (sca.pathmodels.candidates)
    spans = bool(budget) and (hi + max(distances)) > 0
    bounds: dict = {}
    preds: dict = {}
    rejected: list = []  # (path model, protocol) whose misfit rejects the model

    def bound(proto: Protocol, budget_=None) -> Precision:
        key = (proto, None if budget_ is None else tuple(sorted(budget_)))
        if key not in bounds:
            D, R = (np.array(x, float) for x in zip(*proto.photos))
            k = {**kw, "uncertain": budget if budget_ is None else budget_}
            if proto.n_photos == 1 and gain != "free":
                bounds[key] = precision(chl, cdom, depth=float(D[0]), distance=float(R[0]),
                                        gain=gain, auxiliary=aux_of[proto.auxiliary], **k)
            else:
                bounds[key] = precision(chl, cdom, depth=D, distance=R, gain="free",
                                        dive=True, auxiliary=aux_of[proto.auxiliary], **k)
        return bounds[key]

    def truth(p: Precision) -> dict:
        return {"chl": chl, "cdom": cdom, **{k: float(v) for k, v in p.quantities.items()}}

    def bound_rel(proto: Protocol) -> dict:
        p = bound(proto)
        return _half_widths([_intervals(p)], truth(p))

    def bound_meets(proto: Protocol) -> bool:
        r = bound_rel(proto)
        return all(r[k] <= v for k, v in targets.items())

    def other(pm: str, proto: Protocol) -> Precision | None:
        """``pm`` fitted to the protocol's noise-free photos where the median dive will not
        reject it, else None. A model's misfit only grows with more photos or measurements
        (nested protocols), so a model rejected by a part of the protocol (its first photo
        alone, tried first) is rejected by the whole."""
        for part in (Protocol(proto.depths[:1], proto.distances[:1], "none"), proto):
            if any(m == pm and _within(q, part) for m, q in rejected):
                return None
            D, R = (np.array(x, float) for x in zip(*part.photos))
            q = precision(chl, cdom, depth=D, distance=R, gain="free", dive=True,
                          auxiliary=aux_of[part.auxiliary], path_model=pm, **kw)
            if q.fitted["objective"] >= PATH_MODEL_DELTA:
                rejected.append((pm, part))
                return None
        return q

    def predict(proto: Protocol) -> Prediction:
        if proto in preds:
            return preds[proto]
        p = bound(proto)
        ivs, span = [_intervals(p)], [water.path_model]
        if spans and not (proto.n_photos == 1 and gain != "free") and np.isfinite(p.chl_sd):
            for pm in PATH_MODELS:
                q = None if pm == water.path_model else other(pm, proto)
                if q is not None:
                    ivs.append(_intervals(q))
                    span.append(pm)
        rel = _half_widths(ivs, truth(p))
        out = Prediction(protocol=proto, rel95=rel, bound_rel95=bound_rel(proto),
                         span=tuple(span), meets=all(rel[k] <= v for k, v in targets.items()),
                         precision=p)
        preds[proto] = out
        return out

    # the best single depth: the one-photo bound's worst target, nearest distance, nothing else
    def worst_bound(proto):
        r = bound_rel(proto)
        return max(r[k] / v for k, v in targets.items())

    candidates_1 = list(dict.fromkeys(lo + f * (hi - lo) for f in SINGLE_DEPTH_FRACTIONS))
    first = min(candidates_1, key=lambda d: (worst_bound(Protocol((d,), (distances[0],))), -d))

    def proto(n, D, A):
        return Protocol(ladder(lo, hi, n, first), D, A)

    def fewest(ok, a, b):
        """The smallest n in [a, b] with ok(n), ok rising with n (b: ok(b) known)."""
        while a < b:
            mid = (a + b) // 2
            if ok(mid):
                b = mid
            else:
                a = mid + 1
        return a

    sets = [(r,) for r in distances] + ([distances] if len(distances) == 2 else [])
    chains = []  # (photos of the first protocol the bound admits, auxiliary rank, D, A, a, n_max)
    for D in sets:
        n_max = max_photos // len(D)
        if n_max < 1:
            continue
        richer_fails = False
        for A in reversed(auxiliary):  # the richest first: where it fails, the others do
            rank = AUXILIARY_OPTIONS.index(A)
            if richer_fails and _HOLDS[A] <= _HOLDS[auxiliary[-1]]:
                continue
            start = 1
            if len(D) == 1 and gain != "free":
                # one photo with a known or per-channel gain is not nested in the dives (each
                # photo's exposure free): a chain of its own
                if bound_meets(proto(1, D, A)):
                    chains.append((1, rank, D, A, 1, 1))
                start = 2
            if start > n_max:
                continue
            if not bound_meets(proto(n_max, D, A)):
                richer_fails = richer_fails or A == auxiliary[-1]
                continue
            a = fewest(lambda n: bound_meets(proto(n, D, A)), start, n_max)
            chains.append((a * len(D), rank, D, A, a, n_max))
    chosen = None
    for photos, rank, D, A, a, n_max in sorted(chains, key=lambda c: c[:2]):
        if chosen is not None and (photos, rank) > (chosen.protocol.n_photos,
                                                    AUXILIARY_OPTIONS.index(
                                                        chosen.protocol.auxiliary)):
            break  # no cheaper protocol is left
        # the span's predictions taken to fall with the photos, as the bound's (checked at
        # the protocols visited: the chain's cheapest, then its richest)
        if predict(proto(a, D, A)).meets:
            n = a
        elif a == n_max or not predict(proto(n_max, D, A)).meets:
            continue
        else:
            n = fewest(lambda k: predict(proto(k, D, A)).meets, a + 1, n_max)
        cand = predict(proto(n, D, A))
        if chosen is None or (cand.protocol.n_photos, rank, cand.worst(targets)) < (
                chosen.protocol.n_photos, AUXILIARY_OPTIONS.index(chosen.protocol.auxiliary),
                chosen.worst(targets)):
            chosen = cand
    one = min((predict(Protocol((first,), (r,), "none")) for r in distances),
              key=lambda p: p.worst(targets))
    if chosen is not None:
        best, limiting, without = chosen, "", float("nan")
    else:  # the most precise protocol of the space, and what limits it
        richest = auxiliary[-1]
        tops = [predict(proto(max_photos // len(D), D, richest)) for D in sets
                if max_photos // len(D) >= 1]
        best = min(tops + [one], key=lambda p: p.worst(targets))
        limiting, without = (("no water", float("nan")) if hi + max(distances) == 0 else
                             _limiting(best, targets, budget, bound))
    single = precision(chl, cdom, depth=first, distance=one.protocol.distances[0], gain=gain,
                       **kw)
    return Design(chl=chl, cdom=cdom, targets=targets, protocol=chosen, one_photo=one,
                  best=best, limiting=limiting, without_limiting=without,
                  depth_range=(lo, hi), distances=distances, uncertain=budget,
                  auxiliary_sd=aux_sd, searched=list(preds.values()), bounds=len(bounds),
                  one_photo_budget=single)


#: The auxiliary measurements each option holds.
_HOLDS = {"none": set(), "secchi": {"secchi"}, "sample": {"sample"},
          "sample+secchi": {"sample", "secchi"}}


def _within(p: Protocol, q: Protocol) -> bool:
    """Every photo and measurement of ``p`` is in ``q``."""
    from collections import Counter

    have, need = Counter(q.photos), Counter(p.photos)
    return all(have[k] >= v for k, v in need.items()) and \
        _HOLDS[p.auxiliary] <= _HOLDS[q.auxiliary]


def _limiting(best: Prediction, targets: dict, budget: dict, bound) -> tuple:
    """What limits ``best``: ('noise', NaN) without a budget; ('path model', NaN) where the
    bound alone meets the targets but the span does not; else the budget source whose exact
    knowledge narrows the worst target's bound most, and that half-width."""
    if not budget:
        return "noise", float("nan")
    worst = max(targets, key=lambda k: best.rel95[k] / targets[k])
    if best.bound_rel95[worst] <= targets[worst] < best.rel95[worst]:
        return "path model", float("nan")
    truth = {"chl": best.precision.chl, "cdom": best.precision.cdom,
             **{k: float(v) for k, v in best.precision.quantities.items()}}
    trials = {}
    for name in budget:
        rest = {k: v for k, v in budget.items() if k != name}
        p = bound(best.protocol, rest)
        trials[name] = _half_widths([_intervals(p)], truth)[worst]
    name = min(trials, key=trials.get)
    return name, float(trials[name])
