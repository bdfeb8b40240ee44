"""NASTRAN bulk data (.bdf, .nas, .dat), own parser: small (8-character), large (GRID*,
16-character) and free (comma) fields, continuation lines (first field blank, '+...' or '*...'),
'$' comments, BEGIN BULK / ENDDATA when present. Each card is read by one function of CARDS into a
`Deck` (the record and the cross-references resolved at the end: `resolved`).

GRID (the basic coordinate system for positions; a displacement system CD only on grids that
orient no bar by X1-X3), CTETRA, CHEXA (the 20-grid mid-edge order 12 23 34 41, 15 26 37 48, 56 67
78 85 is reordered to fe.mesh's), MAT1 (two of E, G, NU give the third; RHO needed), PSOLID (the
elements of one body use one material), and as node sets: SPC/SPC1 "spc<SID>", SET1 "set<SID>",
RBE2 "rbe2_<EID>" (dependent grids), RBE3 "rbe3_<EID>" (the weighted grids; the weights are not
kept), each with its reference grid in "rbe2_<EID>_ref"/"rbe3_<EID>_ref". Materials are named
"mat<MID>". CBAR and CBEAM with PBAR and PBEAM make a frame ("bar2" cells and `Mesh.bars`, with the
shear factors K1, K2: a PBAR's blank 0, a PBEAM's NASTRAN's 1.0; docs/fe.md, Frames; a file holds
bars or 3-D elements, not both), with CONM2 point masses on its nodes (`Mesh.masses`: no offset,
basic axes, no products of inertia). Other element cards are refused; other cards are skipped.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from flexmbd.core.errors import InputError
from flexmbd.fe.meshfiles import common
from flexmbd.fe.meshfiles.common import integer, is_int, real
from flexmbd.fe.meshfiles.records import Bar, Material, Parsed, PointMass, add

# NASTRAN's CHEXA with 20 grids lists the mid-edge nodes 12 23 34 41, 15 26 37 48, 56 67 78 85;
# fe.mesh's order has the top face's edges before the vertical ones (the permutation is its own inverse)
HEX20 = np.r_[0:12, 16:20, 12:16]

# the solid element cards' kinds by their number of grids
SOLIDS = {"CTETRA": {4: "tet4", 10: "tet10"}, "CHEXA": {8: "hex8", 20: "hex20"}}

# NASTRAN cards that define elements: those not read (CARDS) are refused
ELEMENTS = {
    "CBAR", "CBEAM", "CBEND", "CBUSH", "CBUSH1D", "CBUSH2D", "CROD", "CONROD", "CTUBE", "CVISC",
    "CELAS1", "CELAS2", "CELAS3", "CELAS4", "CDAMP1", "CDAMP2", "CDAMP3", "CDAMP4", "CDAMP5",
    "CGAP", "CMASS1", "CMASS2", "CMASS3", "CMASS4", "CONM1", "CONM2", "CSHEAR", "CQUAD", "CQUAD4",
    "CQUAD8", "CQUADR", "CQUADX", "CTRIA3", "CTRIA6", "CTRIAR", "CTRIAX", "CTRIAX6", "CPENTA",
    "CPYRAM", "CWELD", "CFAST", "CSEAM", "CHACAB", "CHACBR", "CRAC2D", "CRAC3D"}


class Card(NamedTuple):
    """One bulk data card, its continuation lines joined."""
    name: str               # GRID, CTETRA, ... (upper case, a large-field '*' dropped)
    f: list                 # the data fields 2-9, 12-19, ... (continuation markers dropped), stripped
    line: int               # the line of its first field
    at: str                 # "FILE:LINE" of messages


class BarCard(NamedTuple):
    eid: int
    pid: int
    ga: int
    orient: object          # np.ndarray (3,) X1-X3, or the grid number G0
    line: int


class Section(NamedTuple):
    """A PBAR or PBEAM card."""
    mid: int
    values: list            # [A, I1, I2, J, K1, K2]
    line: int


@dataclass
class Deck:
    """A file's cards as read so far: the record, and what is cross-referenced at the end."""
    parsed: Parsed
    n_lines: int
    mat1: dict = field(default_factory=dict)        # MID -> Material
    psolid: dict = field(default_factory=dict)      # PID -> (MID, line)
    solids: list = field(default_factory=list)      # (EID, PID, line) of each CTETRA, CHEXA
    bars: list = field(default_factory=list)        # BarCard of each CBAR, CBEAM
    pbar: dict = field(default_factory=dict)        # PID -> Section
    local: dict = field(default_factory=dict)       # GRID ID -> its displacement system CD, where not basic


