"""The schema of a case file: every key a case may hold, declared once, with its kind and default
(`cases/README.md` documents the same keys with units).

A field is (kind, default); REQUIRED marks a field without default. Kinds: "float+" (> 0),
"float0+" (>= 0), "float", "int+", "int0+", "str", "line", "bool", "vec3", "vec", "floats",
"inertia", "point", "poisson", "strings" (a list of strings), a tuple of allowed strings, or a
nested dict schema.
"""

from __future__ import annotations

from flexmbd.mbd.joints import JOINT_COORDS     # the joint types' coordinate counts: the solver's, one place

REQUIRED = object()

# every number of a case (and of a solver's settings) is finite and at most this in magnitude; the
# section, stiffness and mass properties derived from a beam's or a rigid body's numbers must in
# turn lie within DERIVED (`_check_derived`), so that the products the solvers form stay finite
LARGEST = 1e100
DERIVED = (1e-200, 1e200)

# names of materials, bodies, joints, loads and channels: what a dotted key can address
NAME_CHARS = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-")

MATERIAL = {
    "E": ("float+", REQUIRED),
    "nu": ("poisson", REQUIRED),
    "rho": ("float+", REQUIRED),
}

SECTION = {
    "shape": (("rectangle", "circle"), REQUIRED),
    "b": ("float+", None),          # rectangle width, along the axis that is not h_axis
    "h": ("float+", None),          # rectangle height, along h_axis
    "d": ("float+", None),          # circle diameter
    "h_axis": (("y", "z"), "y"),    # body axis along which h lies
}

MODES = {
    "count": ("int0+", REQUIRED),
    "boundary": (("clamped-free", "hinged-hinged", "free-free", "craig-bampton"), "clamped-free"),
    "interfaces": ("vec", None),    # craig-bampton: interface positions along the beam, m
    "kinds": ("strings", None),     # keep the lowest `count` modes of these kinds (fe.modes.FAMILIES); None: any
    "static": ("vec", None),        # static correction modes at these positions along the beam (each segment), m
}

BEAM = {
    "type": (("beam",), REQUIRED),
    "material": ("str", REQUIRED),
    "length": ("float+", REQUIRED),
    "elements": ("int+", 100),
    "section": (SECTION, REQUIRED),
    "modes": (MODES, REQUIRED),
    "damping_ratio": ("float0+", 0.0),
    "stiffness_damping": ("float0+", 0.0),  # s: material damping sigma = E (eps + beta eps'), C = beta K (formulation §5b)
    "mass": (("lumped", "consistent"), "lumped"),
    "shear": ("bool", False),
    "rigid": ("bool", False),
    "stiffening": ("bool", True),   # geometric stiffening: the foreshortening of bent nodes (formulation §4b)
    "segments": ("int+", 1),        # modal solvers: N flexible beams of length L / N, joined rigidly
    "stress": (("forces", "modes"), "forces"),  # modal solvers' stress: force summation or mode displacement (formulation §7c)
}

MESH = {
    "file": ("str", None),              # a mesh file (.inp Abaqus, .bdf/.nas/.dat NASTRAN, .msh Gmsh), relative to the case
    "units": (("m", "mm"), "m"),        # the file's units: "m" (N, kg, s, Pa) or "mm" (N, t, s, MPa)
    "box": ("vec3", None),              # or a built-in box [L, h, b], m: x in [0, L], y in [-h/2, h/2], z in [-b/2, b/2]
    "divisions": ("vec3", None),        # box: elements along x, y, z (whole numbers)
    "element": (("hex20", "hex8", "tet10", "tet4"), "hex20"),   # box: the element kind
    "stiffness": ("str", None),         # an Abaqus matrix file (.mtx) of the file's mesh: K instead of assembling it
    "mass": ("str", None),              # the same for M (a solid's: Ms (x) I3)
}

INTERFACE = {
    "set": ("str", REQUIRED),           # a node set of the mesh (a box has "x0" and "xL", its end faces)
    "kind": (("rigid", "averaging"), "averaging"),  # RBE2-like (moves rigidly) or RBE3-like (a weighted fit)
    "point": ("vec3", None),            # reference point, mesh coordinates, m (default: the set's centroid)
}

SOLID_MODES = {
    "count": ("int0+", REQUIRED),
    "boundary": (("clamped-interface", "craig-bampton", "free-free"), "clamped-interface"),  # fe.solid.interface_modes
}

SOLID = {
    "type": (("solid",), REQUIRED),
    "material": ("str", None),          # default: the mesh file's one material
    "mesh": (MESH, REQUIRED),
    "interfaces": ({"*": INTERFACE}, REQUIRED),
    "frame": ("str", REQUIRED),         # the interface whose reference point is the body frame's origin
    "modes": (SOLID_MODES, REQUIRED),
    "damping_ratio": ("float0+", 0.0),
}

