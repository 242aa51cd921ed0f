"""Tables on disk for the command line: CSV (a header line of names, rows of
finite decimal numbers; anything else a :class:`CsvError` naming file, line
and column) and ``.npz`` (a float64 array per column, ``status`` as strings,
``names`` the order). Writing is exact (shortest repr) and atomic.
"""
from __future__ import annotations

import contextlib
import difflib
import io
import itertools
import os
import re
import signal
import stat
import sys
import tempfile
import threading
import time
import zipfile
from dataclasses import dataclass, field
from typing import IO, Any, Callable, Iterator, Optional, Sequence

import numpy as np

# the default machine's trajectory header, in the canonical order (any machine's:
# columns.trajectory_columns)
from .columns import TRAJECTORY_COLUMNS  # noqa: F401

#: Name of the .npz array that lists the columns in order.
NAMES_KEY = 'names'


class CsvError(ValueError):
    """A table cannot be read or written: names the file, line and column."""

    def __init__(self, message: str, *, path: str | None = None, line: int | None = None,
                 column: int | None = None, name: str | None = None) -> None:
        self.message, self.path, self.line, self.column = message, path, line, column
        self.name = name
        where = [path if path is not None else '<input>']
        if line is not None:
            where.append(f'line {line}')
        if column is not None:
            where.append(f'column {column}' + (f' ({name})' if name else ''))
        super().__init__(f"{', '.join(where)}: {message}")


@dataclass(frozen=True)
class Table:
    """A parsed table: ``data[i, j]`` is column ``names[j]`` of the row read
    from line ``lines[i]``; ``skipped``: the columns not read; ``text``: the
    words of the ``text_columns``, one per row; ``estimated``: columns not read
    but computed from the others (a trajectory's rates from its poses).
    """

    path: str
    names: tuple[str, ...]
    data: np.ndarray      # (N, ncol) float64
    lines: np.ndarray     # (N,) int, 1-based line numbers (header = 1)
    skipped: tuple[str, ...] = ()
    text: dict[str, list[str]] = field(default_factory=dict)
    estimated: tuple[str, ...] = ()

    def __getitem__(self, name: str) -> np.ndarray:
        return self.data[:, self.names.index(name)]

    def __len__(self) -> int:
        return self.data.shape[0]


_ALLOWED_BYTES = b'0123456789.eE+-, \t\r\n'
_NUMBER = re.compile(r'[ \t]*[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?[ \t]*\Z', re.ASCII)


def _display(path: str | os.PathLike[str]) -> str:
    return '<stdin>' if os.fspath(path) == '-' else os.fspath(path)


def read_bytes(path: str | os.PathLike[str], limit: int | None = None) -> bytes:
    """The file's contents (``-``: standard input); CsvError if it cannot be
    read or holds more than ``limit`` bytes.
    """
    stdin = os.fspath(path) == '-'
    try:
        with contextlib.nullcontext(sys.stdin.buffer) if stdin else open(path, 'rb') as f:
            data = f.read(-1 if limit is None else limit + 1)
    except IsADirectoryError:
        raise CsvError('is a directory, not a CSV file', path=_display(path)) from None
    except OSError as exc:
        raise CsvError(f'cannot read: {exc.strerror or exc}', path=_display(path)) from None
    _check_size(len(data), limit, path)
    return data


def _check_size(size: int, limit: int | None, path: str | os.PathLike[str]) -> None:
    if limit is not None and size > limit:
        raise CsvError(f'larger than {limit >> 20} MiB, more than this command reads',
                       path=_display(path))


