"""CSV reading and writing for the command line (numbers only, SI units).

Reading is strict and fast. A file is a header line of column names followed
by rows of decimal numbers separated by commas. Every value must be a finite
decimal number (``1``, ``-0.5``, ``2.5e-3``); ``nan``, ``inf``, empty cells,
blank lines and rows with too few or too many values are errors, reported as
:class:`CsvError` naming the file, the line (1 = the header) and the column
(1-based number and name). The fast path parses the whole file in C (numpy);
only when it fails does a line-by-line scan run to find the exact cell.

Writing is exact: every float is written with enough digits (at most 17
significant) to read back to the identical double, by a vectorised formatter
(:func:`format_table`) that is an order of magnitude faster than ``'%.17g'``
in a Python loop. Files are written to a temporary file in the destination
directory and moved into place with :func:`os.replace` (:func:`atomic_output`),
so a failed run never leaves a partial file and never clobbers an old one.
"""
from __future__ import annotations

import contextlib
import os
import re
import sys
import tempfile
from dataclasses import dataclass
from fractions import Fraction
from typing import IO, Iterator, Sequence

import numpy as np

#: Header of a trajectory file (input of ``solve``), in the canonical order.
TRAJECTORY_COLUMNS = ('t', 'surge', 'heave', 'roll',
                      'surge_rate', 'heave_rate', 'roll_rate',
                      'surge_acc', 'heave_acc', 'roll_acc')


class CsvError(ValueError):
    """A CSV file cannot be read: names the file, line and column."""

    def __init__(self, message: str, *, path: str | None = None, line: int | None = None,
                 column: int | None = None, name: str | None = None) -> None:
        self.message = message
        self.path = path
        self.line = line
        self.column = column
        self.name = name
        super().__init__(self._text())

    def _text(self) -> str:
        where = [self.path if self.path is not None else '<input>']
        if self.line is not None:
            where.append(f'line {self.line}')
        if self.column is not None:
            where.append(f'column {self.column}' + (f' ({self.name})' if self.name else ''))
        return f"{', '.join(where)}: {self.message}"


@dataclass(frozen=True)
class Table:
    """A parsed CSV file: ``data[i, j]`` is the value of column ``names[j]`` in
    data row ``i``, read from line ``lines[i]`` of the file."""

    path: str
    names: tuple[str, ...]
    data: np.ndarray      # (N, ncol) float64
    lines: np.ndarray     # (N,) int, 1-based line numbers (header = 1)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.data[:, self.names.index(name)]

    def __len__(self) -> int:
        return self.data.shape[0]


# ----------------------------------------------------------------------------
# Reading
# ----------------------------------------------------------------------------
_ALLOWED_BYTES = b'0123456789.eE+-, \t\r\n'
_NUMBER = re.compile(r'[ \t]*[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?[ \t]*\Z')
_BLANK_LINE = re.compile(rb'(?:\A|\n)[ \t\r]*(?:\n|\Z)')


def _display(path: str | os.PathLike[str]) -> str:
    return '<stdin>' if os.fspath(path) == '-' else os.fspath(path)


def read_bytes(path: str | os.PathLike[str]) -> bytes:
    """The file's contents (``-``: standard input). OSError is re-raised as
    CsvError with a plain message."""
    if os.fspath(path) == '-':
        return sys.stdin.buffer.read()
    try:
        with open(path, 'rb') as f:
            return f.read()
    except IsADirectoryError:
        raise CsvError('is a directory, not a CSV file', path=_display(path)) from None
    except OSError as exc:
        raise CsvError(f'cannot read: {exc.strerror or exc}', path=_display(path)) from None


