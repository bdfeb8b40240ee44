"""The layering of DESIGN.md §7: a module imports only from its own layer or the layers below."""

import ast
import subprocess
import sys
from pathlib import Path

import flexmbd

ROOT = Path(flexmbd.__file__).resolve().parent

# module (dotted, under flexmbd) or package prefix -> layer, bottom to top
LAYERS = {
    "errors": 1, "jit": 1, "dense": 1, "spatial": 1, "fe": 1, "results": 1, "profiles": 1, "metrics": 1,
    "cases": 2, "flexbody": 2,
    "model": 3, "dynamics": 3, "integrate": 3,
    "channels": 5, "solver": 5, "adapters": 5, "solvers": 5,
    "report": 6, "bench": 6, "cli": 6, "__main__": 6, "__init__": 6,
}


def layer(module: str) -> int:
    head = module.split(".")[0]
    return LAYERS[head]


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
    return {m for m in out if m and m.split(".")[0] in LAYERS}


def test_every_module_has_a_layer():
    for p in ROOT.rglob("*.py"):
        rel = p.relative_to(ROOT).with_suffix("").as_posix().replace("/", ".")
        assert rel.split(".")[0] in LAYERS, rel


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