def parse_header(raw: bytes, path: str, *, required: Sequence[str],
                 allow_extra: bool) -> tuple[str, ...]:
    """Column names of header line ``raw``, checked (unknown ones unless ``allow_extra``)."""
    try:
        text = raw.decode('utf-8').rstrip('\r')
    except UnicodeDecodeError:
        raise CsvError('header is not valid UTF-8 text', path=path, line=1) from None
    names = tuple(cell.strip() for cell in text.split(','))
    expected = ','.join(required)
    if not text.strip():
        raise CsvError(f'empty header line; expected column names {expected}',
                       path=path, line=1)
    seen: dict[str, int] = {}
    for j, name in enumerate(names):
        if not name:
            raise CsvError('empty column name in the header', path=path, line=1, column=j + 1)
        if name in seen:
            raise CsvError(f"duplicate column '{name}' (also column {seen[name] + 1})",
                           path=path, line=1, column=j + 1, name=name)
        seen[name] = j
    missing = [n for n in required if n not in seen]
    unknown = [(j, n) for j, n in enumerate(names) if n not in required]
    if unknown and not allow_extra:
        listed = ', '.join(f"'{n}' (column {j + 1})" + _did_you_mean(n, missing)
                           for j, n in unknown)
        also = f"; missing {', '.join(repr(m) for m in missing)}" if missing else ''
        raise CsvError(f'unknown column{"s" if len(unknown) > 1 else ""} {listed}{also}; '
                       f'expected exactly the columns {expected} (any order)',
                       path=path, line=1, column=unknown[0][0] + 1, name=unknown[0][1])
    require_columns(names, required, path)
    return names


def require_columns(names: Sequence[str], required: Sequence[str], path: str) -> None:
    """CsvError (line 1) naming the ``required`` columns a header ``names`` lacks,
    with the header's names that are close to them.
    """
    missing = [n for n in required if n not in names]
    if missing:
        near = [f"'{n}' (column {j + 1}){_did_you_mean(n, missing)}"
                for j, n in enumerate(names) if n not in required and _did_you_mean(n, missing)]
        raise CsvError(f'missing column{"s" if len(missing) > 1 else ""} '
                       f"{', '.join(repr(m) for m in missing)}; "
                       f"the header must name {','.join(required)} (any order)"
                       + (f"; it has {', '.join(near)}" if near else ''), path=path, line=1)


def _did_you_mean(name: str, candidates: Sequence[str]) -> str:
    lowered = {c.lower(): c for c in candidates}
    close = ([lowered[name.lower()]] if name.lower() in lowered
             else difflib.get_close_matches(name, candidates, n=1))
    return f" (did you mean '{close[0]}'?)" if close else ''


def read_csv(path: str | os.PathLike[str], *, required: Sequence[str],
             allow_extra: bool = False, text_columns: Sequence[str] = (),
             skip_extra: bool = False, limit: int | None = None) -> Table:
    """Read a numeric CSV file whose header names ``required`` (any order; more
    with ``allow_extra`` or ``skip_extra``; at most ``limit`` bytes); CsvError
    at the first problem.
    """
    with CsvReader.open(path, limit) as reader:
        return reader.table(required=required, allow_extra=allow_extra,
                            text_columns=text_columns, skip_extra=skip_extra)


def parse_csv(data: bytes, path: str = '<input>', *, required: Sequence[str],
              allow_extra: bool = False, text_columns: Sequence[str] = (),
              skip_extra: bool = False) -> Table:
    """:func:`read_csv` on the bytes of a file: ``text_columns`` are read as
    words (``Table.text``); ``skip_extra`` leaves out the columns not in
    ``required`` (``Table.skipped``).
    """
    return CsvReader(io.BytesIO(data), path).table(
        required=required, allow_extra=allow_extra, text_columns=text_columns,
        skip_extra=skip_extra)


_BLANK = b' \t\r\n'


