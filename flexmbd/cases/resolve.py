"""The resolved case: what every solver, the channels and the report read, derived once from the
validated case data (`validate`) as typed, read-only values.

    materials   name -> Material (E, nu, rho; G)
    bodies      name -> Beam (material, section, modes, ...), Solid, Rigid (mass, com, inertia) or
                PointMass (a Rigid of mass only), file order
    joints      name -> Joint: parent and child, where it sits (a snapped Point on a beam parent, an
                offset in the parent frame), triad, unit axis, q0, qd0, motion, nq, nv: the tree
    loops       name -> Joint: the cut joints (`loop = true`) that close kinematic loops, also
                placed on their child (child_point, child_offset); no coordinates of their own
    loads       name -> Load: the body, the snapped Point on a beam, the offset, force, frame, profile
    channels    name -> Channel: kind, body or joint, the snapped Point on a beam, component, fibre
    tree        Link per body in tree order (parents first): index, kind, parent index, joint
    integrator, report, title, duration, gravity, solvers (the [solvers.NAME] tables as given)

Every position along a beam is snapped to its node once, by the one rule (`flexbody.node_index`).
A beam with `segments = N` is split, once, into N beams joined rigidly: `split` is the resolved
case of that expanded tree, which the modal solvers model (`split_segments`), with `whole` mapping
each segment back to its beam and `place` any position along a beam to its segment; the case
itself keeps the whole beam, which the channels measure. The reduced flexible bodies are computed
on first use, once per content (`flexbody.reduce`): the 20 equal segments of a rod reduce once.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass, field
from types import MappingProxyType

from flexmbd.fe import flexbody
from flexmbd.cases.schema import JOINT, JOINT_COORDS, STRESS_KINDS, TOLERANCES
from flexmbd.mbd.spatial import rotation_rpy


def read_only(x):
    """A read-only copy of plain case data: tables as mappings, lists as tuples."""
    if isinstance(x, dict):
        return MappingProxyType({k: read_only(v) for k, v in x.items()})
    if isinstance(x, list):
        return tuple(read_only(v) for v in x)
    return x


# ---------------------------------------------------------------------------------------------
# the parts of a case


@dataclass(frozen=True)
class Material:
    name: str
    E: float            # Young's modulus, Pa
    nu: float           # Poisson's ratio
    rho: float          # density, kg/m^3

    @property
    def G(self) -> float:
        """Shear modulus E / (2 (1 + nu)), Pa."""
        return flexbody.shear_modulus(self)


@dataclass(frozen=True)
class Section:
    shape: str          # "rectangle" or "circle"
    b: float | None     # rectangle width, along the body axis that is not h_axis, m
    h: float | None     # rectangle height, along h_axis, m
    d: float | None     # circle diameter, m
    h_axis: str         # "y" or "z"


@dataclass(frozen=True)
class Modes:
    count: int
    boundary: str       # "clamped-free", "hinged-hinged", "free-free", "craig-bampton"
    interfaces: tuple | None    # craig-bampton: interface positions along the beam, m
    kinds: tuple | None = None  # the kinds (`fe.modes.FAMILIES`) of the modes kept; None: any
    static: tuple | None = None     # positions along the beam (m) of its static correction modes


@dataclass(frozen=True)
class Beam:
    name: str
    material: Material
    length: float       # m, along the body's +x
    elements: int
    section: Section
    modes: Modes
    damping_ratio: float
    mass: str           # the FE mass matrix: "lumped" or "consistent"
    shear: bool
    rigid: bool         # declared rigid
    stiffening: bool    # geometric stiffening (docs/formulation.md §4b)
    segments: int       # the modal solvers' flexible segments joined rigidly
    stress: str = "forces"  # the modal solvers' stress: "forces" (force summation) or "modes" (docs/formulation.md §7c)
    stiffness_damping: float = 0.0  # s: beta of the material damping C = beta K (docs/formulation.md §5b)
    type: str = "beam"

    @property
    def geometry(self):
        """The section's properties (A, Iy, Iz, J, cy, cz, ...; `fe.section.Section`)."""
        return flexbody.beam_section(self)

    @property
    def flexible(self) -> bool:
        """Not declared rigid and with modes: flexible in the modal solvers' model."""
        return not self.rigid and self.modes.count > 0