RIGID = {
    "type": (("rigid",), REQUIRED),
    "mass": ("float+", REQUIRED),
    "com": ("vec3", [0.0, 0.0, 0.0]),
    "inertia": ("inertia", REQUIRED),   # [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] about the com, kg m^2
}

POINT_MASS = {
    "type": (("point_mass",), REQUIRED),
    "mass": ("float+", REQUIRED),       # kg, at the body frame's origin; no rotational inertia
}

# the joints that may carry a point mass: those that leave it no rotation (it has no rotational
# inertia to resist one; a prismatic joint would be well posed, but MuJoCo refuses a moving body
# without inertia); nothing hangs on a point mass and no load acts on it (its parent's point does)
POINT_MASS_JOINTS = ("fixed",)

PROFILE = {
    "type": (("constant_rate", "harmonic", "spin_up", "table"), REQUIRED),
    "rate": ("float", None),            # constant_rate: rad/s or m/s
    "amplitude": ("float", None),       # harmonic
    "frequency": ("float+", None),      # harmonic, Hz
    "phase": ("float", 0.0),            # harmonic, rad
    "offset": ("float", 0.0),           # harmonic
    "W": ("float", None),               # spin_up: final rate
    "T": ("float+", None),              # spin_up: spin-up time
    "file": ("str", None),              # table: CSV with columns t, q (relative to the case file)
}

JOINT = {
    "type": (("revolute", "prismatic", "fixed", "spherical", "free"), REQUIRED),
    "parent": ("str", REQUIRED),
    "child": ("str", REQUIRED),
    "at": ("point", None),              # beam parent: position along it (m); solid: an interface; else a point (vec3)
    "axis": ("vec3", [0.0, 0.0, 1.0]),  # revolute / prismatic axis in the input triad
    "rpy": ("vec3", [0.0, 0.0, 0.0]),   # input triad orientation in the parent frame, rad
    "q0": ("floats", None),
    "qd0": ("floats", None),
    "motion": (PROFILE, None),          # prescribed motion (1-DOF joints)
    "loop": ("bool", False),            # a cut joint: closes a kinematic loop (its child has a tree joint)
    "child_at": ("point", None),        # a loop joint: where it sits on its child (as `at` on the parent)
}

LOAD_PROFILE = {
    "type": (("constant", "step", "ramp", "harmonic"), "constant"),
    "t0": ("float0+", 0.0),             # step / ramp start, s
    "t1": ("float+", None),             # ramp end, s
    "frequency": ("float+", None),      # harmonic, Hz
    "phase": ("float", 0.0),            # harmonic, rad
}

LOAD = {
    "type": (("point_force",), REQUIRED),
    "body": ("str", REQUIRED),
    "at": ("point", REQUIRED),          # beam: position along it (m); solid: an interface; rigid: a point (vec3)
    "force": ("vec3", REQUIRED),        # N
    "frame": (("body", "global"), "body"),
    "profile": (LOAD_PROFILE, {"type": "constant"}),
}

# the stress channels, each a function of the stresses at one point (docs/durability.md): von Mises
# (unsigned), the normal stress along the beam's axis or the solid's x axis (signed: tension
# positive), and von Mises with the sign of the principal stress of largest magnitude
STRESS_KINDS = ("stress_vm", "stress_normal", "stress_signed_vm")

CHANNEL = {
    "kind": (("deflection", *STRESS_KINDS, "joint_angle", "energy", "reaction_force", "reaction_moment"), REQUIRED),
    "body": ("str", None),
    "joint": ("str", None),
    "at": ("point", None),              # m along the beam; a solid's interface (deflection)
    "point": ("vec3", None),            # a stress on a solid: a point in the body frame, m
    "component": (("x", "y", "z"), "y"),
    "fibre": ("vec", None),             # stress point (y, z) in the section, m; default outer fibre
    "direction": ("vec3", None),        # stress_normal on a solid: the direction (body frame); default x
}

INTEGRATOR = {
    "method": (("adams", "dopri5", "fox-goodwin", "exp-adams", "rk45", "dop853", "rk4"), "adams"),
    "rtol": ("float+", 1e-8),
    "atol": ("float+", 1e-10),
    "max_step": ("float+", 1e-3),       # s
    "dt": ("float+", 1e-4),             # s, fixed-step methods
    "refresh": ("int+", 25),            # exp-adams: steps between two linearizations (integrate.EXP_REFRESH)
    "output_dt": ("float+", 1e-3),      # s, sampling of the result table
}