def parse(source) -> Parsed:
    """The record of a NASTRAN bulk data file."""
    text = common.text(source)
    deck = Deck(Parsed(source), len(text.splitlines()))
    for card in cards(source, text):
        read = CARDS.get(card.name)
        if read is not None:
            read(deck, card)
    return resolved(deck)


# ---------------------------------------------------------------------------------------------
# the cards, one function each


def grid(deck, c) -> None:
    f, at = c.f, c.at
    if f[1] not in ("", "0"):
        raise InputError(f"{at}: GRID {f[0]} has coordinate system CP={f[1]}: only the basic system "
                         "(CP blank or 0) is supported")
    if f[5] not in ("", "0"):
        deck.local[integer(f[0], at, "GRID ID")] = f[5]
    deck.parsed.node(integer(f[0], at, "GRID ID"), [real(v, at, "GRID X") if v else 0.0 for v in f[2:5]], c.line)


def solid(deck, c) -> None:
    """CTETRA, CHEXA."""
    f, at, name = c.f, c.at, c.name
    eid = integer(f[0], at, f"{name} EID")
    grids = [integer(v, at, f"{name} G") for v in f[2:] if v]
    sizes = SOLIDS[name]
    if len(grids) not in sizes:
        raise InputError(f"{at}: {name} {eid} has {len(grids)} grids (flexmbd reads "
                         f"{' or '.join(map(str, sizes))})")
    kind = sizes[len(grids)]
    if kind == "hex20":
        grids = list(np.asarray(grids)[HEX20])
    deck.parsed.element(kind, eid, grids, c.line)
    deck.solids.append((eid, integer(f[1], at, f"{name} PID") if f[1] else eid, c.line))


def bar(deck, c) -> None:
    """CBAR, CBEAM: EID PID GA GB X1|G0 X2 X3 OFFT; PA PB W1A W2A W3A W1B W2B W3B."""
    f, at, name = c.f, c.at, c.name
    eid = integer(f[0], at, f"{name} EID")
    ga, gb = (integer(v, at, f"{name} G{e}") for v, e in zip(f[2:4], "AB"))
    orient = _orientation(c, eid)
    if f[7] not in ("", "GGG"):
        raise InputError(f"{at}: {name} {eid}: OFFT {f[7]!r}: only GGG (the default) is read")
    for v, w in zip(f[8:16], ("PA", "PB", "W1A", "W2A", "W3A", "W1B", "W2B", "W3B")):
        if v and (real(v, at, f"{name} {w}") if w[0] == "W" else integer(v, at, f"{name} {w}")) != 0:
            raise InputError(f"{at}: {name} {eid}: {w} = {v}: pin flags and offsets are not supported")
    deck.parsed.element("bar2", eid, [ga, gb], c.line)
    deck.bars.append(BarCard(eid, integer(f[1], at, f"{name} PID") if f[1] else eid, ga, orient, c.line))


def _orientation(c, eid):
    """A bar's orientation: the grid G0, or the vector X1-X3 (np.ndarray)."""
    f, at, name = c.f, c.at, c.name
    if f[4] and is_int(f[4]) and not (f[5] or f[6]):
        return integer(f[4], at, f"{name} G0")
    if f[4] or f[5] or f[6]:
        return np.array([real(v, at, f"{name} X{k + 1}") if v else 0.0 for k, v in enumerate(f[4:7])])
    raise InputError(f"{at}: {name} {eid} has no orientation vector (X1-X3 or G0; BAROR is not read)")