@dataclass(frozen=True)
class MeshSpec:
    file: str | None    # the mesh file, absolute path
    units: str          # "m" or "mm": the file's units
    box: tuple | None   # a built-in box (L, h, b), m
    divisions: tuple | None     # its elements along x, y, z
    element: str        # its element kind
    stiffness: str | None = None    # Abaqus matrix files of the mesh file's K and M, absolute paths
    mass: str | None = None


@dataclass(frozen=True)
class Interface:
    name: str
    set: str            # the mesh's node set
    kind: str           # "rigid" (the frame's) or "averaging"
    point: tuple | None  # (3,) reference point, mesh coordinates, m (None: the set's centroid)


@dataclass(frozen=True)
class Solid:
    """A flexible solid: its mesh, its interfaces (node = its place in `flexbody.solid_order`),
    the frame's interface (body frame origin at its reference point, axes the mesh's)."""

    name: str
    material: Material
    mesh: MeshSpec
    interfaces: MappingProxyType    # name -> Interface, file order
    frame: str
    modes: Modes
    damping_ratio: float
    rigid: bool = False
    stiffening: bool = False
    segments: int = 1
    stiffness_damping: float = 0.0  # a beam's material damping; a solid has none (its key is a beam's)
    type: str = "solid"

    def __hash__(self):
        return hash((self.name, self.material, self.mesh, tuple(self.interfaces.items()), self.frame,
                     self.modes, self.damping_ratio))

    @property
    def flexible(self) -> bool:
        return self.modes.count > 0

    @property
    def length(self) -> float:
        """The mesh's largest extent, m: the size its deflections are measured against."""
        return flexbody.solid_length(self.mesh)

    @property
    def is_frame(self) -> bool:
        """True when the mesh is a frame of bar elements (`fe.frame`), False for a solid's."""
        return flexbody.solid_mesh(**dataclasses.asdict(self.mesh)).is_frame

    def node(self, interface: str) -> int:
        """The FlexBody node of an interface's reference point."""
        return flexbody.solid_order(self).index(interface)


@dataclass(frozen=True)
class Rigid:
    name: str
    mass: float         # kg
    com: tuple          # (3,) centre of mass in the body frame, m
    inertia: tuple      # (6,) [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] about the com, kg m^2
    type: str = "rigid"


@dataclass(frozen=True)
class PointMass(Rigid):
    """A point mass: a rigid body whose mass sits at its frame origin, without rotational inertia;
    fixed to its parent (`schema.POINT_MASS_JOINTS`), carrying nothing. Every reader of a Rigid
    reads it as one (centre of mass at the origin, zero inertia); an engine that cannot take a
    body without inertia asks for `type == "point_mass"` (or isinstance PointMass)."""

    com: tuple = (0.0, 0.0, 0.0)
    inertia: tuple = (0.0,) * 6
    type: str = "point_mass"


@dataclass(frozen=True)
class Point:
    """A position x along a beam (as the case names it) and the node it snaps to."""

    body: str
    x: float
    node: int
    x_node: float


