"""The record every mesh-file reader fills from one file (`Parsed`), in the file's own units and
numbers, and its parts: a kind's elements, a set's members, a material, a bar's section and
orientation, a point mass. `convert.mesh` checks it and turns it into an SI Mesh. The lists may
be numpy arrays (Gmsh gives them whole); a line 0 is one the file does not tell."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple


class Elements(NamedTuple):
    """One kind's elements, in the file's order."""
    numbers: list           # (ne,) the file's element numbers
    nodes: list             # (ne, nn) the file's node numbers of each, in fe.mesh's node order
    lines: list             # (ne,) the line of each


class Members(NamedTuple):
    """A node or element set's members, as the file lists them (repeats allowed)."""
    numbers: list           # (k,) node or element numbers
    lines: list             # (k,) the line that lists each


@dataclass
class Material:
    """A material in file units; None where the file gives no value."""
    E: float | None = None
    nu: float | None = None
    rho: float | None = None
    line: int = 0           # the line that defines it


class Bar(NamedTuple):
    """A bar element's section and orientation vector, file units (`Mesh.bars`' columns)."""
    A: float
    I1: float
    I2: float
    J: float
    K1: float               # shear factors, 0: none
    K2: float
    v: tuple                # (3,) the orientation vector, basic axes


class PointMass(NamedTuple):
    """A frame's point mass at a grid (NASTRAN CONM2), file units."""
    eid: int
    grid: int
    m: float
    I11: float
    I22: float
    I33: float
    line: int


@dataclass
class Parsed:
    """One file's contents."""
    source: str
    node_ids: list = field(default_factory=list)        # (N,) the file's node numbers
    xyz: list = field(default_factory=list)             # (N, 3) positions
    node_lines: list = field(default_factory=list)      # (N,) the line of each node
    elements: dict = field(default_factory=dict)        # kind -> Elements
    node_sets: dict = field(default_factory=dict)       # name -> Members (node numbers)
    elem_sets: dict = field(default_factory=dict)       # name -> Members (element numbers)
    materials: dict = field(default_factory=dict)       # name -> Material
    bars: list = field(default_factory=list)            # a Bar for each of elements["bar2"], in order
    masses: list = field(default_factory=list)          # PointMass, in the file's order

    def node(self, number, xyz, line) -> None:
        self.node_ids.append(number)
        self.xyz.append(xyz)
        self.node_lines.append(line)

    def element(self, kind, number, nodes, line) -> None:
        elements = self.elements.setdefault(kind, Elements([], [], []))
        elements.numbers.append(number)
        elements.nodes.append(nodes)
        elements.lines.append(line)


def add(table, name, numbers, line) -> None:
    """Append numbers (all from one line) to the set `name` (matched without case) of `table`."""
    entry = table.setdefault(named(table, name), Members([], []))
    entry.numbers.extend(numbers)
    entry.lines.extend([line] * len(numbers))


def named(table, name) -> str:
    """The key of `table` that equals `name` without regard to case, else `name`."""
    low = name.lower()
    return next((k for k in table if k.lower() == low), name)
