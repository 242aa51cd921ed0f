"""Parameter files: where the packaged one is, which ``--params-file`` a ROS
command line gives, and how a ROS 2 parameter YAML file is read into flat
dotted names (as ROS 2 flattens them), by the rules of :mod:`.yaml_io`, each
value of a known name type- and range-checked against the schema with the
file named (:func:`check_file_values`).
"""
from __future__ import annotations

import os
import re
import sys
from pathlib import Path
from typing import Any, Mapping, Sequence

from .errors import ParameterError
from .schema import SPECS
from .validation import check_value
from .yaml_io import read_yaml

NODE_NAME = 'flight_sim_dynamics'
PACKAGE_NAME = 'flight_sim_dynamics'
DEFAULT_PARAMS_FILE = 'flight_sim_dynamics.yaml'


def default_params_path() -> Path:
    """The packaged parameter file. Code imported from a source checkout reads
    the checkout's own config/ (code and defaults always match); an installed
    package reads its share directory: the ament index on a ROS install, else
    <prefix>/share/flight_sim_dynamics/config of a pip install.
    """
    candidates = []
    source = Path(__file__).resolve().parents[2]
    if (source / 'package.xml').is_file():
        candidates.append(source / 'config')
    try:  # a colcon/ROS install
        from ament_index_python.packages import get_package_share_directory
        candidates.append(Path(get_package_share_directory(PACKAGE_NAME)) / 'config')
    except Exception:  # noqa: BLE001 - not installed through ament, or no ament_index
        pass
    candidates.append(Path(sys.prefix) / 'share' / PACKAGE_NAME / 'config')
    for folder in candidates:
        path = folder / DEFAULT_PARAMS_FILE
        if path.is_file():
            return path
    raise FileNotFoundError(
        f'packaged parameter file {DEFAULT_PARAMS_FILE} not found in: '
        + ', '.join(str(c) for c in candidates))


def flatten(tree: Mapping[str, Any], prefix: str = '') -> dict[str, Any]:
    """Nested YAML maps to dotted names, as ROS 2 flattens parameters."""
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        name = f'{prefix}{key}'
        if isinstance(value, Mapping):
            if not value:
                raise ParameterError(name, value, 'empty group')
            flat.update(flatten(value, name + '.'))
        else:
            flat[name] = value
    return flat


def check_file_values(flat: Mapping[str, Any], source: str) -> None:
    """Check every value of a parameter of the schema in ``flat`` (read from the
    file ``source``) against its spec: ParameterError naming the key and the
    file. Unknown names are left to :func:`.validation.check_names`.
    """
    for key, value in flat.items():
        if key in SPECS:
            try:
                check_value(SPECS[key], value)
            except ParameterError as exc:
                raise ParameterError(exc.key, exc.value, f'{exc.reason} in {source}') from None


def section_applies(section: str, node: str) -> bool:
    """Whether a params-file section applies to the node of fully qualified
    name ``node`` (``/ns/flight_sim_dynamics``), as rcl decides: the node's
    name alone, its fully qualified name, or a pattern where ``/**`` stands for
    any namespaces and ``*`` for one name token.
    """
    if section == node.rsplit('/', 1)[-1]:
        return True
    pattern = re.escape(section if section.startswith('/') else '/' + section)
    pattern = pattern.replace(r'/\*\*', r'(/[^/]+)*').replace(r'\*', r'[^/]+')
    return re.fullmatch(pattern, node) is not None


def read_params_file(path: str | os.PathLike[str],
                     node: str = '/' + NODE_NAME) -> dict[str, Any]:
    """Read a ROS 2 parameter YAML file and return the parameters of the node
    ``node`` (fully qualified name) as a flat dict of dotted names. Sections
    that apply (:func:`section_applies`: ``/**``, ``flight_sim_dynamics``,
    ``/flight_sim_dynamics`` ...) are merged in file order; other nodes'
    sections are ignored, as ROS does. The names are not checked here (see
    :func:`.parameters.read_params`).
    """
    source = str(Path(path))
    doc = read_yaml(path, 'params_file')
    if not isinstance(doc, Mapping):
        raise ParameterError('params_file', source,
                             "expected a map '<node name>: ros__parameters: ...'")
    flat: dict[str, Any] = {}
    found = False
    for section, body in doc.items():
        if not section_applies(str(section), node):
            continue
        if not isinstance(body, Mapping) or 'ros__parameters' not in body:
            raise ParameterError(section, body, f"section has no 'ros__parameters' map in "
                                                f'{source}')
        params = body['ros__parameters']
        if not isinstance(params, Mapping):
            raise ParameterError(f'{section}.ros__parameters', params, f'expected a map in '
                                                                       f'{source}')
        flat.update(flatten(params))
        found = True
    if not found:
        raise ParameterError('params_file', source,
                             f"no section for node '{NODE_NAME}' (or '/**')")
    check_file_values(flat, source)
    return flat


def params_files_in(args: Sequence[str]) -> list[str]:
    """The files of ``--params-file FILE`` in the ROS arguments of a command
    line (between ``--ros-args`` and ``--`` or the end), in order.
    """
    files: list[str] = []
    in_ros = False
    for i, arg in enumerate(args):
        if arg == '--ros-args':
            in_ros = True
        elif arg == '--':
            in_ros = False
        elif in_ros and arg == '--params-file' and i + 1 < len(args):
            files.append(args[i + 1])
    return files
