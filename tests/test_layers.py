"""The layering of DESIGN.md §7: a module imports only from its own layer or the layers below."""

import ast
import subprocess
import sys
from pathlib import Path

import flexmbd

ROOT = Path(flexmbd.__file__).resolve().parent

# module (dotted, under flexmbd) or package prefix -> layer, bottom to top; the longest prefix wins.
# The kernel's numba plumbing below the algorithms (compiling, dense loops) sits at layer 1; the
# Bound and the compiled entry sit above the algorithms they call (docs/architecture.md).
LAYERS = {
    "errors": 1, "files": 1, "kernel.jit": 1, "kernel.dense": 1, "spatial": 1, "fe": 1, "results": 1, "profiles": 1,
    "metrics": 1,
    "cases": 2, "flexbody": 2,
    "invariants": 3, "joints": 3, "model": 3, "build": 3, "dynamics": 3,
    "kernel": 4, "integrate": 4,
    "channels": 5, "solver": 5, "adapters": 5, "solvers": 5, "linearize": 5, "cost": 5, "external": 5,
    "report": 6, "bench": 6, "cli": 6, "completion": 6, "__main__": 6, "__init__": 6,
}


def layer(module: str) -> int:
    parts = module.split(".")
    for n in range(len(parts), 0, -1):
        if ".".join(parts[:n]) in LAYERS:
            return LAYERS[".".join(parts[:n])]
    raise KeyError(module)


def imports(path: Path) -> set:
    """flexmbd modules imported by a file (module level and inside functions)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("flexmbd"):
            base = node.module.removeprefix("flexmbd").lstrip(".")
            for a in node.names:
                out.add(f"{base}.{a.name}".lstrip(".") if not base else base)
        elif isinstance(node, ast.Import):
            out |= {a.name.removeprefix("flexmbd.") for a in node.names if a.name.startswith("flexmbd.")}
    return {m for m in out if m and m.split(".")[0] in {k.split(".")[0] for k in LAYERS}}


def test_every_module_has_a_layer():
    for p in ROOT.rglob("*.py"):
        rel = p.relative_to(ROOT).with_suffix("").as_posix().replace("/", ".")
        assert layer(rel), rel


def test_no_module_imports_a_higher_layer():
    bad = []
    for p in ROOT.rglob("*.py"):
        rel = p.relative_to(ROOT).with_suffix("").as_posix().replace("/", ".")
        bad += [f"{rel} (layer {layer(rel)}) imports {m} (layer {layer(m)})"
                for m in imports(p) if layer(m) > layer(rel)]
    assert not bad, bad


def test_loading_a_case_imports_no_solver():
    code = ("import sys; from flexmbd import cases; "
            "cases.load('pendulum', ['solvers.exudyn-ffrf.dt=0.001', 'solvers.mujoco-rod.dt=1e-4']); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('exudyn', 'pinocchio', 'mujoco') "
            "or m.startswith('flexmbd.adapters') or m == 'flexmbd.solvers'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"
