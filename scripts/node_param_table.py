"""The parameter tables of docs/node.md, docs/twin.md and docs/cueing_node.md, from
the declarations the nodes make their descriptors from (``--update``: write them
there).
"""
from __future__ import annotations

import argparse
import sys
from typing import Sequence

from flight_sim_dynamics.config import parameters as prm
from flight_sim_dynamics.config.node_schema import node_schema
from flight_sim_dynamics.config.schema import CUEING_NODE_PARAMETERS, SIM_PARAMETERS
from flight_sim_dynamics.config.cueing import PARAMETER_SPECS as CUEING_PARAMETERS
from flight_sim_dynamics.machines import STEWART
from flight_sim_dynamics.machines.staicu.model import BODY_NAMES

from . import DOCS, replace_block

TYPES = {'double_array': 'double[]', 'integer': 'int'}     # else the kind's own name
HEADER = ['| name | type | unit | default | range | meaning |', '|---|---|---|---|---|---|']


def default(spec: prm.ParamSpec, value: object = None) -> str:
    value = spec.default if value is None else value
    if value is None:
        return 'none'
    if isinstance(value, list):
        return 'see YAML' if len(value) > 3 else '[' + ', '.join(f'{v:g}' for v in value) + ']'
    if isinstance(value, float):
        return f'{value:g}'
    return f'`{value}`' if isinstance(value, str) else str(value)


def table(specs: Sequence[prm.ParamSpec], fold: bool = True,
          defaults: dict | None = None) -> list[str]:
    """One row per parameter (``defaults``: their values where the specs have
    none); with ``fold`` (the 3-DOF machine's) the per-body rows
    (bodies.<body>.*) folded into one each, the lengths (geometry.*) into one.
    """
    lines, folded = list(HEADER), set()
    lengths = [s.name.split('.')[1] for s in specs if s.name.startswith('geometry.')]
    for spec in specs:
        name, meaning = spec.name, spec.description
        value = default(spec, (defaults or {}).get(name))
        parts = name.split('.') if fold else ['']
        if parts[0] == 'geometry':
            if 'geometry' in folded:
                continue
            folded.add('geometry')
            name, value = 'geometry.<length>', 'see YAML'
            meaning = ('the lengths of docs/design/mechanism.md: ' + ', '.join(lengths))
        elif parts[0] == 'bodies' and len(parts) == 3:
            if parts[2] in folded:
                continue
            folded.add(parts[2])
            name, value = f'bodies.<body>.{parts[2]}', 'see YAML'
            meaning = meaning.replace(parts[1], '<body>')
        cells = [f'`{name}`', TYPES.get(spec.kind, spec.kind), spec.unit or '-', value,
                 spec.range_text, meaning]
        lines.append('| ' + ' | '.join(c.replace('|', '\\|') for c in cells) + ' |')
    return lines


def blocks() -> dict[tuple[str, str], str]:
    """(page, marker name) -> the table text."""
    bodies = '`<body>` is one of ' + ', '.join(f'`{b}`' for b in BODY_NAMES) + '.'
    node = '\n'.join(['Node parameters:', '', *table(prm.NODE_PARAMETERS), '',
                      "The 3-DOF machine's model parameters (the names of its YAML file; "
                      '`load_model` reads them too):', '', *table(prm.MODEL_PARAMETERS), '',
                      bodies])
    hexapod = '\n'.join(table(STEWART.parameter_specs, fold=False,
                               defaults=dict(node_schema('stewart_6dof').defaults)))
    return {('node.md', 'node-parameters'): node,
            ('node.md', 'hexapod-parameters'): hexapod,
            ('twin.md', 'twin-parameters'): '\n'.join(table(SIM_PARAMETERS)),
            ('cueing_node.md', 'cueing-node-parameters'): '\n'.join(
                table(CUEING_NODE_PARAMETERS + CUEING_PARAMETERS, fold=False))}


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog='python -m scripts.node_param_table',
                                     description=__doc__.split('\n\n')[0])
    parser.add_argument('--update', action='store_true',
                        help='write the tables between their markers in docs/')
    args = parser.parse_args(argv)
    for (page, name), text in blocks().items():
        print(text, end='\n\n')
        if args.update:
            replace_block(DOCS / page, name, text)
    return 0


if __name__ == '__main__':
    sys.exit(main())
