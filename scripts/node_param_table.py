#!/usr/bin/env python3
"""Print the node's parameters as Markdown tables, from parameters.SPECS
(the same schema the node declares its ParameterDescriptors from).

    python -m scripts.node_param_table            # node parameters + model parameters
    python -m scripts.node_param_table --node     # node parameters only
    python -m scripts.node_param_table --twin     # the twin node platform_sim's

(from the repository root).

The per-body rows (bodies.<body>.mass/com/inertia) are folded into one row
each, with the body names listed once.
"""
from __future__ import annotations

import argparse
import sys
from typing import Sequence

from flight_sim_dynamics.config import parameters as prm
from flight_sim_dynamics.config.schema import SIM_PARAMETERS
from flight_sim_dynamics.core.model import BODY_NAMES

TYPES = {'double': 'double', 'double_array': 'double[]', 'integer': 'int',
         'string': 'string', 'bool': 'bool'}


def value_range(spec: prm.ParamSpec) -> str:
    return spec.range_text.replace('|', '\\|')


def default(spec: prm.ParamSpec) -> str:
    value = spec.default
    if isinstance(value, list):
        if len(value) > 3:
            return 'see YAML'
        return '[' + ', '.join(f'{v:g}' for v in value) + ']'
    if isinstance(value, float):
        return f'{value:g}'
    return f'`{value}`' if isinstance(value, str) else str(value)


def row(name: str, spec: prm.ParamSpec, description: str | None = None) -> str:
    text = (description or spec.description).replace('|', '\\|')
    return (f'| `{name}` | {TYPES[spec.kind]} | {spec.unit or "-"} | {default(spec)} '
            f'| {value_range(spec)} | {text} |')


def table(specs: list[prm.ParamSpec]) -> list[str]:
    lines = ['| name | type | unit | default | range | meaning |',
             '|---|---|---|---|---|---|']
    folded = set()
    for spec in specs:
        parts = spec.name.split('.')
        if parts[0] == 'bodies' and len(parts) == 3:
            if parts[2] in folded:
                continue
            folded.add(parts[2])
            meaning = spec.description.replace(parts[1], '<body>')
            lines.append(row(f'bodies.<body>.{parts[2]}', spec, meaning)
                         .replace(f'| {default(spec)} |', '| see YAML |'))
        else:
            lines.append(row(spec.name, spec))
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog='python -m scripts.node_param_table',
                                     description=__doc__.split('\n\n')[0])
    parser.add_argument('--node', action='store_true', help='node parameters only')
    parser.add_argument('--twin', action='store_true',
                        help="the twin node platform_sim's parameters only")
    args = parser.parse_args(argv)
    if args.twin:
        print('\n'.join(table(list(SIM_PARAMETERS))))
        return 0
    print('\n'.join(table(list(prm.NODE_PARAMETERS))))
    if not args.node:
        print()
        print('\n'.join(table(list(prm.MODEL_PARAMETERS))))
        print()
        print('`<body>` is one of ' + ', '.join(f'`{b}`' for b in BODY_NAMES) + '.')
    return 0


if __name__ == '__main__':
    sys.exit(main())