def section(deck, c) -> None:
    """PBAR, PBEAM: a bar's section, constant, without non-structural mass, on principal axes."""
    name, at = c.name, c.at
    pid = integer(c.f[0], at, f"{name} PID")
    if pid in deck.pbar:
        raise InputError(f"{at}: {name} {pid} is defined twice (first on line {deck.pbar[pid].line})")
    f = c.f + [""] * 19                                 # the optional fields read as blank
    values, nsm, i12, shear = (_pbar if name == "PBAR" else _pbeam)(f, at, pid)
    A, I1, I2, J = (real(v, at, f"{name} {w}") if v else 0.0 for v, w in zip(values, ("A", "I1", "I2", "J")))
    K1, K2 = (real(v, at, f"{name} {w}") for v, w in zip(shear, ("K1", "K2")))
    for v, w in ((nsm, "NSM"), (i12, "I12")):
        if v and real(v, at, f"{name} {w}") != 0:
            raise InputError(f"{at}: {name} {pid}: {w} = {v}: only sections without non-structural mass "
                             "and with principal axes along the element's y and z are read")
    if not min(A, I1, I2, J) > 0 or min(K1, K2) < 0:
        raise InputError(f"{at}: {name} {pid}: A, I1, I2 and J must be positive and K1, K2 not negative (got "
                         f"{A:g}, {I1:g}, {I2:g}, {J:g}, {K1:g}, {K2:g})")
    deck.pbar[pid] = Section(integer(f[1], at, f"{name} MID"), [A, I1, I2, J, K1, K2], c.line)


def _pbar(f, at, pid) -> tuple:
    """([A, I1, I2, J], NSM, I12, (K1, K2)) fields of a PBAR: PID MID A I1 I2 J NSM; C1..F2; K1 K2 I12
    (a blank K: 0, no shear deformation)."""
    return f[2:6], f[6], f[18], (f[16] or "0", f[17] or "0")


def _pbeam(f, at, pid) -> tuple:
    """The same of a PBEAM: PID MID A I1 I2 I12 J NSM (end A); C1..F2; stations; K1 K2 ... (a blank
    K: NASTRAN's default 1.0); refused when a station's section differs from end A's."""
    k = 16
    while k < len(f) and f[k].upper() in ("YES", "YESA", "NO"):
        if f[k].upper() != "YESA" and any(real(a or "0", at, "PBEAM") != real(b or "0", at, "PBEAM")
                                          for a, b in zip(f[k + 2:k + 8], f[2:8])):
            raise InputError(f"{at}: PBEAM {pid}: a tapered beam (its stations' sections differ): "
                             "only a constant section is read")
        k += 16
    shear = tuple((f[j] if j < len(f) else "") or "1.0" for j in (k, k + 1))
    return [f[2], f[3], f[4], f[6]], f[7], f[5], shear


def conm2(deck, c) -> None:
    """CONM2: EID G CID M X1 X2 X3; I11 I21 I22 I31 I32 I33."""
    at = c.at
    f = c.f + [""] * 14
    eid = integer(f[0], at, "CONM2 EID")
    if f[2] not in ("", "0"):
        raise InputError(f"{at}: CONM2 {eid}: CID = {f[2]}: only the basic system (blank or 0) is supported")
    for v, w in zip(f[4:7] + [f[9], f[11], f[12]], ("X1", "X2", "X3", "I21", "I31", "I32")):
        if v and real(v, at, f"CONM2 {w}") != 0:
            raise InputError(f"{at}: CONM2 {eid}: {w} = {v}: only a mass at its grid with principal axes along "
                             "the basic ones is read (no offset, no products of inertia)")
    values = [real(v, at, f"CONM2 {w}") if v else 0.0 for v, w in zip([f[3], f[8], f[10], f[13]],
                                                                       ("M", "I11", "I22", "I33"))]
    if min(values) < 0:
        raise InputError(f"{at}: CONM2 {eid}: M and I11, I22, I33 must not be negative")
    deck.parsed.masses.append(PointMass(eid, integer(f[1], at, "CONM2 G"), *values, c.line))


def refuse(deck, c) -> None:
    """An element card flexmbd does not read."""
    raise InputError(f"{c.at}: {c.name} elements are not supported (CTETRA and CHEXA make a solid body, "
                     "CBAR and CBEAM a frame, CONM2 a point mass on a frame)")


def mat1(deck, c) -> None:
    """MAT1: MID E G NU RHO; two of E, G, NU give the third."""
    f, at = c.f, c.at
    mid = integer(f[0], at, "MAT1 MID")
    if mid in deck.mat1:
        raise InputError(f"{at}: MAT1 {mid} is defined twice (first on line {deck.mat1[mid].line})")
    E, G, nu, rho = (real(v, at, "MAT1 " + w) if v else None for v, w in zip(f[1:5], ("E", "G", "NU", "RHO")))
    if E is None and G is not None and nu is not None:
        E = 2.0 * G * (1.0 + nu)
    elif nu is None and E is not None and G is not None:
        nu = E / (2.0 * G) - 1.0
    if E is None or nu is None:
        raise InputError(f"{at}: MAT1 {mid}: two of E, G, NU are needed")
    deck.mat1[mid] = Material(E, nu, rho, c.line)


