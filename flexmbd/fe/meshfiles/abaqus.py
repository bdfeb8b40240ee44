"""Abaqus input files (.inp), own parser: *NODE (NSET=), *ELEMENT (TYPE=, ELSET=), *NSET and *ELSET
(GENERATE, or numbers and names of earlier sets), *MATERIAL with *ELASTIC (isotropic E, nu) and
*DENSITY; keywords are case-insensitive, set and material names keep their case and are matched
without it. Part/assembly structure is ignored, so the file must be flat: one *PART at most (one
part per body); *INSTANCE positioning data is not applied. *INCLUDE is refused; any other keyword
is skipped. Each keyword's options and data lines are read by the functions of KEYWORDS into a
`Deck`. The matrices of *MATRIX GENERATE / *MATRIX OUTPUT: `matrix.read_mtx`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, NamedTuple

from flexmbd.core.errors import InputError
from flexmbd.fe.mesh import NODES_PER
from flexmbd.fe.meshfiles import common
from flexmbd.fe.meshfiles.common import integer, is_int, is_real
from flexmbd.fe.meshfiles.records import Elements, Material, Parsed, add, named

KINDS = {"C3D4": "tet4", "C3D10": "tet10", "C3D10M": "tet10", "C3D10H": "tet10",
         "C3D8": "hex8", "C3D8R": "hex8", "C3D8H": "hex8", "C3D8I": "hex8",
         "C3D20": "hex20", "C3D20R": "hex20", "C3D20H": "hex20"}


@dataclass
class Deck:
    """A file's keywords and data lines as read so far."""
    parsed: Parsed
    n_lines: int
    keyword: str | None = None      # the current keyword: 'NODE', 'ELEMENT', ... (upper case)
    params: dict = field(default_factory=dict)      # its options {PARAMETER: value}, and 'name', 'first'
    kind: str | None = None         # the element kind of the latest *ELEMENT
    material: str | None = None     # the name of the latest *MATERIAL
    pending: tuple | None = None    # (line, node tokens) of an element whose line continues
    parts: int = 0                  # the *PARTs so far
    of_elements: list = field(default_factory=list)     # (node set, element set, line) of *NSET, ELSET=

    def at(self, no) -> str:
        return f"{self.parsed.source}:{no}"


def parse(source) -> Parsed:
    """The record of an Abaqus input file."""
    text = common.text(source)
    deck = Deck(Parsed(source), len(text.splitlines()))
    for no, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s or s.startswith("**"):
            continue
        read = KEYWORDS.get(deck.keyword)
        if s.startswith("*"):
            _finish(deck)
            deck.keyword, deck.params = keyword(s)
            read = KEYWORDS.get(deck.keyword)
            if read is not None and read.options is not None:
                read.options(deck, no)
            deck.params["first"] = True
        elif read is not None and read.data is not None:
            read.data(deck, [t.strip() for t in s.split(",")], s, no)
    _finish(deck)
    if deck.of_elements:
        _nodes_of_element_sets(deck)
    parsed = deck.parsed
    parsed.elements = {k: v for k, v in parsed.elements.items() if v.numbers}
    return parsed


def keyword(line) -> tuple:
    """('NAME WORDS', {PARAMETER: value}) of an Abaqus keyword line; a parameter without a value
    maps to ''."""
    fields = line[1:].split(",")
    params = {}
    for p in fields[1:]:
        key, _, value = p.partition("=")
        if key.strip():
            params[" ".join(key.upper().split())] = value.strip().strip('"')
    return " ".join(fields[0].upper().split()), params


def _finish(deck) -> None:
    """InputError when an element's node list was left unfinished by the keyword (or the end) after it."""
    if deck.pending is not None:
        no, tokens = deck.pending
        raise InputError(f"{deck.at(no)}: element {tokens[0]} ({deck.params['TYPE']}) needs "
                         f"{NODES_PER[deck.kind]} nodes, got {len(tokens) - 1}")


