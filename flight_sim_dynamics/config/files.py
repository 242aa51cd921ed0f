"""Parameter files: where the packaged one is, and how a ROS 2 parameter YAML
file is read into flat dotted names (as ROS 2 flattens them)."""
from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any, Mapping

import yaml

from .errors import ParameterError

NODE_NAME = 'flight_sim_dynamics'
PACKAGE_NAME = 'flight_sim_dynamics'
DEFAULT_PARAMS_FILE = 'flight_sim_dynamics.yaml'


def default_params_path() -> Path:
    """The packaged parameter file. Code imported from a source checkout reads
    the checkout's own config/ (code and defaults always match); an installed
    package reads its share directory: the ament index on a ROS install, else
    <prefix>/share/flight_sim_dynamics/config of a pip install."""
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


def read_params_file(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a ROS 2 parameter YAML file and return this node's parameters as a
    flat dict of dotted names. Sections ``/**``, ``flight_sim_dynamics`` and
    ``/flight_sim_dynamics`` apply (in that order); other nodes' sections are
    ignored, as ROS does."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ParameterError('params_file', str(path), f'cannot read: {exc.strerror}') from None
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ParameterError('params_file', str(path), f'not valid YAML: {exc}') from None
    if not isinstance(doc, Mapping):
        raise ParameterError('params_file', str(path),
                             "expected a map '<node name>: ros__parameters: ...'")
    flat: dict[str, Any] = {}
    found = False
    for section in ('/**', NODE_NAME, '/' + NODE_NAME):
        if section not in doc:
            continue
        body = doc[section]
        if not isinstance(body, Mapping) or 'ros__parameters' not in body:
            raise ParameterError(section, body, "section has no 'ros__parameters' map")
        params = body['ros__parameters']
        if not isinstance(params, Mapping):
            raise ParameterError(f'{section}.ros__parameters', params, 'expected a map')
        flat.update(flatten(params))
        found = True
    if not found:
        raise ParameterError('params_file', str(path),
                             f"no section for node '{NODE_NAME}' (or '/**')")
    return flat