class CsvReader:
    """A CSV file read whole (:meth:`table`) or a block of rows at a time
    (:meth:`tables`: memory bounded by the block, not the file), the same checks
    either way; :attr:`names`: the header's names as written, not yet checked.
    """

    def __init__(self, stream: IO[bytes], path: str, limit: int | None = None) -> None:
        self.stream, self.path, self.limit = stream, path, limit
        self.size = 0
        self.header = self._read_line().removeprefix(b'\xef\xbb\xbf')
        self.names = tuple(cell.strip() for cell in
                           self.header.decode('utf-8', 'replace').rstrip('\r\n').split(','))

    @classmethod
    @contextlib.contextmanager
    def open(cls, path: str | os.PathLike[str], limit: int | None = None
             ) -> Iterator['CsvReader']:
        """The reader of the file ``path`` (``-``: standard input), closed at the end."""
        stdin = os.fspath(path) == '-'
        try:
            f = sys.stdin.buffer if stdin else open(path, 'rb')
        except IsADirectoryError:
            raise CsvError('is a directory, not a CSV file', path=_display(path)) from None
        except OSError as exc:
            raise CsvError(f'cannot read: {exc.strerror or exc}', path=_display(path)) from None
        with contextlib.nullcontext(f) if stdin else f:
            yield cls(f, _display(path), limit)

    def _counted(self, read: Callable[[], bytes]) -> bytes:
        """What ``read`` reads of the stream, counted against the limit."""
        try:
            data = read()
        except IsADirectoryError:
            raise CsvError('is a directory, not a CSV file', path=self.path) from None
        except OSError as exc:
            raise CsvError(f'cannot read: {exc.strerror or exc}', path=self.path) from None
        self.size += len(data)
        _check_size(self.size, self.limit, self.path)
        return data

    def _left(self) -> int:
        return -1 if self.limit is None else self.limit + 1 - self.size

    def _read_line(self) -> bytes:
        return self._counted(lambda: self.stream.readline(self._left()))

    def _read(self, rows: int | None) -> bytes:
        """The next ``rows`` lines (None: the rest of the file)."""
        if rows is None:
            return self._counted(lambda: self.stream.read(self._left()))
        return self._counted(lambda: b''.join(itertools.islice(self.stream, rows)))

    def table(self, *, required: Sequence[str], allow_extra: bool = False,
              text_columns: Sequence[str] = (), skip_extra: bool = False) -> Table:
        """Every row of the file as one table (:func:`read_csv`)."""
        return next(self.tables(required=required, allow_extra=allow_extra,
                                text_columns=text_columns, skip_extra=skip_extra))

    def tables(self, *, required: Sequence[str], allow_extra: bool = False,
               text_columns: Sequence[str] = (), skip_extra: bool = False,
               rows: int | None = None) -> Iterator[Table]:
        """The file's rows as tables of at most ``rows`` rows (None: one table),
        each checked as :func:`read_csv` checks a file; its ``lines`` the file's.
        """
        if not self.header.strip() and self._rest_is_blank():
            raise CsvError('the file is empty; expected a header line '
                           f"{','.join(required)} and rows of numbers", path=self.path, line=1)
        header = self.header.removesuffix(b'\n')
        all_names = parse_header(header, self.path, required=required,
                                 allow_extra=allow_extra or skip_extra)
        skip = [j for j, name in enumerate(all_names)
                if name in text_columns or (skip_extra and name not in required)]
        line, held, first = 2, b'', True
        while True:
            chunk = self._read(rows)
            end = rows is None or not chunk or chunk.count(b'\n') < rows
            body = held + chunk
            # trailing blank lines are fine; any other blank line is a row of missing
            # values: blank lines at a block's end wait for what follows them
            kept = body.rstrip(_BLANK)
            if end:
                held = b''
            elif not kept:
                held, kept = body, b''
            else:
                held = body[body.index(b'\n', len(kept)) + 1:]
            if kept:
                table = _table(kept, self.path, all_names, skip, required, text_columns, line)
                line += len(table)
                first = False
                yield table
            elif first and end:
                raise CsvError('no data rows after the header', path=self.path, line=2)
            if end:
                return

    def _rest_is_blank(self) -> bool:
        """Whether nothing but white space follows a blank header line (read a
        MiB at a time; else the blank header is the error, nothing more is read).
        """
        while True:
            chunk = self._counted(lambda: self.stream.read(1 << 20))
            if chunk.strip():
                return False
            if not chunk:
                return True


