"""The one CSV reader of the package: curves (:func:`forward.spectra.read_spectral_csv`), a
dive's metadata (:func:`measure.dive.read_metadata`) and patch files
(:mod:`uw3p.patchfile`) read their files with :class:`Table`, under one set of dialect rules
(decision 0082-installed-packages):

* **Encoding**: UTF-8 with or without a byte-order mark (a spreadsheet's "CSV UTF-8"), or
  UTF-16 with a byte-order mark (a spreadsheet's "Unicode text"); anything else is refused.
* **Separator**: comma, semicolon or tab, detected: the first of tab, semicolon, comma that
  splits every row of the file's start into the same number (>= 2) of fields, quotes
  respected; a spreadsheet's ``sep=;`` first line is honoured. Fields may be quoted, and a
  quoted field may hold line breaks.
* **Decimal separator**: a point; in a semicolon- or tab-separated file a comma too (``0,25``)
  -- never in a comma-separated one, where the comma is the separator.
* **Comments**: lines starting with ``#`` before the first row, blank lines and rows of empty
  fields are skipped.
* **Header**: the first row, when it is not all numbers (a reader may require one).

What cannot be read is refused with :class:`forward.errors.InputError` naming the reader's
argument, the file, and where a cell is at fault its line and column (:meth:`Table.number`).
A semicolon-separated curve file with decimal commas (``400;0,12;0,45;0,33``) is read as three
curves, not as seven numbers split at every comma.
"""

from __future__ import annotations

import codecs
import csv
import io
import itertools
import re
from pathlib import Path

from .errors import InputError

__all__ = ["Table", "DELIMITERS", "has_data", "to_float"]

#: Separators detected.
DELIMITERS = ",;\t"
#: Bytes read to detect the encoding and the separator.
SAMPLE_BYTES = 65536
#: Rows of that sample that the separator must split alike.
SNIFF_ROWS = 50
#: A spreadsheet's separator hint, the file's first line (``sep=;``).
SEP_LINE = re.compile(r"\s*sep=(.)\s*")


def _check_path(path, name) -> Path:
    p = Path(path)
    if p.is_dir():
        raise InputError(name, f"{p} is a folder, not a CSV file")
    if not p.exists():
        raise InputError(name, f"file not found: {p}")
    if not p.is_file():
        raise InputError(name, f"{p} is not a regular file")
    return p


def _encoding(head: bytes, p, name) -> str:
    """The text encoding of a file starting with ``head``."""
    if head.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        return "utf-16"
    if b"\x00" in head:
        raise InputError(name, f"{p} is not a text CSV file (it holds binary data)")
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 4:  # not just a character cut by the sample's end
            raise InputError(name, f"{p} is not UTF-8 text (byte {exc.start}): save it as "
                             "'CSV UTF-8'") from None
    return "utf-8-sig"


def _skip(line: str) -> bool:
    """Whether a physical line before the file's first row carries no data: blank, only
    separators, a ``#`` comment or a spreadsheet's ``sep=`` hint."""
    s = line.strip()
    return not s or s.startswith("#") or not s.strip(DELIMITERS + " ") or bool(_hint(line))


def _hint(line: str):
    """The match of a ``sep=`` line (its group 1 the separator), or None."""
    return SEP_LINE.fullmatch(line.rstrip("\r\n"))


def _lines(fh, skipped=None):
    """The physical lines of ``fh`` (its line breaks kept, for the csv module) from the first
    that carries data (:func:`_skip`); ``skipped``: a one-element list set to the number of
    lines skipped before it."""
    it = iter(fh)
    for i, line in enumerate(it):
        if not _skip(line):
            if skipped is not None:
                skipped[0] = i
            yield line
            yield from it
            return


def has_data(row) -> bool:
    """Whether a parsed row holds a value (not a blank line or a row of empty fields)."""
    return bool(row and row[0].strip()) or any(f.strip() for f in row)


def to_float(text: str, decimal_comma: bool) -> float:
    """``text`` as a number, a decimal comma read when ``decimal_comma`` (ValueError if not)."""
    return float(text.replace(",", ".") if decimal_comma else text)


def _numeric_row(row, decimal_comma) -> bool:
    try:
        [to_float(x, decimal_comma) for x in row if x.strip()]
    except ValueError:
        return False
    return any(x.strip() for x in row)