def _nodes_of_element_sets(deck) -> None:
    """Fill the node sets of *NSET, ELSET=: the nodes of the elements of the set."""
    parsed = deck.parsed
    nodes_of = {e: c for numbers, conn, _ in parsed.elements.values() for e, c in zip(numbers, conn)}
    for name, elset, no in deck.of_elements:
        if named(parsed.elem_sets, elset) not in parsed.elem_sets:
            raise InputError(f"{deck.at(no)}: *NSET, ELSET={elset}: the file has no element set {elset!r}")
        numbers = parsed.elem_sets[named(parsed.elem_sets, elset)].numbers
        missing = [e for e in numbers if e not in nodes_of]
        if missing:
            raise InputError(f"{deck.at(no)}: element set {elset!r} lists element {missing[0]}, which is "
                             "not a defined solid element")
        add(parsed.node_sets, name, sorted({n for e in numbers for n in nodes_of[e]}), no)


# ---------------------------------------------------------------------------------------------
# the keywords: their options (on the keyword line) and their data lines, one function each


def part(deck, no) -> None:
    deck.parts += 1
    if deck.parts > 1:
        raise InputError(f"{deck.at(no)}: a second *PART: flexmbd reads one part per body (a flat "
                         "file, or one *PART); write each part to its own file")


def include(deck, no) -> None:
    raise InputError(f"{deck.at(no)}: *INCLUDE is not supported: merge the included file in")


def node(deck, no) -> None:
    if deck.params.get("SYSTEM", "R").upper() != "R":
        raise InputError(f"{deck.at(no)}: *NODE, SYSTEM={deck.params['SYSTEM']}: only rectangular coordinates "
                         "(SYSTEM=R) are supported")


def node_line(deck, tokens, s, no) -> None:
    """number, x[, y[, z]] (a blank coordinate 0), added to NSET= if given."""
    at = deck.at(no)
    if len(tokens) < 2 or not all(is_real(t) for t in tokens[1:4] if t) or not is_int(tokens[0]):
        raise InputError(f"{at}: *NODE data: expected 'number, x, y, z', got {s!r}")
    number = integer(tokens[0], at, "*NODE number")
    deck.parsed.node(number, [float(t) if t else 0.0 for t in (tokens[1:4] + ["", ""])[:3]], no)
    if deck.params.get("NSET"):
        add(deck.parsed.node_sets, deck.params["NSET"], [number], no)


def element(deck, no) -> None:
    params = deck.params
    deck.kind = KINDS.get(params.get("TYPE", "").upper())
    if deck.kind is None:
        raise InputError(f"{deck.at(no)}: element type {params.get('TYPE', '(none)')!r} is not supported "
                         f"(supported: {', '.join(KINDS)})")
    params["TYPE"] = params["TYPE"].upper()
    deck.parsed.elements.setdefault(deck.kind, Elements([], [], []))


def element_line(deck, tokens, s, no) -> None:
    """number, node numbers, continued on the next lines until the kind's count (C3D20: 16 + 5)."""
    if deck.pending is None:
        deck.pending = (no, [])
    deck.pending[1].extend(t for t in tokens if t)
    n = NODES_PER[deck.kind]
    if len(deck.pending[1]) < n + 1:
        return
    (start, numbers), deck.pending = deck.pending, None
    at, kind = deck.at(start), deck.params["TYPE"]
    if len(numbers) != n + 1 or not all(is_int(t) for t in numbers):
        raise InputError(f"{at}: element {numbers[0]} ({kind}) needs {n} node numbers, got {' '.join(numbers[1:])!r}")
    numbers = [integer(t, at, f"*ELEMENT, TYPE={kind}") for t in numbers]
    deck.parsed.element(deck.kind, numbers[0], numbers[1:], start)
    if deck.params.get("ELSET"):
        add(deck.parsed.elem_sets, deck.params["ELSET"], [numbers[0]], start)


def node_set(deck, no) -> None:
    """*NSET, NSET=name [, ELSET=name: the nodes of that element set] [, GENERATE]."""
    _named_set(deck, no, "NSET")
    if deck.params.get("ELSET"):
        deck.of_elements.append((deck.params["NSET"], deck.params["ELSET"], no))
    deck.params["name"] = named(deck.parsed.node_sets, deck.params["NSET"])


def elem_set(deck, no) -> None:
    """*ELSET, ELSET=name [, GENERATE]."""
    _named_set(deck, no, "ELSET")
    deck.params["name"] = named(deck.parsed.elem_sets, deck.params["ELSET"])