def _table(body: bytes, path: str, all_names: Sequence[str], skip: Sequence[int],
           required: Sequence[str], text_columns: Sequence[str], first_line: int) -> Table:
    """The rows of ``body`` (no trailing blank line; the first at ``first_line``)
    as a checked table of the header ``all_names``, without the columns ``skip``.
    """
    keep = [j for j in range(len(all_names)) if j not in skip]
    rows = body.split(b'\n')
    values = None
    if not skip:
        values = _parse(body, len(rows), len(keep))
    else:
        cells = [row.split(b',') for row in rows]
        if all(len(c) == len(all_names) for c in cells):
            values = _parse(b'\n'.join(b','.join(c[j] for j in keep) for c in cells),
                            len(rows), len(keep))
    if values is None:
        _raise_first_error(rows, all_names, path, keep, first_line)
    bad = ~np.isfinite(values)
    if bad.any():  # e.g. 1e999: a valid literal, but not a finite double
        i, k = np.argwhere(bad)[0]
        cell = rows[i].split(b',')[keep[k]].decode().strip()
        raise CsvError(f"'{cell}' is not a finite number", path=path,
                       line=int(i) + first_line, column=keep[k] + 1, name=all_names[keep[k]])
    text = {all_names[j]: [c[j].decode('utf-8', 'replace').strip() for c in cells]
            for j in skip if all_names[j] in text_columns}
    return Table(path=path, names=tuple(all_names[j] for j in keep), data=values,
                 lines=np.arange(first_line, len(rows) + first_line),
                 skipped=tuple(all_names[j] for j in skip if all_names[j] not in text_columns),
                 text=text)


def _parse(body: bytes, nrows: int, ncol: int) -> np.ndarray | None:
    """The rows of ``body`` parsed in C; None if anything is wrong."""
    if body.translate(None, _ALLOWED_BYTES):   # letters, quotes, NUL, non-ASCII...
        return None
    body = body.replace(b'\r\n', b'\n')
    if body.count(b',') != nrows * (ncol - 1):
        return None
    # on these characters numpy accepts exactly the cells _NUMBER does; with
    # nrows rows read and nrows * (ncol - 1) commas, every row has ncol cells
    try:
        values = np.loadtxt(body.decode('ascii').split('\n'), delimiter=',', comments=None,
                            dtype=np.float64, ndmin=2)
    except ValueError:
        return None
    return values if values.shape == (nrows, ncol) else None


def _raise_first_error(rows: list[bytes], names: Sequence[str], path: str,
                       keep: Sequence[int], first_line: int = 2) -> None:
    """CsvError at the first malformed cell of ``rows`` in the columns ``keep``."""
    ncol = len(names)
    for i, raw in enumerate(rows):
        line = i + first_line
        try:
            text = raw.decode('utf-8').rstrip('\r')
        except UnicodeDecodeError:
            raise CsvError('not valid UTF-8 text', path=path, line=line) from None
        if not text.strip():
            raise CsvError(f'empty line; expected {ncol} values', path=path, line=line)
        cells = text.split(',')
        for j in keep[:len(cells)]:
            shown = cells[j].strip()
            if not shown:
                raise CsvError('missing value', path=path, line=line, column=j + 1,
                               name=names[j])
            try:
                finite = bool(np.isfinite(float(cells[j])))
            except ValueError:
                finite = None
            if not (finite and _NUMBER.match(cells[j])):
                raise CsvError(f"'{shown}' is not a {'finite ' if finite is False else ''}number",
                               path=path, line=line, column=j + 1, name=names[j])
        if len(cells) != ncol:
            short = len(cells) < ncol
            raise CsvError(f"{'missing' if short else 'extra'} value (the row has {len(cells)} "
                           f'values, the header {ncol} columns)', path=path, line=line,
                           column=len(cells) + 1 if short else ncol + 1,
                           name=names[len(cells)] if short else None)
    raise CsvError('cannot be read as rows of numbers', path=path)