def psolid(deck, c) -> None:
    deck.psolid[integer(c.f[0], c.at, "PSOLID PID")] = (integer(c.f[1], c.at, "PSOLID MID"), c.line)


def grid_set(deck, c) -> None:
    """SPC (SID G1 C1 D1 G2), SPC1 (SID C G1 ...) as "spc<SID>", SET1 (SID G1 ...) as "set<SID>"."""
    f, at, name = c.f, c.at, c.name
    sid = integer(f[0], at, f"{name} SID")
    if name == "SPC":
        grids = [integer(v, at, "SPC G") for v in (f[1], f[4]) if v]
    else:
        grids = _thru(f[2 if name == "SPC1" else 1:], at, name, deck.n_lines)
    add(deck.parsed.node_sets, f"{'set' if name == 'SET1' else 'spc'}{sid}", grids, c.line)


def rbe2(deck, c) -> None:
    """RBE2: EID GN CM GM1 ... [ALPHA]: the dependent grids, and the reference grid."""
    f, at = c.f, c.at
    eid = integer(f[0], at, "RBE2 EID")
    dependent = []
    for v in f[3:]:
        if v and not is_int(v):
            break                                       # ALPHA, a real, ends the grid list
        if v:
            dependent.append(integer(v, at, "RBE2 GM"))
    add(deck.parsed.node_sets, f"rbe2_{eid}", dependent, c.line)
    add(deck.parsed.node_sets, f"rbe2_{eid}_ref", [integer(f[1], at, "RBE2 GN")], c.line)


def rbe3(deck, c) -> None:
    """RBE3: EID blank REFGRID REFC WT1 C1 G1,1 ... [UM ...]: the weighted grids, and the reference grid."""
    f, at = c.f, c.at
    eid = integer(f[0], at, "RBE3 EID")
    weighted, k = [], 4
    while k < len(f) and f[k].upper() not in ("UM", "ALPHA", "TREF", "STRESS"):
        if f[k] and not is_int(f[k]):
            real(f[k], at, "RBE3 WT")                   # a weight WTi (not kept), then its components Ci
            k += 2
            continue
        if f[k]:
            weighted.append(integer(f[k], at, "RBE3 G"))
        k += 1
    add(deck.parsed.node_sets, f"rbe3_{eid}", weighted, c.line)
    add(deck.parsed.node_sets, f"rbe3_{eid}_ref", [integer(f[2], at, "RBE3 REFGRID")], c.line)


# card name -> the function reading it; element cards not read are refused, other cards skipped
CARDS = {name: refuse for name in ELEMENTS} | {
    "GRID": grid, "CTETRA": solid, "CHEXA": solid, "CBAR": bar, "CBEAM": bar, "PBAR": section,
    "PBEAM": section, "CONM2": conm2, "MAT1": mat1, "PSOLID": psolid, "SPC": grid_set, "SPC1": grid_set,
    "SET1": grid_set, "RBE2": rbe2, "RBE3": rbe3}


# ---------------------------------------------------------------------------------------------
# cross-references


