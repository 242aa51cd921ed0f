"""Reading a YAML file the one safe way, for parameter and scene files.

Every problem is one :class:`ParameterError` naming the file (and the key,
when there is one), in well under a second, whatever the file holds:

* at most :data:`MAX_FILE_BYTES` (256 KiB) are read (``/dev/zero``, a FIFO or a
  huge file never read unbounded); a directory, NUL bytes (a binary file) or
  text that is not UTF-8 is refused;
* aliases and anchors are refused outright (a 1.4 KB "billion laughs" file
  expands to gigabytes; a self-referencing alias never ends); nesting is
  bounded (:data:`MAX_DEPTH`); a key given twice is refused (not the last one
  silently winning); explicit tags (``!!float``) are refused;
* the plain values that PyYAML (YAML 1.1) and ROS 2's own parser (rcl, which
  reads ``--params-file`` for the node) read differently, or that only YAML
  1.1 reads as numbers or booleans, are refused naming the key, so that the
  library and the node never run on different numbers: sexagesimal
  (``1:30``), ``0x``/``0o``/``0b`` and leading-zero octal integers, ``_`` in
  numbers, ``yes``/``no``/``on``/``off``/``y``/``n``, ``null``/``~``/empty
  values, dates, ``inf``/``nan`` without the dot (write ``.inf``/``.nan``),
  integers outside 64 bits, empty lists and lists of lists. Quote a value to
  make it a string. (A list mixing integers and floats, ``[0, 0.5]``, is read
  as numbers here; rcl refuses the whole file at the node's start-up: write
  ``0.0``.)
* YAML 1.2 floats that PyYAML alone reads as strings (``1e3``, ``2.5e-3``,
  ``+.5``) are read as floats, as rcl reads them.

libyaml's parser is used when PyYAML has it (fast); composing and the
checks are PyYAML's Python code on top of its events.
"""
from __future__ import annotations

import os
import re
import stat
from pathlib import Path
from typing import Any

import yaml
from yaml.composer import Composer
from yaml.constructor import SafeConstructor
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode
from yaml.resolver import Resolver

from .errors import ParameterError

#: Largest file read (bytes): the packaged parameter file is 6 KB; a file of
#: this size is read and checked in about 0.25 s.
MAX_FILE_BYTES = 256 * 1024
#: Deepest nesting of maps and lists.
MAX_DEPTH = 32

try:                # libyaml's parser: events at C speed
    from yaml.cyaml import CParser as _Parser
except ImportError:  # PyYAML built without libyaml
    from yaml.parser import Parser as _Parser  # type: ignore[assignment]
_STR = 'tag:yaml.org,2002:str'
_INT = 'tag:yaml.org,2002:int'
_FLOAT = 'tag:yaml.org,2002:float'

#: Plain scalars refused, with why (first match wins).
_REFUSED = [(re.compile(pattern, re.IGNORECASE), why) for pattern, why in (
    (r'[-+]?[0-9][0-9_]*(:[0-5]?[0-9])+(\.[0-9_]*)?', 'a YAML 1.1 sexagesimal number'),
    (r'[-+]?0[xob][0-9a-f_.p+-]*', 'a hexadecimal, octal or binary number'),
    (r'[-+]?0[0-9_]+', 'a number with a leading zero (YAML 1.1 octal)'),
    (r'[-+]?[0-9.][0-9._]*_[0-9._]*([e][-+]?[0-9]+)?', "a number with '_'"),
    (r'yes|no|on|off|y|n', 'a YAML 1.1 boolean (write true or false)'),
    (r'null|~|', 'an empty value (null)'),
    (r'[0-9]{4}-[0-9]{1,2}-[0-9]{1,2}([Tt ].*)?', 'a date'),
    (r'[-+]?(inf|infinity|nan)', "an infinity or NaN without the dot (write .inf, .nan)"),
)]
# (anchored at both ends: PyYAML only anchors the start, and '1e3 junk' is a string)
_FLOAT_12 = re.compile(r'[-+]?(\.[0-9]+([eE][-+]?[0-9]+)?|[0-9]+(\.[0-9]*)?[eE][-+]?[0-9]+)\Z')
_INT64 = (-2 ** 63, 2 ** 63 - 1)


class _Resolver(Resolver):
    """PyYAML's resolver plus YAML 1.2 exponent floats (``1e3``), as rcl reads them."""


_Resolver.add_implicit_resolver(_FLOAT, _FLOAT_12, list('-+0123456789.'))


class _StrictLoader(Composer, _Parser, SafeConstructor, _Resolver):  # type: ignore[misc,valid-type]
    """PyYAML's safe loader (libyaml's parser when available) that refuses
    aliases, anchors, tags and deep nesting while composing.
    """

    def __init__(self, text: str) -> None:
        _Parser.__init__(self, text)
        Composer.__init__(self)
        SafeConstructor.__init__(self)
        _Resolver.__init__(self)
        self.depth = 0

    def compose_node(self, parent: Node | None, index: Any) -> Node:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, 'anchor', None) is not None:
            raise yaml.MarkedYAMLError(None, None, 'anchors and aliases (&, *) are not allowed',
                                       event.start_mark)
        tag = getattr(event, 'tag', None)
        if tag is not None:         # rcl ignores tags: '!!float 1' would differ
            raise yaml.MarkedYAMLError(None, None, f'explicit tags ({tag}) are not allowed',
                                       event.start_mark)
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise yaml.MarkedYAMLError(None, None, f'nested deeper than {MAX_DEPTH} levels',
                                       event.start_mark)
        try:
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1


