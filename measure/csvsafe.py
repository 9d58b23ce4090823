"""CSV cells a spreadsheet cannot run: the one rule every CSV writer of the package applies.

A spreadsheet (Excel, LibreOffice Calc, Google Sheets) opening a CSV file takes a cell that
begins with ``=``, ``+``, ``-`` or ``@`` as a formula, and tab or carriage return can smuggle
one in; a file name or metadata cell such as ``=HYPERLINK(...)`` copied into summary.csv would
run. :func:`neutralise` prefixes such a text cell with a single quote (the OWASP rule, "CSV
Injection"), which every spreadsheet shows as text. Numbers stay numbers: a value that is not a
string, or a string that is a finite decimal number as a spreadsheet reads one (``-1.5``,
``+2``, ``1e3``; not Python-only forms such as ``-1_0``), is not text.

References
----------
OWASP Foundation, "CSV Injection", https://owasp.org/www-community/attacks/CSV_Injection
"""

from __future__ import annotations

import csv
import math
import re

__all__ = ["FORMULA_PREFIXES", "neutralise", "safe_row", "safe_writer"]

#: First characters that make a spreadsheet read a text cell as a formula (OWASP)
FORMULA_PREFIXES = ("=", "+", "-", "@", "\t", "\r")
_FIRST = frozenset(FORMULA_PREFIXES)  # a set lookup: the batch CSV writes ~10^7 cells


#: A number as a spreadsheet reads one (Python's float() also takes ``-1_0``, ``-inf``, spaces)
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")


def _is_number(text: str) -> bool:
    if not _NUMBER.fullmatch(text):
        return False
    return math.isfinite(float(text))


def neutralise(cell):
    """A cell a spreadsheet shows as it is: a text cell that begins like a formula gets a
    leading single quote.

    Parameters
    ----------
    cell : object
        A cell's value. Only strings are changed.

    Returns
    -------
    object
        ``"'" + cell`` for a string that begins with one of :data:`FORMULA_PREFIXES` and does
        not parse as a finite number; ``cell`` itself otherwise.
    """
    if isinstance(cell, str) and cell[:1] in _FIRST and not _is_number(cell):
        return "'" + cell
    return cell


def safe_row(row):
    """Every cell of a row through :func:`neutralise`.

    Parameters
    ----------
    row : dict or iterable
        A ``csv.DictWriter`` row (its values are neutralised) or a ``csv.writer`` row.

    Returns
    -------
    dict or list
        The row, its text cells neutralised.
    """
    if isinstance(row, dict):
        return {k: neutralise(v) for k, v in row.items()}
    return [neutralise(v) if v.__class__ is str and v[:1] in _FIRST else v for v in row]


class _SafeWriter:
    """A csv writer whose rows (header included) go through :func:`safe_row`."""

    def __init__(self, writer):
        self._w = writer

    def writerow(self, row):
        return self._w.writerow(safe_row(row))

    def writerows(self, rows):
        for row in rows:
            self.writerow(row)

    def writeheader(self):
        return self._w.writerow(dict(zip(self._w.fieldnames, safe_row(self._w.fieldnames))))

    def __getattr__(self, name):
        return getattr(self._w, name)


def safe_writer(fh, fieldnames=None, **kwargs):
    """``csv.writer(fh, **kwargs)`` (or ``csv.DictWriter`` with ``fieldnames``) whose cells
    are neutralised (:func:`neutralise`).

    Parameters
    ----------
    fh : text stream
        Opened with ``newline=''``.
    fieldnames : sequence of str, optional
        Given: a ``csv.DictWriter`` (``writeheader``, dict rows).
    **kwargs
        The csv writer's options (``lineterminator``, ...).

    Returns
    -------
    object
        With ``writerow`` and ``writerows`` (and ``writeheader`` with ``fieldnames``).
    """
    if fieldnames is None:
        return _SafeWriter(csv.writer(fh, **kwargs))
    return _SafeWriter(csv.DictWriter(fh, fieldnames=fieldnames, **kwargs))
