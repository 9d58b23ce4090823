"""How the chart detectors do on a test set of rendered dives and one real photograph.

    python -m experiments.detect_eval [--quick]

Candidates: colour-checker-detection's segmentation and templated detectors (float linear RGB
in, as its issues #49 and #83 advise for RAW input), OpenCV's ``cv2.mcc`` (reported absent when
the installed build lacks it) and :func:`measure.find_chart`. The test set: scenes of
:mod:`experiments.scene` (patch values from the second renderer,
:mod:`experiments.independent_world`, for four waters) -- rotations 0/90/180/270° and oblique,
foreshortening, mirror images, the card 10-60 % of the frame width, reef backgrounds, dark and
colour-cast, glints -- plus chartless frames and the real underwater JPEG of
``../shared/realdata/underwater_chart_jpeg`` (centres of patches 1, 6, 19 and 24 from its
README). Per candidate: charts found, located (every patch centre within half a pitch in the
best of the four orders of the grid), correctly oriented (within half a pitch in the order returned),
the median over found charts of the largest centre error in pitches, and false positives on
chartless frames.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

__all__ = ["REAL_CENTRES", "REAL_JPEG", "evaluate", "main", "test_set"]

#: The real photograph and its patch centres (patches 1, 6, 19, 24; full-resolution pixels) and
#: row pitch from ../shared/realdata/README.md
REAL_JPEG = (Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
             / "underwater_chart_jpeg" / "andieich_test_photo.jpg")
REAL_CENTRES = {0: (1510, 1260), 5: (2300, 1670), 18: (1200, 1740), 23: (2060, 2160)}
REAL_PITCH = 178.0
#: (chl mg m^-3, a_CDOM(440) m^-1, depth m, distance m) of the waters of the test set
WATERS = ((0.2, 0.02, 3.0, 1.0), (1.0, 0.1, 8.0, 1.5), (3.0, 0.3, 5.0, 2.0), (0.5, 0.05, 15.0, 1.0))
#: Frame of the rendered scenes (height, width), pixels
FRAME = (1000, 1500)


def _waters():
    from .independent_world import render_chart

    return [render_chart(c, a, d, r, noise=False, backscatter="single_scatter")["expected"]
            for c, a, d, r in WATERS]


def test_set(quick: bool = False) -> list:
    """The rendered scenes: list of dicts (``name``, ``image``, ``centres`` (24, 2) or None,
    ``pitch``)."""
    from .scene import card_corners, render_scene

    waters = _waters()
    casts = ("blue", "green", "turbid")
    rng = np.random.default_rng(18)
    out = []
    widths = (0.1, 0.15, 0.25, 0.4, 0.6)
    rotations = (0, 90, 180, 270, 27, -135, 200, 63)
    n = 12 if quick else 40
    for k in range(n):
        wf = widths[k % len(widths)]
        rot = rotations[k % len(rotations)] + float(rng.uniform(-4, 4))
        per = tuple(rng.uniform(-0.25, 0.25, 2)) if k % 3 else (0.0, 0.0)
        mirrored = k % 4 == 3
        margin = wf / 2 * 1.5 + 0.02
        centre = (rng.uniform(margin, 1 - margin), rng.uniform(min(0.5, margin * 1.5),
                                                                max(0.5, 1 - margin * 1.5)))
        corners = card_corners(FRAME, width_fraction=wf, rotation_deg=rot, perspective=per,
                               mirrored=mirrored, centre=centre)
        dark = k % 2 == 1
        s = render_scene(waters[k % len(waters)], corners, size=FRAME, seed=k, glints=k % 6,
                         cast=casts[k % 3], exposure=0.06 if dark else 0.3)
        name = (f"w{wf:.2f} rot{rot:.0f} persp{max(abs(p) for p in per):.2f}"
                f"{' mirror' if mirrored else ''}{' dark' if dark else ''} {casts[k % 3]}")
        out.append({"name": name, "image": s["image"], "centres": s["centres"],
                    "pitch": s["pitch"]})
    for k in range(2 if quick else 6):
        s = render_scene(waters[k % len(waters)], card_corners(FRAME), size=FRAME, seed=100 + k,
                         glints=3, cast=casts[k % 3], exposure=0.06 if k % 2 else 0.3,
                         chart=False)
        out.append({"name": f"chartless {k}", "image": s["image"], "centres": None, "pitch": 0})
    return out


def _real():
    """The real JPEG, linearised (sRGB decoding), or None when ../shared is absent."""
    if not REAL_JPEG.is_file():
        return None
    import colour
    import cv2

    decode = colour.cctf_decoding(np.arange(256) / 255, "sRGB").astype(np.float32)
    lin = decode[cv2.imread(str(REAL_JPEG), cv2.IMREAD_COLOR)[..., ::-1]]
    return {"name": "real JPEG (andieich)", "image": lin, "centres": None,
            "partial": REAL_CENTRES, "pitch": REAL_PITCH}


def _srgb_values():
    """The real JPEG's values as read (sRGB-encoded, 0-1)."""
    import cv2

    return cv2.imread(str(REAL_JPEG), cv2.IMREAD_COLOR)[..., ::-1].astype(np.float32) / 255