class Table:
    """A CSV file opened for reading: its encoding, separator, decimal mark and header.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file.
    name : str
        The argument that gave it, at the start of every error message.

    Attributes
    ----------
    delimiter : str
        The separator (comma, semicolon or tab).
    decimal_comma : bool
        Whether a number may have a decimal comma (the separator is not a comma).
    first : list of str
        The first row.
    header : list of str or None
        The first row when it is not all numbers, else None.

    Raises
    ------
    forward.InputError
        Naming ``name``: a missing file, a folder, binary or undecodable data, no rows.
    """

    def __init__(self, path, name):
        self.name = name
        self.path = p = _check_path(path, name)
        try:
            with open(p, "rb") as fh:
                head = fh.read(SAMPLE_BYTES)
        except OSError as exc:
            raise InputError(name, f"cannot read {p}: {exc.strerror}") from None
        self.size = p.stat().st_size
        self.encoding = _encoding(head, p, name)
        text = head.decode(self.encoding, errors="ignore")
        if self.encoding == "utf-8-sig" and text.startswith("\ufeff"):
            text = text[1:]
        # lines split as the csv module will read the file (line breaks inside quoted cells
        # are the csv module's to join); the sample's last line may be cut
        lines = list(io.StringIO(text, newline=""))[:-1 if len(head) == SAMPLE_BYTES else None]
        hint = next(filter(None, map(_hint, itertools.takewhile(_skip, lines))), None)
        lines = list(_lines(lines))
        self.delimiter = hint.group(1) if hint else self._sniff(lines)
        first = next(filter(has_data, csv.reader(lines, delimiter=self.delimiter)), None)
        if first is None:
            raise InputError(name, f"{p} has no rows")
        # a decimal comma: only where the comma cannot be the separator
        self.decimal_comma = self.delimiter != ","
        self.header = None if _numeric_row(first, self.decimal_comma) else first
        self.first = first

    @staticmethod
    def _sniff(lines):
        """The separator: the first of tab, semicolon, comma that splits every sample row
        (quotes respected, csv module) into the same number (>= 2) of fields. Tab and
        semicolon go first: their files may hold decimal commas, while a comma-separated file
        has no unquoted semicolon on every line."""
        def rows(d):
            return list(itertools.islice(filter(has_data, csv.reader(lines, delimiter=d)),
                                         SNIFF_ROWS))
        for d in ("\t", ";", ","):
            widths = {len(r) for r in rows(d)}
            if len(widths) == 1 and widths.pop() >= 2:
                return d
        # ragged whichever the separator: the one splitting the first row most (the reader
        # then names the ragged line)
        return max(DELIMITERS, key=lambda d: len((rows(d) or [[]])[0]))

    def _open(self, progress=None):
        raw = open(self.path, "rb")
        if progress is not None:
            raw = io.BufferedReader(_Counted(raw, progress))
        return io.TextIOWrapper(raw, encoding=self.encoding, newline="")

    def numbered(self, progress=None):
        """Iterate ``(line, row)``: each row holding data (the header included), a list of str,
        with the physical line (1-based) it starts on; ``progress``: a tqdm bar advanced by the
        bytes read."""
        skipped = [0]
        fh = self._open(progress)
        try:
            reader = csv.reader(_lines(fh, skipped), delimiter=self.delimiter)
            end = 0
            for row in reader:
                start, end = end + 1, reader.line_num
                if has_data(row):
                    yield skipped[0] + start, row
        except csv.Error as exc:
            raise InputError(self.name, f"{self.path} is not valid CSV: {exc}") from None
        except UnicodeDecodeError as exc:
            what = "UTF-16" if self.encoding == "utf-16" else "UTF-8"
            raise InputError(self.name, f"{self.path} is not {what} text ({exc.reason}): "
                             "save it as 'CSV UTF-8'") from None
        finally:
            fh.close()

    def rows(self, progress=None):
        """Iterate the rows holding data (lists of str), the header included."""
        return (row for _, row in self.numbered(progress))

    def line_of(self, k: int) -> int:
        """The physical line number (1-based) where data row ``k`` starts (0 = the first row
        after the header, or the first row of a file without one); for error messages."""
        line, target = 0, k + (self.header is not None)
        for j, (line, _) in enumerate(self.numbered()):
            if j == target:
                break
        return line

    def where(self, k: int) -> str:
        """``'<file> line <n>'`` of data row ``k`` (:meth:`line_of`)."""
        return f"{self.path} line {self.line_of(k)}"

    def number(self, text: str, line: int, column) -> float:
        """The cell ``text`` at ``line``, ``column`` (a 1-based index or a name) as a number.

        Raises
        ------
        forward.InputError
            Naming the file, the line and the column when it is not a number.
        """
        try:
            return to_float(text.strip(), self.decimal_comma)
        except ValueError:
            raise InputError(self.name, f"{self.path} line {line} column {column}: {text!r} is "
                             "not a number") from None


class _Counted(io.RawIOBase):
    """A binary file that advances a progress bar by the bytes read."""

    def __init__(self, raw, bar):
        self.raw, self.bar = raw, bar

    def readable(self):
        return True

    def readinto(self, b):
        n = self.raw.readinto(b)
        self.bar.update(n or 0)
        return n

    def close(self):
        self.raw.close()
        super().close()