def resolved(deck) -> Parsed:
    """The record with its materials ("mat<MID>"), one for every element, and its bars' sections and
    orientation vectors (G0: towards that grid) from the properties the elements refer to."""
    source, parsed = deck.parsed.source, deck.parsed
    parsed.materials = {f"mat{mid}": m for mid, m in deck.mat1.items()}
    used = {}                                           # MID -> (EID, PID, line) of its first element
    for eid, pid, no in deck.solids + [(b.eid, b.pid, b.line) for b in deck.bars]:
        card, (mid, pline) = ("PSOLID", deck.psolid[pid]) if pid in deck.psolid else \
            ("PBAR", deck.pbar[pid][::2]) if pid in deck.pbar else (None, (None, None))
        if card:
            if mid not in deck.mat1:
                raise InputError(f"{source}:{pline}: {card} {pid} refers to material {mid}, which has no MAT1 card")
            used.setdefault(mid, (eid, pid, no))
    if len(used) > 1:
        (m1, (e1, p1, _)), (m2, (e2, p2, no)) = list(used.items())[:2]
        raise InputError(f"{source}:{no}: element {e2} has material mat{m2} (property {p2}) but element {e1} "
                         f"mat{m1} (property {p1}): the elements of one body must use one material")
    xyz = np.array(parsed.xyz, dtype=float).reshape(-1, 3)
    where = dict(zip(parsed.node_ids, range(len(parsed.node_ids))))
    for eid, pid, ga, orient, no in deck.bars:
        if pid not in deck.pbar:
            raise InputError(f"{source}:{no}: element {eid} refers to property {pid}, which has no PBAR or PBEAM card")
        if isinstance(orient, np.ndarray) and ga in deck.local:
            raise InputError(f"{source}:{no}: element {eid}'s orientation vector is in the displacement coordinate "
                             f"system CD={deck.local[ga]} of its node {ga}: only the basic system is supported "
                             "(or give G0)")
        if not isinstance(orient, np.ndarray):
            if orient not in where or ga not in where:
                raise InputError(f"{source}:{no}: element {eid} refers to node "
                                 f"{orient if orient not in where else ga}, which is not defined")
            orient = xyz[where[orient]] - xyz[where[ga]]
        parsed.bars.append(Bar(*deck.pbar[pid].values, v=tuple(orient)))
    return parsed


# ---------------------------------------------------------------------------------------------
# lines and fields


def cards(source, text):
    """Yield each bulk data Card, its continuation lines joined."""
    lines = text.splitlines()
    start = next((i + 1 for i, line in enumerate(lines) if re.match(r"\s*BEGIN\s+BULK", line, re.I)), 0)
    card = None
    for i in range(start, len(lines)):
        no = i + 1
        line = lines[i].split("$", 1)[0].rstrip()
        if not line.strip():
            continue
        if re.match(r"\s*ENDDATA", line, re.I):
            break
        if re.match(r"\s*INCLUDE", line, re.I):
            raise InputError(f"{source}:{no}: INCLUDE is not supported: merge the included file in")
        first, data = _fields(source, no, line)
        if not first or first[0] in "+*":
            if card is None:
                raise InputError(f"{source}:{no}: a continuation line with no card before it")
            card.f.extend(data)
        else:
            if card is not None:
                yield _paired(card)
            card = Card(first.upper().rstrip("*"), data, no, f"{source}:{no}")
    if card is not None:
        yield _paired(card)


def _paired(card) -> Card:
    """The card, refused when it ends in half a line: large-field lines hold four fields each and
    come in pairs (fields 2-5, then 6-9 on a continuation line), every other line eight."""
    if len(card.f) % 8:
        raise InputError(f"{card.at}: {card.name}*: a large-field card's lines come in pairs (fields 2-5, then "
                         "fields 6-9 on a continuation line starting with '*'): the continuation line is missing")
    return card


def _fields(source, no, line) -> tuple:
    """(first field, data fields) of one physical line: free (commas), large (16 characters: the
    first field ends or starts with '*') or small (8 characters) field format."""
    if "," in line:
        f = [v.strip() for v in line.split(",")]
        if len(f) > 10:
            raise InputError(f"{source}:{no}: a free-field line with more than 10 fields")
        n = 4 if f[0].endswith("*") or f[0].startswith("*") else 8
        return f[0], (f[1:n + 1] + [""] * n)[:n]
    line = line.expandtabs(8)
    first = line[:8].strip()
    if first.endswith("*") or first.startswith("*"):
        return first, [line[8 + 16 * k:24 + 16 * k].strip() for k in range(4)]
    return first, [line[8 + 8 * k:16 + 8 * k].strip() for k in range(8)]


def _thru(fields, at, card, n_lines) -> list:
    """Grid numbers of a list that may use 'G1 THRU G2' (G1 <= G2; `common.members` in a file of
    `n_lines` lines)."""
    out, fields = [], [v for v in fields if v]
    k = 0
    while k < len(fields):
        if fields[k].upper() == "THRU":
            if not out or k + 1 >= len(fields):
                raise InputError(f"{at}: {card}: THRU needs a number on each side")
            last = integer(fields[k + 1], at, card + " G")
            out.extend(common.members(out[-1], last, 1, at, f"{card}: {out[-1]} THRU {last}", n_lines)[1:])
            k += 2
        else:
            out.append(integer(fields[k], at, card + " G"))
            k += 1
    return out