def _ccd_centres(result, shape, working_width):
    """Patch centres (24, 2) in image pixels from a colour-checker-detection result."""
    import cv2

    W = shape[1]
    ww = working_width
    wh = int(ww / 1.5)
    rect = np.array([[ww, 0], [ww, wh], [0, wh], [0, 0]], np.float32)
    quad = np.asarray(result.quadrilateral, np.float32)
    M = cv2.getPerspectiveTransform(rect, quad)
    r, c = np.divmod(np.arange(24), 6)
    pts = np.c_[(c + 0.5) * ww / 6, (r + 0.5) * wh / 4, np.ones(24)] @ M.T
    pts = pts[:, :2] / pts[:, 2:3]
    return pts * (W / ww)


def _normalised(image):
    top = np.percentile(image.reshape(-1, 3)[::11], 99.5, axis=0)
    return np.clip(image / np.where(top > 0, top, 1), 0, 1).astype(np.float32)


def _have(module) -> bool:
    import importlib.util

    return importlib.util.find_spec(module) is not None


def _ccd(kind, as_read=False):
    """A colour-checker-detection detector: linear RGB normalised to 0-1 in (its segmenter
    encodes it with the sRGB curve), or with ``as_read`` the image as given (a JPEG's values)."""
    import colour_checker_detection as ccd

    fn = {"segmentation": ccd.detect_colour_checkers_segmentation,
          "templated": ccd.detect_colour_checkers_templated}[kind]
    settings = {"segmentation": ccd.SETTINGS_SEGMENTATION_COLORCHECKER_CLASSIC,
                "templated": ccd.SETTINGS_TEMPLATED_COLORCHECKER_CLASSIC}[kind]

    def detect(image):
        res = fn(image if as_read else _normalised(image), additional_data=True)
        if not res:
            return None
        return _ccd_centres(res[0], image.shape, settings["working_width"])
    return detect


def _ours(image):
    from measure.detect import ChartNotFound, find_chart

    try:
        return find_chart(image).centres
    except ChartNotFound:
        return None


def _orders():
    """The re-orderings of a (4, 6) grid of centres that keep its shape: as given, rotated
    180°, mirrored left-right, mirrored top-bottom."""
    return [lambda a: a, lambda a: a[::-1, ::-1], lambda a: a[:, ::-1], lambda a: a[::-1, :]]


def _errors(centres, case):
    """(error in the order returned, error in the best order), pitches: the largest centre
    error over the patches with a known centre."""
    if case["centres"] is not None:
        idx = np.arange(24)
        truth = case["centres"]
    else:
        idx = np.array(list(case["partial"]))
        truth = np.array([case["partial"][i] for i in idx], float)
    grid = centres.reshape(4, 6, 2)
    errs = [float(np.max(np.hypot(*(g(grid).reshape(24, 2)[idx] - truth).T))) / case["pitch"]
            for g in _orders()]
    return errs[0], min(errs)