def parse_header(raw: bytes, path: str, *, required: Sequence[str],
                 allow_extra: bool) -> tuple[str, ...]:
    """Column names of header line ``raw``; checks empty, duplicate, missing
    and (unless ``allow_extra``) unknown names."""
    try:
        text = raw.decode('utf-8')
    except UnicodeDecodeError:
        raise CsvError('header is not valid UTF-8 text', path=path, line=1) from None
    text = text.lstrip('\ufeff').rstrip('\r')
    names = tuple(cell.strip() for cell in text.split(','))
    expected = ','.join(required)
    if not text.strip():
        raise CsvError(f'empty header line; expected column names {expected}',
                       path=path, line=1)
    for j, name in enumerate(names):
        if not name:
            raise CsvError('empty column name in the header', path=path, line=1, column=j + 1)
    seen: dict[str, int] = {}
    for j, name in enumerate(names):
        if name in seen:
            raise CsvError(f"duplicate column '{name}' (also column {seen[name] + 1})",
                           path=path, line=1, column=j + 1, name=name)
        seen[name] = j
    if not allow_extra:
        unknown = [(j, n) for j, n in enumerate(names) if n not in required]
        if unknown:
            j0, _ = unknown[0]
            listed = ', '.join(f"'{n}' (column {j + 1})" for j, n in unknown)
            raise CsvError(f'unknown column{"s" if len(unknown) > 1 else ""} {listed}; '
                           f'expected exactly the columns {expected} (any order)',
                           path=path, line=1, column=j0 + 1, name=unknown[0][1])
    missing = [n for n in required if n not in seen]
    if missing:
        raise CsvError(f'missing column{"s" if len(missing) > 1 else ""} '
                       f"{', '.join(repr(m) for m in missing)}; "
                       f'the header must name {expected} (any order)', path=path, line=1)
    return names


def read_csv(path: str | os.PathLike[str], *, required: Sequence[str],
             allow_extra: bool = False) -> Table:
    """Read a numeric CSV file with a header naming at least ``required``
    (exactly those, in any order, unless ``allow_extra``).

    Raises :class:`CsvError` naming the line and column of the first problem.
    """
    display = _display(path)
    data = read_bytes(path)
    return parse_csv(data, display, required=required, allow_extra=allow_extra)


def parse_csv(data: bytes, path: str = '<input>', *, required: Sequence[str],
              allow_extra: bool = False) -> Table:
    """:func:`read_csv` on the bytes of a file."""
    if data.startswith(b'\xef\xbb\xbf'):
        data = data[3:]
    if not data.strip():
        raise CsvError('the file is empty; expected a header line '
                       f"{','.join(required)} and rows of numbers", path=path, line=1)
    end = data.find(b'\n')
    header, body = (data, b'') if end < 0 else (data[:end], data[end + 1:])
    names = parse_header(header, path, required=required, allow_extra=allow_extra)
    ncol = len(names)
    # Trailing blank lines at the end of the file are fine; any other blank
    # line is a row with every value missing.
    body = body.rstrip(b' \t\r\n')
    if not body:
        raise CsvError('no data rows after the header', path=path, line=2)
    nrows = body.count(b'\n') + 1
    values = _parse_fast(body, nrows, ncol)
    if values is None:
        values = _parse_slow(body, names, path)  # raises on the first bad cell
    bad = ~np.isfinite(values)
    if bad.any():  # e.g. 1e999: a valid literal, but not a finite double
        i, j = np.argwhere(bad)[0]
        cell = body.split(b'\n')[i].split(b',')[j].decode().strip()
        raise CsvError(f"'{cell}' is not a finite number", path=path, line=int(i) + 2,
                       column=int(j) + 1, name=names[j])
    return Table(path=path, names=names, data=values, lines=np.arange(2, nrows + 2))


def _parse_fast(body: bytes, nrows: int, ncol: int) -> np.ndarray | None:
    """Parse ``body`` (the rows) in C; None if anything looks wrong (then the
    slow scan finds and reports the offending cell)."""
    if body.translate(None, _ALLOWED_BYTES):   # letters, quotes, NUL, non-ASCII...
        return None
    if _BLANK_LINE.search(body):
        return None
    buf = np.frombuffer(body, dtype=np.uint8)
    newlines = np.flatnonzero(buf == 0x0A)
    commas = np.flatnonzero(buf == 0x2C)
    if commas.size != nrows * (ncol - 1):
        return None
    per_line = np.bincount(np.searchsorted(newlines, commas), minlength=nrows)
    if np.any(per_line != ncol - 1):
        return None
    try:
        flat = np.fromstring(body.replace(b'\n', b','), dtype=np.float64, sep=',')
    except ValueError:
        return None
    if flat.size != nrows * ncol:
        return None
    return flat.reshape(nrows, ncol)


