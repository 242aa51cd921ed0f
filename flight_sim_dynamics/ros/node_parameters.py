"""The node's parameters on an rclpy node: declared from the schema with
their descriptors (:mod:`.descriptors`), checked one by one for the parameter
services, read as plain values.

A value given at start-up that its descriptor refuses (``-p
bodies.platform.mass:=-1.0``) does not end a managed node: the parameter is
declared with its packaged default, the problem is kept, and every configure
fails with it until the parameter is set (``ros2 param set``). Under
``autostart`` that first configure is the start-up, so the process exits 2.
"""
from __future__ import annotations

from typing import Any

from rclpy.node import Node
from rclpy.parameter import Parameter

from ..config import parameters as prm
from .descriptors import declarations, plain

#: Parameters ROS itself declares on every node; not ours to check.
ROS_PARAMETERS = frozenset({'use_sim_time', 'start_type_description_service'})


class NodeParameters:
    """The schema's parameters declared on ``node`` (see the module's docstring).

    :attr:`given`: the names given on the command line or in params files;
    :attr:`unknown`: those of them that are not parameters of the node.
    """

    def __init__(self, node: Node) -> None:
        self._node = node
        #: start-up values the descriptors refused: name -> the error
        self.refused: dict[str, prm.ParameterError] = {}
        self.given = set(node.list_parameters([], 0).names) - ROS_PARAMETERS
        given = {name: node.get_parameter(name).value for name in self.given}
        for name in self.given:
            # re-declared below with our descriptors (ours), by the endpoints
            # (qos_overrides.*) or not at all (unknown: reported)
            node.undeclare_parameter(name)
        ours = {name: value for name, value in given.items() if name in prm.SPECS}
        for name, value in list(ours.items()):
            try:
                prm.check_value(prm.SPECS[name], plain(value))
            except prm.ParameterError as exc:
                self.refused[name] = exc
                del ours[name]
        while True:     # statically typed, the given values in the declared type
            try:
                declared = declarations(ours)
                break
            except prm.ParameterError as exc:
                if exc.key not in ours:
                    raise
                self.refused[exc.key] = exc
                del ours[exc.key]
        node.declare_parameters('', declared, ignore_override=True)

    @property
    def unknown(self) -> list[str]:
        """Names given at start-up that are no parameter of the node (typos)."""
        return sorted(name for name in self.given if not self._node.has_parameter(name))

    def values(self) -> dict[str, Any]:
        """Every parameter of the schema, as plain Python values."""
        get = self._node.get_parameter
        return {name: plain(get(name).value) for name in prm.SPECS}

    def startup_problem(self) -> prm.ParameterError | None:
        """The first start-up value refused and not set since, if any."""
        return next(iter(self.refused.values()), None)

    def set(self, names: list[str]) -> None:
        """``names`` were set: their start-up problems are gone."""
        for name in names:
            self.refused.pop(name, None)

    @staticmethod
    def precheck(param: Parameter) -> str | None:
        """What is wrong with one of our parameters on its own (type, range),
        if anything: cheap, for the parameter services.
        """
        spec = prm.SPECS.get(param.name)
        if spec is None:
            return None
        try:
            prm.check_value(spec, plain(param.value))
        except prm.ParameterError as exc:
            return str(exc)
        return None