def evaluate(cases, candidates) -> dict:
    """Per candidate: counts and errors over the cases (see the module docstring)."""
    out = {}
    for name, detect in candidates.items():
        row = {"found": 0, "located": 0, "oriented": 0, "charts": 0, "false_pos": 0,
               "chartless": 0, "errors": [], "seconds": 0.0, "failures": []}
        for case in cases:
            t = time.perf_counter()
            try:
                centres = detect(case["image"])
            except Exception as exc:  # noqa: BLE001 - a candidate's crash is its failure here
                centres = None
                row["failures"].append(f"{case['name']}: {type(exc).__name__}")
            row["seconds"] += time.perf_counter() - t
            has_chart = case["centres"] is not None or "partial" in case
            if not has_chart:
                row["chartless"] += 1
                row["false_pos"] += centres is not None
                continue
            row["charts"] += 1
            if centres is None:
                row["failures"].append(f"{case['name']}: not found")
                continue
            row["found"] += 1
            as_given, best = _errors(centres, case)
            row["located"] += best < 0.5
            row["oriented"] += as_given < 0.5
            if best < 0.5:
                row["errors"].append(as_given if as_given < 0.5 else best)
            if as_given >= 0.5:
                row["failures"].append(f"{case['name']}: " + ("flipped" if best < 0.5 else
                                                               f"wrong place ({best:.1f} pitch)"))
        out[name] = row
    return out


def _table(results, title) -> str:
    head = (f"{'candidate':28s} {'found':>7s} {'located':>8s} {'oriented':>9s} "
            f"{'err med':>8s} {'err max':>8s} {'false+':>7s} {'s/img':>6s}")
    lines = [title, head]
    for name, r in results.items():
        e = r["errors"]
        n = r["charts"] + r["chartless"]
        lines.append(f"{name:28s} {r['found']:3d}/{r['charts']:<3d} {r['located']:8d} "
                     f"{r['oriented']:9d} {np.median(e) if e else np.nan:8.3f} "
                     f"{max(e) if e else np.nan:8.3f} {r['false_pos']:3d}/{r['chartless']:<3d} "
                     f"{r['seconds'] / max(n, 1):6.2f}")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Run the candidates on the test set and print the tables.

    Parameters
    ----------
    argv : list of str, optional
        ``--quick``: 12 scenes and 2 chartless frames instead of 40 and 6.

    Returns
    -------
    int
        0.
    """
    import cv2

    ap = argparse.ArgumentParser(prog="python -m experiments.detect_eval")
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    candidates = {"measure.find_chart": _ours, "ccd segmentation": _ccd("segmentation")}
    print(f"cv2.mcc in opencv {cv2.__version__}: "
          f"{'present' if hasattr(cv2, 'mcc') else 'absent (not evaluated)'}")
    if _have("sklearn"):
        candidates["ccd templated"] = _ccd("templated")
    else:
        print("colour-checker-detection templated: needs scikit-learn, not installed (not "
              "evaluated)")
    cases = test_set(args.quick)
    res = evaluate(cases, candidates)
    print(_table(res, f"rendered scenes ({len(cases)} frames, {FRAME[1]} x {FRAME[0]})"))
    for name, r in res.items():
        for f in r["failures"]:
            print(f"  {name}: {f}")
    real = _real()
    if real is None:
        print("real JPEG: ../shared/realdata absent, skipped")
    else:
        as_read = dict(real, image=_srgb_values())
        rr = evaluate([real], candidates) | evaluate(
            [as_read], {"ccd segmentation, as read": _ccd("segmentation", as_read=True)})
        print(_table(rr, "real underwater JPEG (4000 x 3000; patches 1, 6, 19, 24)"))
        for name, r in rr.items():
            for f in r["failures"]:
                print(f"  {name}: {f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