def _parse_slow(body: bytes, names: Sequence[str], path: str) -> np.ndarray:
    """Line-by-line parse that raises CsvError at the first malformed cell."""
    ncol = len(names)
    rows = body.split(b'\n')
    out = np.empty((len(rows), ncol))
    for i, raw in enumerate(rows):
        line = i + 2
        try:
            text = raw.decode('utf-8').rstrip('\r')
        except UnicodeDecodeError:
            raise CsvError('not valid UTF-8 text', path=path, line=line) from None
        if not text.strip():
            raise CsvError(f'empty line; expected {ncol} values', path=path, line=line)
        cells = text.split(',')
        for j, cell in enumerate(cells[:ncol]):
            shown = cell.strip()
            if not shown:
                raise CsvError('missing value', path=path, line=line, column=j + 1,
                               name=names[j])
            try:
                value = float(cell)
            except ValueError:
                value = None
            if not _NUMBER.match(cell) or value is None:
                if value is not None and not np.isfinite(value):
                    msg = f"'{shown}' is not a finite number"
                else:
                    msg = f"'{shown}' is not a number"
                raise CsvError(msg, path=path, line=line, column=j + 1, name=names[j])
            out[i, j] = value
        if len(cells) < ncol:
            raise CsvError(f'missing value (the row has {len(cells)} values, '
                           f'the header {ncol} columns)', path=path, line=line,
                           column=len(cells) + 1, name=names[len(cells)])
        if len(cells) > ncol:
            raise CsvError(f'extra value (the row has {len(cells)} values, '
                           f'the header {ncol} columns)', path=path, line=line,
                           column=ncol + 1)
    return out


# ----------------------------------------------------------------------------
# Writing: exact, vectorised float formatting
# ----------------------------------------------------------------------------
_WIDTH = 24                 # widest value: '-1.2345678901234567e-123'
_RANGE = (1e-250, 1e250)    # vectorised path; outside it (and nan/inf): Python's '%.17g'
_P10_MIN, _P10_MAX = -270, 270


def _pow10_table() -> tuple[np.ndarray, np.ndarray]:
    """10**k as unevaluated sums hi + lo of two doubles (|error| < 2**-106)."""
    ks = range(_P10_MIN, _P10_MAX + 1)
    hi = np.empty(len(ks))
    lo = np.empty(len(ks))
    for i, k in enumerate(ks):
        exact = Fraction(10) ** k
        hi[i] = float(exact)
        lo[i] = float(exact - Fraction(hi[i]))
    return hi, lo


_P10_HI, _P10_LO = _pow10_table()
_SPLITTER = 134217729.0     # 2**27 + 1 (Dekker)
_TEN16 = 10 ** 16
_TEN17 = 10 ** 17
_DIGITS4 = np.array([list(f'{i:04d}'.encode()) for i in range(10000)], dtype=np.uint8)
_TRAILING0 = np.array([4 if i == 0 else len(f'{i:04d}') - len(f'{i:04d}'.rstrip('0'))
                       for i in range(10000)], dtype=np.int64)
_DIGITS3 = np.array([list(f'{i:03d}'.encode()) for i in range(1000)], dtype=np.uint8)


