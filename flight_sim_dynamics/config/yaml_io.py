"""Reading a YAML parameter or scene file the one safe way: every problem is one
:class:`ParameterError` naming the file (and the key). At most
:data:`MAX_FILE_BYTES`; no directory, NUL byte, non-UTF-8 text, anchor, alias or
key given twice. A plain value is a number only as a decimal (integers of at most
19 digits), a boolean only as true/false, null as ``~``, ``null`` or nothing;
anything else (``yes``, ``0x10``, ``010``, a date) is a string, as rcl reads it. A
``!!set`` is refused (no order: it would give a vector in hash order).
"""
from __future__ import annotations

import copy
import functools
import os
import re
import stat
from pathlib import Path
from typing import Any

import yaml
from yaml.composer import Composer
from yaml.constructor import SafeConstructor
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode
from yaml.resolver import BaseResolver

from .errors import ParameterError

#: Largest file read (bytes): the packaged parameter file is 6 KB.
MAX_FILE_BYTES = 256 * 1024

try:                # libyaml's parser: events at C speed
    from yaml.cyaml import CParser as _Parser
except ImportError:  # PyYAML built without libyaml
    from yaml.parser import Parser as _Parser  # type: ignore[assignment]


class _Resolver(BaseResolver):
    """Plain scalars: YAML 1.2's null, booleans, decimal numbers; the rest strings."""


for _tag, _pattern, _first in (
        ('null', r'(?:~|null|Null|NULL|)\Z', ['~', 'n', 'N', '']),
        ('bool', r'(?:true|True|TRUE|false|False|FALSE)\Z', 'tTfF'),
        ('int', r'[-+]?(?:0|[1-9][0-9]{0,18})\Z', '-+0123456789'),
        ('float', r'[-+]?(?:(?:[0-9]+\.[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?'
                  r'|[0-9]+[eE][-+]?[0-9]+|\.(?:inf|Inf|INF))\Z|\.(?:nan|NaN|NAN)\Z',
         '-+0123456789.')):
    _Resolver.add_implicit_resolver(f'tag:yaml.org,2002:{_tag}', re.compile(_pattern),
                                    list(_first))


class _StrictLoader(Composer, _Parser, SafeConstructor, _Resolver):  # type: ignore[misc,valid-type]
    """PyYAML's safe loader (libyaml's parser if any), refusing anchors and aliases."""

    def __init__(self, text: str) -> None:
        _Parser.__init__(self, text)
        Composer.__init__(self)
        SafeConstructor.__init__(self)
        _Resolver.__init__(self)

    def compose_node(self, parent: Node | None, index: Any) -> Node:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, 'anchor', None) is not None:
            raise yaml.MarkedYAMLError(None, None, 'anchors and aliases (&, *) are not allowed',
                                       event.start_mark)
        return super().compose_node(parent, index)


# launch_ros writes the list values a launch file gives as a dict with PyYAML's
# tuple tag; rcl reads them as sequences, and so does this loader
_StrictLoader.add_constructor('tag:yaml.org,2002:python/tuple',
                              SafeConstructor.construct_yaml_seq)


#: YAML's unordered collection: a set's items come out in hash order, not as written
_SET_TAG = 'tag:yaml.org,2002:set'


def _parameter_name(path: list[str]) -> str:
    """The dotted name of a node's ``path``: the parameter's own name inside ``ros__parameters``."""
    if 'ros__parameters' in path[:2]:
        path = path[path.index('ros__parameters') + 1:]
    return '.'.join(path)


def _check_nodes(node: Node, path: list[str], source: str) -> None:
    """ParameterError naming the first key given twice in a map, or the first
    ``!!set`` (no order: a vector given as one would be read in hash order).
    """
    if node.tag == _SET_TAG:
        items = ', '.join(str(key.value) for key, _ in node.value
                          if isinstance(key, ScalarNode))
        raise ParameterError(_parameter_name(path) or '(the document)', f'!!set {{{items}}}',
                             f'a set has no order: give a list [...] in {source}')
    if isinstance(node, SequenceNode):
        for i, item in enumerate(node.value):
            _check_nodes(item, path + [f'[{i}]'], source)
    elif isinstance(node, MappingNode):
        seen = set()
        for key, value in node.value:
            name = path + [str(key.value)]
            if isinstance(key, ScalarNode) and key.value in seen:
                raise ParameterError(_parameter_name(name), None, f'given twice in {source}')
            if isinstance(key, ScalarNode):
                seen.add(key.value)
            _check_nodes(value, name, source)


def read_bytes(path: str | os.PathLike[str], key: str) -> bytes:
    """At most MAX_FILE_BYTES + 1 bytes of a file (a FIFO without a writer does
    not block); ParameterError(``key``) otherwise.
    """
    name = os.fspath(path)
    try:
        fd = os.open(name, os.O_RDONLY | os.O_NONBLOCK)
    except OSError as exc:
        raise ParameterError(key, name, f'cannot read: {exc.strerror}') from None
    try:
        if stat.S_ISDIR(os.fstat(fd).st_mode):
            raise ParameterError(key, name, 'cannot read: is a directory')
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
    """The YAML document of a file (module docstring); ParameterError naming
    ``key`` (the file's parameter) or the offending key inside the file.
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
    # the caller owns its document: a deep copy of the one parsed (0.1 ms against
    # 2-3 ms of parsing a packaged file, which a process loads again and again)
    return copy.deepcopy(_parse(text, key, source))


@functools.lru_cache(maxsize=32)
def _parse(text: str, key: str, source: str) -> Any:
    """The document of ``text`` by read_yaml's rules (the last 32 texts' kept; a
    failure raised again each time); ParameterError as there.
    """
    loader = _StrictLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_nodes(node, [], source)
        return loader.construct_document(node)
    except yaml.YAMLError as exc:
        message = str(exc).replace('"<unicode string>", ', '')
        raise ParameterError(key, source, f'not valid YAML: {message}') from None
    except RecursionError:          # a file of a thousand nested brackets
        raise ParameterError(key, source, 'not valid YAML: nested too deeply') from None
    except ParameterError:          # a key of the file named (_check_nodes)
        raise
    except (ValueError, TypeError) as exc:      # an explicit tag its text does not fit (!!float x)
        raise ParameterError(key, source, f'not valid YAML: {exc}') from None
    finally:
        loader.dispose()