@dataclass(frozen=True)
class Joint:
    name: str
    type: str           # revolute, prismatic, fixed, spherical, free
    parent: str         # body name, or "ground"
    child: str
    parent_index: int   # 0 for ground
    child_index: int
    point: Point | None  # on a beam parent: the position along it and its node
    offset: tuple       # (3,) where it sits in the parent frame, m (on a beam: its node, (x_node, 0, 0))
    rpy: tuple          # (3,) input triad orientation in the parent (or node) frame, rad
    triad: tuple        # (3, 3) rotation of the input triad, rows
    axis: tuple         # (3,) unit joint axis in the input triad
    q0: tuple
    qd0: tuple
    motion: MappingProxyType | None     # prescribed motion profile (`profiles`)
    nq: int             # coordinates: revolute, prismatic 1; spherical 4 (quaternion); free 7
    nv: int             # velocities: 1, 1, 3, 6
    loop: bool = False  # a cut joint closing a loop: no coordinates (nq, nv count what it leaves free)
    child_point: Point | None = None    # a loop joint on a beam child: the position along it and its node
    child_offset: tuple = (0.0, 0.0, 0.0)   # (3,) a loop joint: where it sits in the child frame, m

    @property
    def node(self) -> int:
        """The node of a beam parent the joint sits on, -1 off a beam."""
        return self.point.node if self.point else -1

    @property
    def x(self) -> float | None:
        """That node's position along the beam, m (None off a beam)."""
        return self.point.x_node if self.point else None


@dataclass(frozen=True)
class Load:
    name: str
    type: str           # point_force
    body: str
    point: Point | None  # on a beam: the position along it and its node
    offset: tuple       # (3,) where it acts in the body frame, m (on a beam: its node)
    force: tuple        # (3,) N
    frame: str          # "body" or "global"
    profile: MappingProxyType   # time profile (`profiles.load_factor`)


@dataclass(frozen=True)
class Channel:
    name: str
    kind: str           # deflection, stress_vm, joint_angle, energy, reaction_force, reaction_moment
    body: str | None
    joint: str | None
    at: float | None    # position along the beam as the case names it, m
    component: str      # x, y or z
    fibre: tuple | None  # stress point (y, z) in the section, m (None: the outer fibre)
    point: Point | None  # deflection and stress: at, snapped (a solid's deflection: its interface)
    where: tuple | None = None  # a solid's stress: the point (3,) in the body frame, m
    direction: tuple | None = None  # a solid's stress_normal: the unit direction (3,), body frame (None: x)


@dataclass(frozen=True)
class Integrator:
    method: str
    rtol: float
    atol: float
    max_step: float     # s
    dt: float           # s, fixed-step methods
    output_dt: float    # s, sampling of the result table
    refresh: int        # exp-adams: steps between two linearizations of its linear part


@dataclass(frozen=True)
class Report:
    reference: str | None
    solvers: tuple | None
    tolerances: MappingProxyType    # channel -> relative tolerance
    snapshots: tuple    # instants of the deformed-shape snapshots, s
    shape_points: int   # evenly spaced points along each flexible beam drawn in them
    notes: str = ""     # shown on the case page beside its accuracy table
    graded_from: float = 0.0    # s: the accuracy rows compare t >= this (a start-up left out)
    defaults: tuple = ()    # which of "reference", "tolerances" are defaults, not the case file's
    expected_failures: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))  # solver -> why its
    # run fails, shown on the page


@dataclass(frozen=True)
class Link:
    """A body's place in the tree."""

    name: str
    index: int          # 1..nb, parents before children (0: ground)
    kind: str           # "rigid" (a rigid body or a point mass), "beam" (flexible), "rigid beam" (a beam
                        # declared rigid) or "solid"
    parent: int         # parent body index, 0 for ground
    joint: str          # the joint to the parent
    nodes: int          # beam nodes (elements + 1); 0 for a rigid body
    modes: int          # modal coordinates (a flexible beam's mode count, else 0)


# ---------------------------------------------------------------------------------------------
# the resolved case