def _where(path: list[str]) -> str:
    """The dotted name of a place in the file: a parameter's own name inside
    a ``<node>: ros__parameters:`` section.
    """
    if 'ros__parameters' in path[:2]:
        path = path[path.index('ros__parameters') + 1:] or path
    return '.'.join(path) or '(top level)'


def _check(node: Node, path: list[str], source: str) -> None:
    """Refuse what rcl and PyYAML read differently (module docstring), naming the key."""
    if isinstance(node, ScalarNode):
        if not node.style:      # plain (None, or "" from libyaml): its type is implied
            for pattern, why in _REFUSED:
                if pattern.fullmatch(node.value):
                    raise ParameterError(_where(path), node.value,
                                         f'{why} in {source}: ambiguous between YAML readers '
                                         '(ROS 2 reads it differently or only YAML 1.1 does); '
                                         'write a plain decimal number, true/false, or quote a '
                                         'string')
            if node.tag == _INT:
                digits = node.value.lstrip('+-')
                if len(digits) > 19 or not _INT64[0] <= int(node.value) <= _INT64[1]:
                    raise ParameterError(_where(path), node.value[:40],
                                         f'integer outside 64 bits in {source}')
        return
    if isinstance(node, SequenceNode):
        if not node.value:
            raise ParameterError(_where(path), [], f'empty list in {source} (ROS 2 ignores '
                                                   'it: give the values or leave the key out)')
        for i, item in enumerate(node.value):
            if not isinstance(item, ScalarNode):
                raise ParameterError(_where(path), None,
                                     f'element {i} is not a single value in {source} '
                                     '(a parameter is a value or a flat list of values)')
            _check(item, path + [f'[{i}]'], source)
        return
    if isinstance(node, MappingNode):
        seen = set()
        for key, value in node.value:
            if not isinstance(key, ScalarNode):
                raise ParameterError(_where(path + ['(complex key)']), None,
                                     f'a key must be a name, in {source}')
            _check(key, path + [key.value], source)
            if key.tag != _STR:
                raise ParameterError(_where(path + [key.value]), None,
                                     f'a key must be a name, not a number, in {source}')
            if key.value in seen:
                raise ParameterError(_where(path + [key.value]), None,
                                     f'given twice in {source}')
            seen.add(key.value)
            _check(value, path + [key.value], source)


def read_bytes(path: str | os.PathLike[str], key: str) -> bytes:
    """At most MAX_FILE_BYTES + 1 bytes of a file (never blocks on a FIFO
    without a writer); ParameterError(``key``) for a directory, an unreadable
    or an oversized file.
    """
    name = os.fspath(path)
    try:
        fd = os.open(name, os.O_RDONLY | getattr(os, 'O_NONBLOCK', 0))
    except OSError as exc:
        raise ParameterError(key, name, f'cannot read: {exc.strerror}') from None
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise ParameterError(key, name, 'cannot read: is a directory')
        if hasattr(os, 'set_blocking'):
            os.set_blocking(fd, True)       # a FIFO with a writer: wait for its data
        with os.fdopen(fd, 'rb', closefd=True) as stream:
            fd = -1
            data = stream.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ParameterError(key, name, f'cannot read: {exc.strerror}') from None
    finally:
        if fd >= 0:
            os.close(fd)
    if len(data) > MAX_FILE_BYTES:
        raise ParameterError(key, name, f'larger than {MAX_FILE_BYTES} bytes: not a parameter '
                                        'or scene file')
    return data


def read_yaml(path: str | os.PathLike[str], key: str = 'params_file') -> Any:
    """The YAML document of a file, read by the rules of the module docstring.
    Every problem raises ParameterError: ``key`` names the file's parameter
    (``params_file``, ``scene``), or the offending key inside the file.
    """
    source = str(Path(path))
    data = read_bytes(path, key)
    if b'\x00' in data:
        raise ParameterError(key, source, 'contains NUL bytes: a binary file, not YAML text')
    try:
        text = data.decode('utf-8-sig')
    except UnicodeDecodeError as exc:
        raise ParameterError(key, source, f'not UTF-8 text (byte 0x{data[exc.start]:02x} at '
                                          f'offset {exc.start})') from None
    loader = _StrictLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check(node, [], source)
        return loader.construct_document(node)
    except yaml.YAMLError as exc:
        message = str(exc).replace('"<unicode string>", ', '')
        raise ParameterError(key, source, f'not valid YAML: {message}') from None
    except RecursionError:          # bounded by MAX_DEPTH; a safety net only
        raise ParameterError(key, source, 'not valid YAML: nested too deeply') from None
    finally:
        getattr(loader, 'dispose', lambda: None)()