def _scaled(ax: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ax * 10**p as a double-double (hi, lo), relative error < 2**-100."""
    th = _P10_HI[p - _P10_MIN]
    tl = _P10_LO[p - _P10_MIN]
    prod = ax * th
    c = _SPLITTER * ax
    ah = c - (c - ax)
    al = ax - ah
    c = _SPLITTER * th
    bh = c - (c - th)
    bl = th - bh
    err = ((ah * bh - prod) + ah * bl + al * bh) + al * bl
    err += ax * tl
    hi = prod + err
    lo = err - (hi - prod)
    return hi, lo


def _round_int(hi: np.ndarray, lo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest integer to hi + lo (as int64) and the residual (int - (hi + lo))."""
    rh = np.rint(hi)
    frac = (hi - rh) + lo
    rf = np.rint(frac)
    return rh.astype(np.int64) + rf.astype(np.int64), rf - frac


def _decimal(ax: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For finite ax in _RANGE: (m, e) with 10**16 <= m < 10**17 and
    m * 10**(e - 16) a decimal that reads back exactly as ax, using 16
    significant digits when they suffice and 17 otherwise."""
    e = np.floor(np.log10(ax)).astype(np.int64)
    m, _ = _round_int(*_scaled(ax, 16 - e))
    for _ in range(2):  # log10 may be off by one next to a power of ten
        hi = m >= _TEN17
        low = m < _TEN16
        if not (hi.any() or low.any()):
            break
        e = e + hi - low
        fix = hi | low
        m[fix], _ = _round_int(*_scaled(ax[fix], 16 - e[fix]))
    # 17 digits always read back exactly (error <= 0.51 unit < half a gap).
    # Try 16: keep the candidate if it lies strictly within half the gap to
    # the neighbouring double on its side (with a wide safety margin).
    m16, resid = _round_int(*_scaled(ax, 15 - e))   # resid = m16 - ax*10**(15-e)
    scale = _P10_HI[15 - e - _P10_MIN]
    up = (np.nextafter(ax, np.inf) - ax) * scale
    down = (ax - np.nextafter(ax, 0.0)) * scale
    half_gap = 0.5 * np.where(resid >= 0, up, down) * (1.0 - 1e-9)
    short = np.abs(resid) < half_gap
    carry = short & (m16 >= _TEN16)      # rounded up to the next power of ten
    m = np.where(short, m16 * 10, m)
    m[carry] = _TEN16
    e = e + carry
    return m, e


def _layouts() -> tuple[np.ndarray, np.ndarray]:
    """Character layout of each format class: index into the per-value source
    row (17 digits, exponent sign, 3 exponent digits, '.', '0', 'e', '-') and
    the keep threshold (a cell is kept when the number of significant digits
    exceeds it; -1 always, 99 never)."""
    DOT, ZERO, E, MINUS, ESIGN = 21, 22, 23, 24, 17
    never = (ZERO, 99)
    rows_idx, rows_thr = [], []
    for cls in range(22):
        cells: list[tuple[int, int]] = [(MINUS, 99)]   # sign: handled separately
        if cls <= 20:
            e = cls - 4
            if e >= 0:
                cells += [(i, -1) for i in range(e + 1)]
                cells.append((DOT, e + 1))
                cells += [(i, i) for i in range(e + 1, 17)]
            else:
                cells += [(ZERO, -1), (DOT, -1)] + [(ZERO, -1)] * (-e - 1)
                cells += [(i, i) for i in range(17)]
        else:
            cells += [(0, -1), (DOT, 1)] + [(i, i) for i in range(1, 17)]
            cells += [(E, -1), (ESIGN, -1), (18, 99), (19, -1), (20, -1)]
        cells += [never] * (_WIDTH - len(cells))
        rows_idx.append([c[0] for c in cells])
        rows_thr.append([c[1] for c in cells])
    return np.array(rows_idx, dtype=np.intp), np.array(rows_thr, dtype=np.int64)


_LAYOUT_IDX, _LAYOUT_THR = _layouts()
_SCI = 21
_EXP_HUNDREDS_COL = 21


def format_values(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Format doubles as text, vectorised.

    Returns ``(chars, keep)``, both of shape (n, 24): the text of value i is
    ``chars[i][keep[i]]``. The text follows ``'%.17g'`` (fixed notation for
    decimal exponents -4..16, else ``d.ddde+XX``) but with 16 significant
    digits whenever 16 read back exactly; ``float(text) == x`` always (the
    sign of zero included)."""
    x = np.ascontiguousarray(x, dtype=np.float64).ravel()
    n = x.size
    chars = np.zeros((n, _WIDTH), dtype=np.uint8)
    keep = np.zeros((n, _WIDTH), dtype=bool)
    ax = np.abs(x)
    fast = (ax >= _RANGE[0]) & (ax <= _RANGE[1])      # false for 0, nan, inf
    neg = np.signbit(x)
    idx = np.flatnonzero(fast)
    if idx.size:
        m, e = _decimal(ax[idx])
        k = idx.size
        src = np.empty((k, 25), dtype=np.uint8)
        g = m
        groups = []
        for _ in range(4):
            g, r = np.divmod(g, 10000)
            groups.append(r)
        src[:, 0] = g + 48                       # leading digit (1..9)
        for pos, r in zip((13, 9, 5, 1), groups):
            src[:, pos:pos + 4] = _DIGITS4[r]
        tz = np.zeros(k, dtype=np.int64)
        zero_so_far = np.ones(k, dtype=bool)
        for r in groups:
            tz += np.where(zero_so_far, _TRAILING0[r], 0)
            zero_so_far &= r == 0
        nd = 17 - tz
        ae = np.abs(e)
        src[:, 17] = np.where(e < 0, ord('-'), ord('+'))
        src[:, 18:21] = _DIGITS3[np.minimum(ae, 999)]
        src[:, 21] = ord('.')
        src[:, 22] = ord('0')
        src[:, 23] = ord('e')
        src[:, 24] = ord('-')
        cls = np.where((e >= -4) & (e <= 16), e + 4, _SCI)
        for c in np.unique(cls):
            sel = np.flatnonzero(cls == c)
            rows = idx[sel]
            chars[rows] = src[sel][:, _LAYOUT_IDX[c]]
            kp = nd[sel, None] > _LAYOUT_THR[c][None, :]
            if c == _SCI:
                kp[:, _EXP_HUNDREDS_COL] = ae[sel] >= 100
            keep[rows] = kp
    zero = x == 0
    chars[zero, 1] = ord('0')
    keep[zero, 1] = True
    chars[:, 0] = ord('-')
    keep[:, 0] = neg & ~np.isnan(x)
    for i in np.flatnonzero(~fast & ~zero):       # nan, inf, tiny, huge: rare
        text = ('%.17g' % abs(x[i])).encode() if not np.isnan(x[i]) else b'nan'
        chars[i, 1:1 + len(text)] = np.frombuffer(text, dtype=np.uint8)
        keep[i, 1:] = False
        keep[i, 1:1 + len(text)] = True
    return chars, keep


def format_value(x: float) -> str:
    """The text :func:`format_values` gives one value."""
    chars, keep = format_values(np.array([x]))
    return chars[0][keep[0]].tobytes().decode()


def format_table(data: np.ndarray, *, chunk_rows: int = 20000) -> bytes:
    """Rows of comma-separated exact decimals, each row ending in a newline."""
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 2:
        raise ValueError(f'expected a 2-D array, got shape {data.shape}')
    nrows, ncol = data.shape
    parts = []
    for start in range(0, nrows, chunk_rows):
        block = data[start:start + chunk_rows]
        nb = block.shape[0]
        chars, keep = format_values(block)
        out = np.empty((nb, ncol, _WIDTH + 1), dtype=np.uint8)
        mask = np.empty((nb, ncol, _WIDTH + 1), dtype=bool)
        out[:, :, :_WIDTH] = chars.reshape(nb, ncol, _WIDTH)
        mask[:, :, :_WIDTH] = keep.reshape(nb, ncol, _WIDTH)
        out[:, :, _WIDTH] = ord(',')
        out[:, -1, _WIDTH] = ord('\n')
        mask[:, :, _WIDTH] = True
        parts.append(out[mask].tobytes())
    return b''.join(parts)


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[IO[bytes]]:
    """Open ``path`` for binary writing so that it appears complete or not at
    all: the data goes to a temporary file in the same directory, which
    replaces ``path`` only when the block finishes without an exception (the
    old file, if any, is untouched otherwise). ``-`` writes to standard output."""
    if os.fspath(path) == '-':
        yield sys.stdout.buffer
        sys.stdout.buffer.flush()
        return
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        raise IsADirectoryError(21, 'Is a directory', path)
    fd, tmp = tempfile.mkstemp(prefix='.' + os.path.basename(path) + '.', suffix='.tmp',
                               dir=directory)
    try:
        with os.fdopen(fd, 'wb') as f:
            yield f
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_csv(path: str | os.PathLike[str], names: Sequence[str], data: np.ndarray) -> None:
    """Write a header and the rows of ``data`` (N, len(names)), exactly, atomically."""
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 2 or data.shape[1] != len(names):
        raise ValueError(f'{len(names)} column names for data of shape {data.shape}')
    body = format_table(data)
    with atomic_output(path) as f:
        f.write((','.join(names) + '\n').encode())
        f.write(body)