@dataclass(frozen=True)
class Resolved:
    title: str
    duration: float     # s
    gravity: tuple      # (3,) m/s^2, global frame
    materials: MappingProxyType     # name -> Material
    bodies: MappingProxyType        # name -> Beam | Rigid, file order
    joints: MappingProxyType        # name -> Joint, file order
    loads: MappingProxyType         # name -> Load
    channels: MappingProxyType      # name -> Channel
    integrator: Integrator
    report: Report
    solvers: MappingProxyType       # solver name -> its [solvers.NAME] table as given
    tree: tuple         # Link, in tree order (parents first)
    nq: int
    nv: int
    segments: MappingProxyType      # split beam -> its segments' body names, root first
    whole: MappingProxyType         # segment -> (its beam, the segment's root position along it, m);
                                    # held by the case and by its `split`
    split: Resolved | None = field(default=None, repr=False, compare=False)     # None: this one
    loops: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))   # name -> Joint: the cut joints
    durability: MappingProxyType | None = None      # the [durability] table as checked (None: none)
    frequency_map: MappingProxyType | None = None   # the [frequency_map] table (None: none)

    @property
    def modelled(self) -> Resolved:
        """The tree the modal solvers model: `split`, or this case when no beam is split."""
        return self.split or self

    @property
    def order(self) -> list:
        """Body names, parents before children."""
        return [b.name for b in self.tree]

    def link(self, name: str) -> Link:
        return next(b for b in self.tree if b.name == name)

    def joint_of(self, body: str) -> Joint:
        """The joint whose child is `body`."""
        return self.joints[self.link(body).joint]

    def children(self, body: str) -> list:
        """The joints whose parent is `body` ("ground" for the base), file order."""
        return [j for j in self.joints.values() if j.parent == body]

    def place(self, body: str, x: float) -> tuple[str, float]:
        """(segment, position along it) in `split` of position x (m) along `body`; a body that
        is not split is returned as it is."""
        n = len(self.segments.get(body, ()))
        if not n:
            return body, x
        k, local = segment_of(self.bodies[body].length, n, x)
        return segment_name(body, k), local

    def stress_sections(self, body: str) -> list:
        """Positions x of a beam's stress channels, sorted, without repeats (FlexBody.stress_x);
        a solid's stress points (3,), sorted, without repeats (FlexBody.S_solid)."""
        if isinstance(self.bodies.get(body), Solid):
            return sorted({c.where for c in self.channels.values() if c.kind in STRESS_KINDS and c.body == body})
        return sorted({c.point.x for c in self.channels.values() if c.kind in STRESS_KINDS and c.body == body})

    def reduced(self, name: str) -> flexbody.FlexBody:
        """The reduced flexible body `name` (computed once per content, `flexbody.reduce`)."""
        return flexbody.reduce(name, self.bodies[name], self.stress_sections(name))

    def flexible(self) -> dict:
        """Every flexible beam and solid, reduced, by name, in tree order."""
        return {b.name: self.reduced(b.name) for b in self.tree if b.kind in ("beam", "solid")}


def tree_order(data: dict) -> list:
    """Body names so that every parent comes before its children (file order kept otherwise)."""
    parent_of = {j["child"]: j["parent"] for j in data["joints"].values() if not j["loop"]}
    order, placed = [], {"ground"}
    while len(order) < len(parent_of):
        for name in data["bodies"]:
            if name not in placed and parent_of[name] in placed:
                order.append(name)
                placed.add(name)
    return order


def beam_point(beam: Beam, x: float) -> Point:
    return Point(body=beam.name, x=x, node=flexbody.node_index(beam.length, beam.elements, x),
                 x_node=flexbody.snapped(beam.length, beam.elements, x))


