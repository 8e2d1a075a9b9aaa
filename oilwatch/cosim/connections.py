"""Connections between slaves: by matching names or from a list, checked, and batched for speed.

A connection copies one output of one slave to one input of another at every macro step. Same-name
matching connects each input to the output of the same name on another slave (the plant's
``x1_um`` to the estimator's ``x1_um``); an input that several slaves offer is ambiguous and must
be connected explicitly.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass

from .errors import SystemDescriptionError
from .loading import Port, Slave


@dataclass(frozen=True)
class Connection:
    """``start_element.start_connector`` (an output) feeds ``end_element.end_connector`` (an input).

    The field names are SSP's (``ssd:Connection``).
    """

    start_element: str
    start_connector: str
    end_element: str
    end_connector: str

    def __str__(self) -> str:
        return f"{self.start_element}.{self.start_connector} -> {self.end_element}.{self.end_connector}"


def same_name_connections(variables: dict[str, Iterable]) -> list[Connection]:
    """Connect every input to the same-named output of another instance (unmatched inputs stay).

    ``variables`` maps instance names to their variables (anything with ``name`` and
    ``causality``: this module's Variable or fmpy's ScalarVariable).
    """
    outputs: dict[str, list[str]] = defaultdict(list)
    for instance, items in variables.items():
        for variable in items:
            if variable.causality == "output":
                outputs[variable.name].append(instance)
    connections = []
    for instance, items in variables.items():
        for variable in items:
            if variable.causality != "input":
                continue
            sources = [name for name in outputs.get(variable.name, []) if name != instance]
            if len(sources) > 1:
                raise SystemDescriptionError(
                    f"input {instance}.{variable.name} matches outputs of {sources}; "
                    "give an explicit connection list"
                )
            if sources:
                connections.append(Connection(sources[0], variable.name, instance, variable.name))
    return connections


def check_connections(connections: list[Connection], slaves: dict[str, Slave]) -> None:
    """Raise SystemDescriptionError for an unknown instance or connector, a wrong causality, a type
    mismatch, or an input fed twice."""
    fed: dict[tuple[str, str], Connection] = {}
    for connection in connections:
        ends = (
            (connection.start_element, connection.start_connector, "output"),
            (connection.end_element, connection.end_connector, "input"),
        )
        found = []
        for element, connector, causality in ends:
            if element not in slaves:
                raise SystemDescriptionError(
                    f"connection {connection}: no FMU instance named {element!r} "
                    f"(instances: {sorted(slaves)})"
                )
            slave = slaves[element]
            if connector not in slave.variables:
                candidates = sorted(v.name for v in slave.variables.values() if v.causality == causality)
                raise SystemDescriptionError(
                    f"connection {connection}: FMU instance '{element}' ({slave.path.name}) has "
                    f"no connector {connector!r}; its {causality}s are {candidates}"
                )
            variable = slave.variables[connector]
            if variable.causality != causality:
                raise SystemDescriptionError(
                    f"connection {connection}: {element}.{connector} is a {variable.causality}, "
                    f"not an {causality}"
                )
            found.append(variable)
        if found[0].type != found[1].type:
            raise SystemDescriptionError(
                f"connection {connection}: type {found[0].type} cannot feed {found[1].type}"
            )
        key = (connection.end_element, connection.end_connector)
        if key in fed:
            raise SystemDescriptionError(f"input {'.'.join(key)} is fed twice: {fed[key]}, {connection}")
        fed[key] = connection


class Transfer:
    """All connections from one slave to another of one type, moved with one get and one set."""

    def __init__(self, source: Slave, target: Slave, pairs: list[tuple[str, str]], type_name: str):
        self.source = source
        self.target = target
        self.get = Port(source, [a for a, _ in pairs], type_name)
        self.put = Port(target, [b for _, b in pairs], type_name)

    def pull(self) -> None:
        """Read the source outputs into the buffer."""
        self.get.read()

    def push(self) -> None:
        """Write the buffered values to the target inputs."""
        self.put.write(self.get.values)

    def move(self) -> None:
        """pull() then push()."""
        self.get.read()
        self.put.write(self.get.values)


def make_transfers(connections: list[Connection], slaves: dict[str, Slave]) -> list[Transfer]:
    """Group checked connections into :class:`Transfer` batches (source, target, type)."""
    groups: dict[tuple[str, str, str], list[tuple[str, str]]] = defaultdict(list)
    for c in connections:
        type_name = slaves[c.start_element].variables[c.start_connector].type
        if type_name == "String":
            raise SystemDescriptionError(f"connection {c}: String connections are not supported")
        groups[(c.start_element, c.end_element, type_name)].append((c.start_connector, c.end_connector))
    return [
        Transfer(slaves[source], slaves[target], pairs, type_name)
        for (source, target, type_name), pairs in groups.items()
    ]
