"""Case files: TOML in (`validate`: defaults filled, every key checked, one-line errors naming the
file and key), the resolved case out (`resolve`: typed, read-only, every position snapped once,
the tree, the split of segmented beams, the reduced flexible bodies on first use).

A `Case` is a file's name, path, content hash and overrides, and its resolved case: a consumer
reads `case.bodies`, `case.joints`, `case.channels`, `case.integrator`, ... (`resolve.Resolved`),
never the file's dicts, which stay inside this package (`Case.data`). The schema (`schema`) holds
every key a case may hold, once; `cases/README.md` documents the same keys with units.

It imports the core, the FE package (a body's reduction, a mesh's checks) and the solver's joint
coordinate counts and loop rank rule (`flexmbd.mbd`); no solver and nothing of the harness.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

from flexmbd import version
from flexmbd.cases import closure
from flexmbd.cases.resolve import (Beam, Channel, Integrator, Joint, Link, Load, Material, Modes, Point, PointMass,
                                   Report, Resolved, Rigid, Section, is_fixed_base, resolve, segment_name, segment_of)
from flexmbd.cases.schema import (JOINT_COORDS, JOINT_DOFS, LARGEST, MAX_SHAPE_POINTS, MAX_SNAPSHOTS, STRESS_KINDS,
                                  TOLERANCES)
from flexmbd.cases.validate import (CASES_DIR, apply_override, available, check_table, find, hint, parse_toml,
                                    read_text, snapshot_instants, validate)

__all__ = ["Beam", "CASES_DIR", "Case", "Channel", "Integrator", "JOINT_COORDS", "JOINT_DOFS", "Joint", "LARGEST", "Link", "Load",
           "MAX_SHAPE_POINTS", "MAX_SNAPSHOTS", "Material", "Modes", "Point", "PointMass", "Report", "Resolved",
           "Rigid", "Section", "available", "check_table", "find", "hint", "is_fixed_base", "load", "segment_name",
           "segment_of", "snapshot_instants", "STRESS_KINDS", "TOLERANCES", "assembly_line"]

# what a Case reads from its resolved case (`resolve.Resolved`)
TYPED = ("title", "duration", "gravity", "materials", "bodies", "joints", "loads", "channels", "integrator",
         "report", "solvers", "tree", "nq", "nv", "segments", "whole", "split", "modelled", "order", "link",
         "joint_of", "children", "place", "stress_sections", "reduced", "flexible", "loops", "durability",
         "frequency_map")


@dataclass(frozen=True)
class Case:
    """A validated case: its name, file, content hash (of the text and the overrides) and
    overrides, and the resolved case everything reads (`resolved`, whose fields and methods
    the case also answers: TYPED). `data` is the file's content with every default filled in,
    read by this package only."""

    name: str
    path: Path
    data: dict = field(repr=False)
    sha256: str = ""
    overrides: tuple = field(default_factory=tuple)
    resolved: Resolved | None = field(default=None, repr=False, compare=False)
    assembly: tuple = ()    # ((joint, the file's q0 guess, the value that closes the loops), ...)

    def __post_init__(self):
        if self.resolved is None:
            object.__setattr__(self, "resolved", resolve(self.data))

    @functools.cached_property
    def content_sha256(self) -> str:
        """SHA-256 (hex) of what the case says: every value with its defaults and overrides filled
        in, and the content of the motion tables, mesh files and matrix files it reads. Unlike
        `sha256` (the file's text), a comment or a reordered table leaves it unchanged."""
        tables = [Path(j.motion["file"]).read_bytes() for j in self.joints.values()
                  if j.motion is not None and j.motion["type"] == "table"]
        meshes = [Path(f).read_bytes() for b in self.bodies.values() if b.type == "solid"   # a solid's mesh
                  for f in (b.mesh.file, b.mesh.stiffness, b.mesh.mass) if f]                # and matrix files
        return version.cache_key(self.data, *tables, *meshes)


for _name in TYPED:
    setattr(Case, _name, property(lambda self, _n=_name: getattr(self.resolved, _n),
                                  doc=f"`resolved.{_name}` (resolve.Resolved)"))


def load(name_or_path: str, overrides: list[str] | tuple = ()) -> Case:
    """Read, override (`KEY=VALUE` strings) and validate a case."""
    path = find(name_or_path)
    text = read_text(path)
    raw = parse_toml(text, path)
    for item in overrides:
        apply_override(raw, item, path)
    data = validate(raw, str(path))
    digest = version.cache_key(text, "\n".join(overrides), digits=16)
    case = Case(name=path.stem, path=path, data=data, sha256=digest, overrides=tuple(overrides))
    closed = closure.assemble(case, str(path))
    if not closed:
        return case
    joints = {n: dict(j, q0=[closed[n]]) if n in closed else j for n, j in data["joints"].items()}
    return Case(name=case.name, path=path, data={**data, "joints": joints}, sha256=digest, overrides=case.overrides,
                assembly=tuple((n, float(data["joints"][n]["q0"][0]), x) for n, x in closed.items()))


def assembly_line(case) -> str:
    """The loops' assembly every solver starts from, in one line: `crank_pin = -0.9553 rad,
    follower_pivot = 1.6666 rad (from the guesses -0.955, 1.667)`; '' without loops."""
    if not case.assembly:
        return ""
    unit = {n: "m" if case.joints[n].type == "prismatic" else "rad" for n, _, _ in case.assembly}
    got = ", ".join(f"{n} = {x:.6g} {unit[n]}" for n, _, x in case.assembly)
    return f"{got} (from the guesses {', '.join(f'{g:.6g}' for _, g, _ in case.assembly)})"