def _body(name: str, b: dict, materials: dict):
    if b["type"] == "rigid":
        return Rigid(name=name, mass=b["mass"], com=tuple(b["com"]), inertia=tuple(b["inertia"]))
    if b["type"] == "point_mass":
        return PointMass(name=name, mass=b["mass"])
    if b["type"] == "solid":
        m = b["mesh"]
        spec = MeshSpec(file=m["file"], units=m["units"], box=None if m["box"] is None else tuple(m["box"]),
                        divisions=None if m["divisions"] is None else tuple(m["divisions"]), element=m["element"],
                        stiffness=m["stiffness"], mass=m["mass"])
        if b["material"] is None:                       # the mesh file's one material
            mname, (E, nu, rho) = next(iter(flexbody.solid_mesh(**dataclasses.asdict(spec)).materials.items()))
            material = Material(name=mname, E=E, nu=nu, rho=rho)
        else:
            material = materials[b["material"]]
        faces = {n: Interface(name=n, set=i["set"], kind=i["kind"], point=None if i["point"] is None else tuple(i["point"]))
                 for n, i in b["interfaces"].items()}
        return Solid(name=name, material=material, mesh=spec, interfaces=MappingProxyType(faces), frame=b["frame"],
                     modes=Modes(count=b["modes"]["count"], boundary=b["modes"]["boundary"], interfaces=None),
                     damping_ratio=b["damping_ratio"])
    m = b["modes"]
    return Beam(name=name, material=materials[b["material"]], length=b["length"], elements=b["elements"],
                section=Section(**b["section"]), damping_ratio=b["damping_ratio"],
                stiffness_damping=b["stiffness_damping"], mass=b["mass"], shear=b["shear"],
                modes=Modes(count=m["count"], boundary=m["boundary"],
                            interfaces=None if m["interfaces"] is None else tuple(m["interfaces"]),
                            kinds=None if m["kinds"] is None else tuple(m["kinds"]),
                            static=None if m["static"] is None else tuple(m["static"])),
                rigid=b["rigid"], stiffening=b["stiffening"], segments=b["segments"], stress=b["stress"])


def _unit(v) -> tuple | None:
    """v (3,) scaled to unit length; None stays None."""
    return None if v is None else tuple(float(x) / math.hypot(*v) for x in v)


def _where(bodies: dict, body: str, at) -> tuple:
    """(Point or None, offset (3,)) of a position `at` on `body` (along a beam, or a point)."""
    b = bodies.get(body)
    if isinstance(b, Beam):
        p = beam_point(b, at)
        return p, (p.x_node, 0.0, 0.0)
    if isinstance(b, Solid):
        p = solid_point(b, at)
        return p, tuple(float(v) for v in flexbody.interface_offset(b, at))
    return None, tuple(float(v) for v in at)


def solid_point(solid: Solid, interface: str) -> Point:
    """An interface of a solid as a Point: x the interface's name, node its reference point's node."""
    return Point(body=solid.name, x=interface, node=solid.node(interface), x_node=interface)