REPORT = {
    "reference": ("solver", None),
    "solvers": ("solvers", None),
    "tolerances": ("tolerances", None),  # channel -> relative tolerance (None: TOLERANCES by channel kind)
    "graded_from": ("float0+", 0.0),    # s: the differences are taken over t >= this (a start-up left out)
    "snapshots": ("vec", None),         # s: instants of the deformed-shape snapshots (default `snapshot_instants`)
    "shape_points": ("int0+", 11),      # evenly spaced points along each flexible beam drawn in them (0: none)
    "notes": ("str", ""),               # what a reader of the case page should know of its reference and verdicts
    "expected_failures": ("explanations", {}),   # solver = why its run is expected to fail (shown on the page)
}

# the relative tolerance of each channel kind in a case that gives no report.tolerances (the RMS
# difference from the reference over the reference's largest magnitude, as a given tolerance):
# the shipped cases' own choices for their converged references
TOLERANCES = {"deflection": 0.05, **{k: 0.05 for k in STRESS_KINDS}, "joint_angle": 0.01, "energy": 0.01,
              "reaction_force": 0.05, "reaction_moment": 0.05}

# a case's own S-N curve (docs/durability.md): N = 10^log_a S^-m on each segment, S in MPa, the
# highest ranges first, segment k down to the range lower[k] (the last one's lower: 0 goes on)
CURVE = {
    "name": ("line", "the case's own S-N curve"),
    "m": ("floats", REQUIRED),          # slopes, one per segment
    "log_a": ("floats", REQUIRED),      # log10 of each segment's constant, S in MPa
    "lower": ("floats", REQUIRED),      # MPa: each segment's lowest range
    "cutoff": ("bool", False),          # no damage below the last segment's lower range
}

# a case's fatigue count of its signed stress channels (docs/durability.md, cases/README.md)
DURABILITY = {
    "channels": ("strings", REQUIRED),  # signed stress channels (stress_normal, stress_signed_vm)
    "curve": ("curve", "dnv-c"),        # a name of harness.durability.CURVES or a CURVE table
    "correction": (("none", "goodman", "walker"), "none"),
    "ultimate": ("float+", None),       # Pa: the material's ultimate strength (goodman)
    "gamma": ("float+", 0.5),           # walker's exponent
    "residue": (("half", "repeat"), "half"),    # the residue as half cycles, or the history repeated
    "discard": ("float0+", 0.0),        # s: the start-up left out of the count
    "tolerance": ("float+", 0.05),      # verdict: |S_eq / S_eq of the reference - 1| at most this
}

# the system's frequencies against a setting, shown on the case page (`flexmbd modes --system --sweep`)
FREQUENCY_MAP = {
    "key": ("line", REQUIRED),          # the swept case key (a number)
    "start": ("float", REQUIRED),       # its first value
    "stop": ("float", REQUIRED),        # its last value
    "values": ("int+", REQUIRED),       # evenly spaced values, ends included (>= 2)
    "set": ("strings", []),             # KEY=VALUE overrides the map is taken with (a crank held: its rate 0)
    "tracks": ("int+", 3),              # the lowest tracks drawn and tabulated
    "peers": ("strings", []),           # solvers whose own eigen-solve is set beside flexmbd's
}

# the deformed-shape snapshots: at most this many instants (one panel each) and shape points per beam
MAX_SNAPSHOTS = 12
MAX_SHAPE_POINTS = 101

CASE = {
    "title": ("line", REQUIRED),
    "duration": ("float+", REQUIRED),
    "gravity": ("vec3", [0.0, 0.0, 0.0]),
    "materials": ({"*": MATERIAL}, REQUIRED),
    "bodies": ({"*": "body"}, REQUIRED),
    "joints": ({"*": JOINT}, REQUIRED),
    "loads": ({"*": LOAD}, {}),
    "channels": ({"*": CHANNEL}, REQUIRED),
    "integrator": (INTEGRATOR, {}),
    "solvers": ("solver_settings", {}),
    "report": (REPORT, {}),
    "durability": (DURABILITY, None),
    "frequency_map": (FREQUENCY_MAP, None),
}


JOINT_DOFS = {k: nv for k, (_, nv) in JOINT_COORDS.items()}

# the keys without default that each kind of channel reads (the others must be left out)
CHANNEL_KEYS = {"deflection": ("body", "at"), **{k: ("body", "at", "fibre", "point") for k in STRESS_KINDS},
                "stress_normal": ("body", "at", "fibre", "point", "direction"),
                "joint_angle": ("joint",),
                "reaction_force": ("joint",), "reaction_moment": ("joint",), "energy": ()}