def _named_set(deck, no, what) -> None:
    if not deck.params.get(what):
        raise InputError(f"{deck.at(no)}: *{what} without {what}=name")


def set_line(deck, tokens, s, no) -> None:
    """A data line of *NSET or *ELSET: 'first, last[, step]' with GENERATE, else numbers and the
    names of sets defined before."""
    what = deck.keyword
    table = deck.parsed.node_sets if what == "NSET" else deck.parsed.elem_sets
    add(table, deck.params["name"], _members(deck.at(no), tokens, table, "GENERATE" in deck.params, what,
                                             deck.n_lines), no)


def _members(at, tokens, table, generate, what, n_lines) -> list:
    """The numbers listed on one data line of *NSET or *ELSET of a file of `n_lines` lines: 'first,
    last[, step]' with GENERATE (`common.members`), else numbers and the names of sets defined before."""
    tokens = [t for t in tokens if t]
    if generate:
        if not 2 <= len(tokens) <= 3 or not all(is_int(t) for t in tokens):
            raise InputError(f"{at}: *{what}, GENERATE: expected 'first, last[, increment]'")
        first, last, step = (integer(t, at, f"*{what}, GENERATE") for t in (tokens + ["1"])[:3])
        return list(common.members(first, last, step, at, f"*{what}, GENERATE: {first}, {last}, {step}", n_lines))
    out = []
    for t in tokens:
        if is_int(t):
            out.append(integer(t, at, f"*{what}"))
        else:
            name = named(table, t)
            if name not in table:
                raise InputError(f"{at}: *{what}: {t!r} is neither a number nor a set defined before")
            out.extend(table[name].numbers)
    return out


def system_line(deck, tokens, s, no) -> None:
    raise InputError(f"{deck.at(no)}: *SYSTEM (nodes in a local coordinate system) is not supported")


def material(deck, no) -> None:
    if not deck.params.get("NAME"):
        raise InputError(f"{deck.at(no)}: *MATERIAL without NAME=")
    deck.material = named(deck.parsed.materials, deck.params["NAME"])
    deck.parsed.materials.setdefault(deck.material, Material(line=no))


def elastic(deck, no) -> None:
    if deck.params.get("TYPE", "ISOTROPIC").upper() != "ISOTROPIC":
        raise InputError(f"{deck.at(no)}: *ELASTIC, TYPE={deck.params['TYPE']}: only isotropic elasticity "
                         "is supported")


def property_line(deck, tokens, s, no) -> None:
    """The one data line of *ELASTIC (E, nu) or *DENSITY (rho) of the latest *MATERIAL."""
    what = deck.keyword
    if deck.material is None:
        return
    if not deck.params.pop("first", False):
        raise InputError(f"{deck.at(no)}: *{what} of material {deck.material}: more than one data line "
                         "(temperature-dependent data is not supported)")
    values = [t for t in tokens if t]
    need = 2 if what == "ELASTIC" else 1
    if len(values) < need or not all(is_real(t) for t in values[:need]):
        raise InputError(f"{deck.at(no)}: *{what}: expected {'E, nu' if need == 2 else 'rho'}, got {s!r}")
    m = deck.parsed.materials[deck.material]
    if what == "ELASTIC":
        m.E, m.nu = float(values[0]), float(values[1])
    else:
        m.rho = float(values[0])


class Keyword(NamedTuple):
    options: Callable | None        # (deck, line): checks and state of the keyword line
    data: Callable | None           # (deck, fields, stripped line, line): one data line


# keyword -> the functions reading it; any other keyword is skipped with its data lines
KEYWORDS = {
    "PART": Keyword(part, None), "INCLUDE": Keyword(include, None), "NODE": Keyword(node, node_line),
    "ELEMENT": Keyword(element, element_line), "NSET": Keyword(node_set, set_line),
    "ELSET": Keyword(elem_set, set_line), "SYSTEM": Keyword(None, system_line),
    "MATERIAL": Keyword(material, None), "ELASTIC": Keyword(elastic, property_line),
    "DENSITY": Keyword(None, property_line)}