def resolve(data: dict, split: bool = True) -> Resolved:
    """The resolved case of validated case data (`split`: also resolve the split tree)."""
    materials = {n: Material(name=n, **m) for n, m in data["materials"].items()}
    bodies = {n: _body(n, b, materials) for n, b in data["bodies"].items()}
    order = tree_order(data)
    index = {"ground": 0, **{name: k + 1 for k, name in enumerate(order)}}
    joint_of = {j["child"]: name for name, j in data["joints"].items() if not j["loop"]}
    joints, loops = {}, {}
    for jn, j in data["joints"].items():
        point, offset = _where(bodies, j["parent"], j["at"])
        jq, jv = (0, 0) if j["loop"] else JOINT_COORDS[j["type"]]
        norm = math.hypot(*j["axis"])
        cut = {}
        if j["loop"]:
            child_point, child_offset = _where(bodies, j["child"], j["child_at"])
            cut = {"loop": True, "child_point": child_point, "child_offset": child_offset}
        (loops if j["loop"] else joints)[jn] = Joint(
            name=jn, type=j["type"], parent=j["parent"], child=j["child"], parent_index=index[j["parent"]],
            child_index=index[j["child"]], point=point, offset=offset, rpy=tuple(j["rpy"]),
            triad=tuple(tuple(float(x) for x in row) for row in rotation_rpy(j["rpy"])),
            axis=tuple(float(a / norm) if norm > 0 else 0.0 for a in j["axis"]),
            q0=tuple(j["q0"]), qd0=tuple(j["qd0"]), motion=read_only(j["motion"]), nq=jq, nv=jv, **cut)
    tree, nq, nv = [], 0, 0
    for name in order:
        b, j = bodies[name], joints[joint_of[name]]
        kind = "rigid" if isinstance(b, Rigid) else "solid" if isinstance(b, Solid) else "rigid beam" if b.rigid else "beam"
        modes = b.modes.count if kind in ("beam", "solid") else 0
        nodes = 0 if kind == "rigid" else len(b.interfaces) + flexbody.solid_mesh(
            **dataclasses.asdict(b.mesh)).n_nodes if kind == "solid" else b.elements + 1
        tree.append(Link(name=name, index=index[name], kind=kind, parent=j.parent_index, joint=j.name,
                         nodes=nodes, modes=modes))
        nq, nv = nq + j.nq + modes, nv + j.nv + modes
    loads = {}
    for ln, ld in data["loads"].items():
        point, offset = _where(bodies, ld["body"], ld["at"])
        loads[ln] = Load(name=ln, type=ld["type"], body=ld["body"], point=point, offset=offset,
                         force=tuple(ld["force"]), frame=ld["frame"], profile=read_only(ld["profile"]))
    channels = {n: Channel(name=n, kind=c["kind"], body=c["body"], joint=c["joint"], at=c["at"],
                           component=c["component"], fibre=None if c["fibre"] is None else tuple(c["fibre"]),
                           point=_channel_point(bodies[c["body"]], c) if c["kind"] in ("deflection", *STRESS_KINDS)
                           else None, where=None if c["point"] is None else tuple(c["point"]),
                           direction=_unit(c["direction"]))
                for n, c in data["channels"].items()}
    ig, rep = data["integrator"], data["report"]
    parts = splits(data)
    segments = {name: tuple(segment_name(name, k) for k in range(n)) for name, n in parts.items()}
    whole = {s: (name, k * bodies[name].length / len(segs)) for name, segs in segments.items()
             for k, s in enumerate(segs)}
    expanded = split_segments(data) if split else data
    return Resolved(
        title=data["title"], duration=data["duration"], gravity=tuple(data["gravity"]),
        materials=MappingProxyType(materials), bodies=MappingProxyType(bodies), joints=MappingProxyType(joints),
        loads=MappingProxyType(loads), channels=MappingProxyType(channels), integrator=Integrator(**ig),
        report=Report(reference=rep["reference"], solvers=None if rep["solvers"] is None else tuple(rep["solvers"]),
                      tolerances=read_only(tolerances(rep["tolerances"], data["channels"])),
                      snapshots=tuple(rep["snapshots"]), shape_points=rep["shape_points"], notes=rep["notes"],
                      graded_from=rep["graded_from"],
                      defaults=("tolerances",) * (rep["tolerances"] is None),
                      expected_failures=read_only(rep["expected_failures"])),
        solvers=read_only(data["solvers"]), tree=tuple(tree), nq=nq, nv=nv,
        segments=MappingProxyType(segments), whole=MappingProxyType(whole),
        split=None if expanded is data else dataclasses.replace(resolve(expanded, split=False),
                                                                whole=MappingProxyType(whole)),
        loops=MappingProxyType(loops), durability=None if data["durability"] is None else read_only(data["durability"]),
        frequency_map=None if data["frequency_map"] is None else read_only(data["frequency_map"]))


def tolerances(given: dict | None, chans: dict) -> dict:
    """The report's tolerances: those the case gives (only those channels are graded), or, when it
    gives none, every channel's by its kind (`schema.TOLERANCES`)."""
    return dict(given) if given is not None else {n: TOLERANCES[c["kind"]] for n, c in chans.items()}


def _channel_point(body, c: dict) -> Point | None:
    """The Point of a deflection or stress channel: snapped along a beam, a solid's interface
    (none for a solid's stress: it is at a point of the body, `Channel.where`)."""
    if isinstance(body, Solid):
        return solid_point(body, c["at"]) if c["kind"] == "deflection" else None
    return beam_point(body, c["at"])


def is_fixed_base(case) -> bool:
    """True when every joint is fixed: the structure cannot move as a whole."""
    return all(j.type == "fixed" for j in case.joints.values())


# ---------------------------------------------------------------------------------------------
# segments: a beam split into flexible beams joined rigidly (docs/formulation.md §9)


