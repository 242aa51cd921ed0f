"""Parameter files: the packaged one, ``--params-file``, a ROS 2 parameter file."""
from __future__ import annotations

import os
import re
import sys
from pathlib import Path
from typing import Any, Mapping, Sequence

from .errors import ParameterError
from .yaml_io import read_yaml

NODE_NAME = 'flight_sim_dynamics'
#: the top key of the packaged parameter files: the node of that name in any
#: namespace, as rcl reads it
PACKAGED_SECTION = '/**/' + NODE_NAME
PACKAGE_NAME = 'flight_sim_dynamics'
DEFAULT_PARAMS_FILE = 'flight_sim_dynamics.yaml'
#: Prefix of rclpy's QoS override parameters (the node's endpoints', read at start-up).
QOS_OVERRIDES = 'qos_overrides.'
#: Parameters rclpy declares on every node: a params file may set them; the models ignore them.
ROS_PARAMETERS = frozenset({'use_sim_time', 'start_type_description_service'})


def default_params_path() -> Path:
    """The packaged parameter file: a source checkout's config/, else the
    ament share directory, else <prefix>/share/flight_sim_dynamics/config.
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


def without_ros(flat: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(the parameters of ``flat`` that are no ROS 2 node's own, its
    ``qos_overrides.*``): :data:`ROS_PARAMETERS` are dropped, for every machine.
    """
    qos = {k: v for k, v in flat.items() if k.startswith(QOS_OVERRIDES)}
    return {k: v for k, v in flat.items() if k not in qos and k not in ROS_PARAMETERS}, qos


def section_applies(section: str, node: str) -> bool:
    """Whether a params-file section applies to the node ``node`` (fully
    qualified), as rcl decides: its fully qualified name, a bare name ``foo``
    being ``/foo`` (the node of that name in the root namespace only), or a
    pattern (``/**`` any namespaces, ``*`` one token).
    """
    pattern = re.escape(section if section.startswith('/') else '/' + section)
    pattern = pattern.replace(r'/\*\*', r'(/[^/]+)*').replace(r'\*', r'[^/]+')
    return re.fullmatch(pattern, node) is not None


def read_params_sections(path: str | os.PathLike[str],
                         node: str = '/' + NODE_NAME) -> dict[str, Any]:
    """The parameters of the node ``node`` in a ROS 2 parameter YAML file, as
    flat dotted names: the sections that apply, merged in file order, no value
    checked (the loader checks them by the rules of the file's machine,
    :mod:`.machine_files`).
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
        try:
            flat.update(flatten(params))
        except ParameterError as exc:
            raise ParameterError(exc.key, exc.value, f'{exc.reason} in {source}') from None
        found = True
    if not found:
        raise ParameterError('params_file', source,
                             f"no section for node '{NODE_NAME}' (or '/**')")
    return flat


def params_files_in(args: Sequence[str]) -> list[str]:
    """The files of ``--params-file FILE`` in the ROS arguments of ``args``."""
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