def read_table(path: str | os.PathLike[str], *, required: Sequence[str],
               optional: Sequence[str] = (), limit: int | None = None) -> Table:
    """The output of ``solve`` (CSV, ``-``, or .npz, at most ``limit`` bytes):
    ``required``, ``optional`` and the ``status`` words.
    """
    if is_npz(path):
        with contextlib.suppress(OSError):      # (a missing file: read_npz says so)
            _check_size(os.path.getsize(path), limit, path)
        return read_npz(path, required=required, optional=optional)
    return read_csv(path, required=required, allow_extra=True, text_columns=('status',),
                    limit=limit)


def is_npz(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` names an .npz file (by its suffix, any case)."""
    return os.fspath(path).lower().endswith('.npz')


def read_npz(path: str | os.PathLike[str], *, required: Sequence[str],
             optional: Sequence[str] = ()) -> Table:
    """:func:`read_table` of an .npz written by :func:`write_npz`."""
    shown = os.fspath(path)
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {key: npz[key] for key in npz.files}
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise CsvError(f'cannot read as .npz: {exc}', path=shown) from None
    if NAMES_KEY not in arrays:
        raise CsvError(f"no '{NAMES_KEY}' array: not an .npz written by solve", path=shown)
    names = tuple(str(n) for n in arrays[NAMES_KEY])
    missing = [n for n in required if n not in names or n not in arrays]
    if missing:
        raise CsvError(f"missing column{'s' if len(missing) > 1 else ''} "
                       f"{', '.join(repr(m) for m in missing)}; it has {', '.join(names)}",
                       path=shown)
    kept = tuple(n for n in names if n in required or (n in optional and n in arrays))
    columns = []
    for name in kept:
        column = arrays[name]
        where = dict(path=shown, column=names.index(name) + 1, name=name)
        if column.ndim != 1 or column.dtype.kind not in 'fiu':
            raise CsvError(f'not a 1-D array of numbers ({column.dtype}, shape {column.shape})',
                           **where)
        if columns and column.shape != columns[0].shape:
            raise CsvError(f'{column.size} rows, column {kept[0]!r} has {columns[0].size}',
                           **where)
        bad = np.flatnonzero(~np.isfinite(column))
        if bad.size:
            raise CsvError(f'{column[bad[0]]} in row {bad[0] + 1} is not a finite number',
                           **where)
        columns.append(np.asarray(column, dtype=np.float64))
    n = columns[0].size if columns else 0
    text = {}
    if 'status' in arrays:
        status = arrays['status']
        if status.ndim != 1 or status.dtype.kind != 'U' or status.size != n:
            raise CsvError(f'not {n} strings ({status.dtype}, shape {status.shape})',
                           path=shown, name='status')
        text['status'] = status.tolist()
    return Table(path=shown, names=kept, data=np.column_stack(columns) if columns
                 else np.empty((n, 0)), lines=np.arange(2, n + 2), text=text)


def _format_blocks(data: np.ndarray, words: Sequence[str] | None,
                   step: int = 1024) -> Iterator[bytes]:
    """The rows of ``data`` (``repr``, shortest exact, without an integral ``.0``),
    ``step`` at a time, ``words`` (one per row) last.
    """
    sep = ',' if data.shape[1] else ''
    for start in range(0, data.shape[0], step):
        rows = [','.join(map(repr, row)) for row in data[start:start + step].tolist()]
        if words is None:
            text = '\n'.join(rows + ['']).replace('.0\n', '\n')
        else:
            text = ''.join([row + sep + word + '\n'
                            for row, word in zip(rows, words[start:start + step])])
        # a '.0' before a separator is only ever repr's integral 'd.0'
        yield text.replace('.0,', ',').encode()


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[IO[bytes]]:
    """Open ``path`` for binary writing so that it appears complete or not at
    all (a temporary file replaces it at the end; ``-``: standard output).
    Devices, FIFOs and sockets are written through; a symlink's target is
    replaced, keeping its mode; a read-only file is refused; SIGTERM/SIGHUP
    remove the temporary file and end with 128 + the signal (after a SIGKILL,
    the next write to ``path`` removes it).
    """
    if os.fspath(path) == '-':
        yield sys.stdout.buffer
        sys.stdout.buffer.flush()
        return
    shown = os.fspath(path)
    target = os.path.realpath(shown)            # a symlink: its target
    try:
        st = os.stat(target)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise CsvError(f'cannot write: {exc.strerror}', path=shown) from None
    if st is not None and (stat.S_ISCHR(st.st_mode) or stat.S_ISFIFO(st.st_mode)
                           or stat.S_ISSOCK(st.st_mode)):
        with _errors_named(shown), open(target, 'wb') as f:    # write through, never replace
            yield f
        return
    if st is not None and not stat.S_ISREG(st.st_mode):
        what = 'a directory' if stat.S_ISDIR(st.st_mode) else 'not a regular file'
        raise CsvError(f'is {what}; cannot write a file there', path=shown)
    if st is not None and not st.st_mode & 0o222:
        raise CsvError(f'is read-only (mode {stat.S_IMODE(st.st_mode):04o}): not replaced',
                       path=shown)
    directory = os.path.dirname(target)
    if not os.path.isdir(directory):
        raise CsvError(f"cannot write: directory '{os.path.dirname(shown) or '.'}' does not "
                       'exist', path=shown)
    _remove_stale(directory, os.path.basename(target))
    with _errors_named(shown):
        fd, tmp = tempfile.mkstemp(prefix=f'.{os.path.basename(target)}.{os.getpid()}.',
                                   suffix='.tmp', dir=directory)
    try:
        with _signals_end_the_write(), _errors_named(shown):
            with os.fdopen(fd, 'wb') as f:
                yield f
            if st is None:
                umask = os.umask(0)
                os.umask(umask)
                os.chmod(tmp, 0o666 & ~umask)
            else:
                os.chmod(tmp, stat.S_IMODE(st.st_mode))
            os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _remove_stale(directory: str, base: str) -> None:
    """Remove the temporary files a killed write of ``base`` left (SIGKILL runs
    no handler): a minute old, their writer (the pid in the name) gone.
    """
    ours = re.compile(re.escape(f'.{base}.') + r'(\d{1,7})\.[a-z0-9_]{8}\.tmp')
    with contextlib.suppress(OSError):
        for entry in os.scandir(directory):
            found = ours.fullmatch(entry.name)
            if found and time.time() - entry.stat().st_mtime > 60:
                try:
                    os.kill(int(found[1]), 0)
                except ProcessLookupError:
                    os.unlink(entry.path)
                except OSError:         # alive, another user's
                    pass


@contextlib.contextmanager
def _errors_named(shown: str) -> Iterator[None]:
    """An OSError as a CsvError naming the user's path, not the temporary file."""
    try:
        yield
    except OSError as exc:
        raise CsvError(f'cannot write: {exc.strerror or exc}', path=shown) from None


@contextlib.contextmanager
def _signals_end_the_write() -> Iterator[None]:
    """SIGTERM/SIGHUP raise SystemExit(128 + signal) inside the block (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: object) -> None:
        raise SystemExit(128 + signum)

    old = {s: signal.signal(s, handler) for s in (signal.SIGTERM, signal.SIGHUP)}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def write_csv(path: str | os.PathLike[str], names: Sequence[str], data: np.ndarray,
              text: tuple[str, Sequence[str]] | None = None) -> None:
    """Write a header and ``data`` exactly, atomically; ``text = (name, words)``
    appends a column of words.
    """
    with table_writer(path, names, None if text is None else text[0], npz=False) as write:
        write(data, None if text is None else text[1])


def write_npz(path: str | os.PathLike[str], names: Sequence[str], data: np.ndarray,
              text: tuple[str, Sequence[str]] | None = None) -> None:
    """:func:`write_csv` as numpy's .npz (module docstring), atomically."""
    with table_writer(path, names, None if text is None else text[0], npz=True) as write:
        write(data, None if text is None else text[1])


#: ``write(data, words)``: rows of a table, and their words (one per row) if it has a text column.
RowWriter = Callable[[np.ndarray, Optional[Sequence[str]]], None]


@contextlib.contextmanager
def table_writer(path: str | os.PathLike[str], names: Sequence[str], text: str | None = None,
                 *, npz: bool | None = None, parallel: bool = False) -> Iterator[RowWriter]:
    """A table written a block of rows at a time (memory bounded by the block),
    atomically (:func:`atomic_output`: all of it, or nothing if the block
    raises): CSV, or .npz (``npz``; None: by the suffix); ``text`` the name of a
    last column of words. ``parallel``: a CSV's rows formatted and written by a
    second process (:class:`_FormatterProcess`) while the caller makes the next
    block, the same bytes.
    """
    if npz is None:
        npz = is_npz(path)
    order = list(names) + ([text] if text is not None else [])
    if npz and (len(set(order)) != len(order) or NAMES_KEY in order):
        raise ValueError(f'column names must be distinct and not {NAMES_KEY!r}: {order}')
    with atomic_output(path) as f:
        if not npz:
            f.write((','.join(order) + '\n').encode())
            # a second process writes through a file descriptor (not an in-memory stream)
            formatter = _FormatterProcess(f, path) if parallel and _has_fd(f) else None

            def write(data: np.ndarray, words: Sequence[str] | None = None) -> None:
                data, words = _checked(names, data, None if text is None else (text, words))
                if formatter is not None:
                    formatter.send(data, words)
                    return
                for part in _format_blocks(data, words):     # written as formatted
                    f.write(part)

            if formatter is None:
                yield write
                return
            try:
                yield write
                formatter.finish()
            finally:
                formatter.close()
            return
        # .npz: each column spilled to its own file beside the output, zipped at the end
        folder = None if os.fspath(path) == '-' else os.path.dirname(os.path.realpath(path))
        with tempfile.TemporaryDirectory(prefix='.fsd-npz-', dir=folder) as spill, \
                contextlib.ExitStack() as files:
            columns = [files.enter_context(open(os.path.join(spill, f'{j}.f8'), 'wb'))
                       for j in range(len(names))]
            codes = files.enter_context(open(os.path.join(spill, 'text.u1'), 'wb'))
            vocabulary: dict[str, int] = {}
            rows = 0

            def write(data: np.ndarray, words: Sequence[str] | None = None) -> None:
                nonlocal rows
                data, words = _checked(names, data, None if text is None else (text, words))
                for j, column in enumerate(columns):
                    column.write(np.ascontiguousarray(data[:, j], dtype='<f8').tobytes())
                if words is not None:
                    code = [vocabulary.setdefault(w, len(vocabulary)) for w in words]
                    if len(vocabulary) > 256:
                        raise ValueError(f'text column {text!r}: more than 256 distinct words')
                    codes.write(np.asarray(code, dtype=np.uint8).tobytes())
                rows += data.shape[0]

            yield write
            for spilled in (*columns, codes):
                spilled.close()
            _zip_columns(f, spill, names, text, list(vocabulary), rows, order)


def _has_fd(f: IO[bytes]) -> bool:
    try:
        f.fileno()
    except (OSError, ValueError, AttributeError):     # io.UnsupportedOperation included
        return False
    return True


class _FormatterProcess:
    """:func:`_format_blocks` of each block sent, written to ``f`` by a forked
    process, in order (the pipe holds the sender at most about a block ahead);
    a write error is a :class:`CsvError` naming ``path`` at the next send or at
    :meth:`finish`.
    """

    def __init__(self, f: IO[bytes], path: str | os.PathLike[str]) -> None:
        import multiprocessing      # only for a parallel write
        f.flush()                   # the child's copy of f must hold no bytes of ours
        context = multiprocessing.get_context('fork')
        blocks, self._blocks = context.Pipe(duplex=False)
        self._status, status = context.Pipe(duplex=False)
        # the child closes its copies of our ends: the blocks' EOF, when we
        # give up, reaches it only once no copy of their sending end is open
        self._process = context.Process(target=_format_into, daemon=True,
                                        args=(f, blocks, status, (self._blocks, self._status)))
        self._process.start()
        blocks.close()
        status.close()
        self._path = os.fspath(path)

    def send(self, data: np.ndarray, words: Sequence[str] | None) -> None:
        try:
            self._blocks.send((data, words))
        except OSError:             # the child has ended: its error
            self._raise()

    def finish(self) -> None:
        """Every block written (the child's error, if any, raised)."""
        self.send(None, None)
        self._raise()

    def _raise(self) -> None:
        try:
            error = self._status.recv()
        except EOFError:
            error = f'the writing process ended (exit code {self._process.exitcode})'
        if error is not None:
            raise CsvError(f'cannot write: {error}', path=self._path)

    def close(self) -> None:
        self._blocks.close()        # a child still reading ends at once (EOFError)
        self._process.join(timeout=5)
        if self._process.is_alive():
            self._process.terminate()
            self._process.join()
        self._status.close()


def _format_into(f: IO[bytes], blocks: Any, status: Any, parents: Sequence[Any]) -> None:
    """The child of :class:`_FormatterProcess`: format and write each block
    until ``(None, None)``; then None (or the error's text) on ``status``
    (``parents``: the parent's ends of the pipes, closed here).
    """
    for end in parents:
        end.close()
    error = None
    try:
        while True:
            data, words = blocks.recv()
            if data is None:
                break
            for part in _format_blocks(data, words):
                f.write(part)
        f.flush()
    except EOFError:                # the parent gave up: nothing to report
        return
    except OSError as exc:
        error = exc.strerror or str(exc)
    status.send(error)


def _zip_columns(f: IO[bytes], spill: str, names: Sequence[str], text: str | None,
                 vocabulary: list[str], rows: int, order: list[str]) -> None:
    """The .npz of the spilled columns (as numpy.savez writes it: a stored .npy each)."""
    from numpy.lib import format as npy

    def member(name: str, dtype: np.dtype, chunks: Iterator[bytes]) -> None:
        with zf.open(f'{name}.npy', 'w', force_zip64=True) as out:
            npy.write_array_header_1_0(out, {'descr': npy.dtype_to_descr(dtype),
                                             'fortran_order': False, 'shape': (rows,)})
            for chunk in chunks:
                out.write(chunk)

    def pieces(spilled: str, size: int = 1 << 20) -> Iterator[bytes]:
        with open(os.path.join(spill, spilled), 'rb') as src:
            while chunk := src.read(size):
                yield chunk

    with zipfile.ZipFile(f, 'w', compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
        for j, name in enumerate(names):
            member(name, np.dtype('<f8'), pieces(f'{j}.f8'))
        if text is not None:
            words = np.asarray(vocabulary or [''], dtype=str)
            member(text, words.dtype, (words[np.frombuffer(chunk, dtype=np.uint8)].tobytes()
                                       for chunk in pieces('text.u1')))
        with zf.open(f'{NAMES_KEY}.npy', 'w') as out:
            npy.write_array(out, np.asarray(order, dtype=str))


def _checked(names: Sequence[str], data: np.ndarray, text: tuple[str, Sequence[str]] | None
             ) -> tuple[np.ndarray, Sequence[str] | None]:
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 2 or data.shape[1] != len(names):
        raise ValueError(f'{len(names)} column names for data of shape {data.shape}')
    if text is None:
        return data, None
    name, words = text
    if len(words) != data.shape[0] or any(',' in w or '\n' in w for w in set(words)):
        raise ValueError(f'text column {name!r}: one word per row expected')
    return data, words