def splits(data: dict) -> dict:
    """{beam: N} of the flexible beams with `segments` = N > 1 (a beam declared rigid or without
    modes is not split)."""
    return {name: b["segments"] for name, b in data["bodies"].items()
            if b["type"] == "beam" and not b["rigid"] and b["modes"]["count"] > 0 and b["segments"] > 1}


def modeless(data: dict) -> list:
    """Beams not declared rigid that retain no modes (`modes.count = 0`): the modal solvers model
    their rigid limit, as if declared rigid (`split_segments`)."""
    return [name for name, b in data["bodies"].items()
            if b["type"] == "beam" and not b["rigid"] and b["modes"]["count"] == 0]


def segment_name(beam: str, k: int) -> str:
    """Body name of segment k (0-based) of a split beam: 'beam:1' is its root segment."""
    return f"{beam}:{k + 1}"


def segment_of(length: float, n: int, x: float) -> tuple[int, float]:
    """(k, x - k length / n): the segment (0-based) of a beam split in n that holds position x (m),
    and x along that segment. A point on a boundary belongs to the segment that starts there
    (within round-off), the beam's end to the last segment."""
    s = x * n / length
    k = min(round(s) if abs(s - round(s)) < 1e-9 else int(s), n - 1)
    return k, min(max(x - k * length / n, 0.0), length / n)           # the end: within the last segment


def _place(data: dict, body: str, x):
    """(body, x) in the split tree of position x along `body` (a point [x, y, z] on a body that
    is not split is returned as it is)."""
    n = splits(data).get(body)
    if n is None:
        return body, x
    k, local = segment_of(data["bodies"][body]["length"], n, x)
    return segment_name(body, k), local


def split_segments(data: dict) -> dict:
    """The case data of the tree the modal solvers model: every flexible beam with `segments` = N
    > 1 replaced by N beams `beam:1` .. `beam:N` of length L / N and elements / N elements, each
    with the beam's `modes` table, joined by fixed joints `beam:k-k+1` at the end node of segment
    k. Segment 1 takes the beam's joint (same name, same parent); joints on the beam, loads and
    channels at position x go to the segment that holds x (`segment_of`). A beam without modes
    becomes a beam declared rigid, the modal model's limit (`modeless`). `data` itself when no
    beam is split or without modes."""
    from flexmbd.cases.validate import _check_joint_values, check_table
    parts, still = splits(data), modeless(data)
    if not parts and not still:
        return data
    bodies, joints = {}, {}
    for jn, j in data["joints"].items():
        j = copy.deepcopy(j)
        if j["child"] in parts:
            j["child"] = segment_name(j["child"], 0)
        j["parent"], j["at"] = _place(data, j["parent"], j["at"])
        joints[jn] = j
    for name, b in data["bodies"].items():
        n = parts.get(name)
        if n is None:
            bodies[name] = {**copy.deepcopy(b), "rigid": True} if name in still else copy.deepcopy(b)
            continue
        seg = {**copy.deepcopy(b), "length": b["length"] / n, "elements": b["elements"] // n, "segments": 1}
        for k in range(n):
            bodies[segment_name(name, k)] = copy.deepcopy(seg)
        for k in range(1, n):
            j = check_table({"type": "fixed", "parent": segment_name(name, k - 1), "child": segment_name(name, k),
                             "at": seg["length"]}, JOINT, "segments", "")
            _check_joint_values(j, "segments", "")
            joints[f"{name}:{k}-{k + 1}"] = j
    loads = copy.deepcopy(data["loads"])
    for ld in loads.values():
        ld["body"], ld["at"] = _place(data, ld["body"], ld["at"])
    chans = copy.deepcopy(data["channels"])
    for c in chans.values():
        if c["kind"] in ("deflection", *STRESS_KINDS):
            c["body"], c["at"] = _place(data, c["body"], c["at"])
    return {**copy.deepcopy(data), "bodies": bodies, "joints": joints, "loads": loads, "channels": chans}
