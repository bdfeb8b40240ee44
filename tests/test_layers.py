"""The layering of docs/architecture.md: a module imports only from its own layer or the layers
below, every package is one layer, and `import flexmbd` (or a name of its `__init__`, which
re-exports the API) counts as an import of the top layer."""

import pytest
import ast
import re
import subprocess
import sys
from pathlib import Path

import flexmbd
from flexmbd.mbd.compiled import jit

pytestmark = pytest.mark.kernel_free

ROOT = Path(flexmbd.__file__).resolve().parent

# package -> layer, bottom to top (docs/architecture.md): one entry a package, each above the ones it imports
LAYERS = {"mbd": 1, "core": 2, "fe": 3, "cases": 4, "harness": 5, "solvers": 6, "report": 7, "cli": 8}
FLAT = {"version": 0, "__init__": 9, "__main__": 9}     # the only modules outside a package


def layer(module: str) -> int:
    """The layer of a module (dotted, under flexmbd; '__init__' for the package itself): its package's."""
    return FLAT[module] if module in FLAT else LAYERS[module.split(".")[0]]


def target(base: str, name: str) -> str:
    """The module that `from flexmbd[.base] import name` reads: base when it is a module; else the
    submodule base.name when there is one; else the package's `__init__` (a name it defines)."""
    where = ROOT.joinpath(*base.split(".")) if base else ROOT
    if base and where.with_suffix(".py").is_file():
        return base
    sub = where / name
    if sub.with_suffix(".py").is_file() or (sub / "__init__.py").is_file():
        return f"{base}.{name}".lstrip(".")
    return f"{base}.__init__".lstrip(".")


def imported(source: str) -> set:
    """flexmbd modules imported by a source text (module level and inside functions): `import
    flexmbd` is its `__init__`, `import flexmbd.X` is X, `from flexmbd[.P] import X` is the
    module X or, for a name, the package's `__init__` (`target`)."""
    out = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            out |= {"__init__" if a.name == "flexmbd" else a.name.removeprefix("flexmbd.")
                    for a in node.names if a.name == "flexmbd" or a.name.startswith("flexmbd.")}
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module \
                and (node.module == "flexmbd" or node.module.startswith("flexmbd.")):
            base = node.module.removeprefix("flexmbd").lstrip(".")
            out |= {target(base, a.name) for a in node.names}
    return out


def upward(module: str, source: str) -> list:
    """The imports of `source`, the text of `module`, from a layer above the module's."""
    return [f"{module} (layer {layer(module)}) imports {m} (layer {layer(m)})"
            for m in sorted(imported(source)) if layer(m) > layer(module)]


def modules() -> dict:
    """Every module of the package (dotted, under flexmbd) -> its file."""
    return {p.relative_to(ROOT).with_suffix("").as_posix().replace("/", "."): p for p in ROOT.rglob("*.py")}


def test_every_module_is_in_a_package_but_the_version_and_the_entry_points():
    assert len(LAYERS) <= 8 and all("." not in k for k in LAYERS)
    flat = sorted(rel for rel in modules() if "." not in rel)
    assert flat == sorted(FLAT), flat
    for rel in modules():
        assert layer(rel) is not None, rel
    assert {p.name for p in ROOT.iterdir() if (p / "__init__.py").is_file()} == set(LAYERS)


def test_every_package_says_what_it_holds_and_may_import():
    """Each package's docstring (its __init__) is a few lines saying what it holds."""
    for name in LAYERS:
        doc = ast.get_docstring(ast.parse((ROOT / name / "__init__.py").read_text()))
        assert doc and len(doc.split()) >= 20 and "import" in doc, name


def test_no_module_imports_a_higher_layer():
    bad = []
    for rel, p in modules().items():
        bad += upward(rel, p.read_text())
    assert not bad, bad


def test_a_planted_upward_import_is_caught():
    """The scanner sees every form of an upward import, the bare package's included, and passes
    the downward ones."""
    planted = ["import flexmbd", "import flexmbd as f", "from flexmbd import __version__",
               "from flexmbd import load_case", "from flexmbd import cli", "import flexmbd.solvers",
               "from flexmbd.report import build", "from flexmbd.report.build import write",
               "from flexmbd.solvers.build import from_case", "def f():\n    from flexmbd.solvers import inhouse\n"]
    for source in planted:
        assert upward("harness.results", source), source
    assert upward("mbd.model", "import flexmbd") == ["mbd.model (layer 1) imports __init__ (layer 9)"]
    fine = ("from flexmbd.core import errors, files\nfrom flexmbd.core.errors import InputError\n"
            "from flexmbd.version import __version__\nfrom flexmbd.fe import assembly\nimport numpy")
    assert not upward("harness.results", fine)
    assert imported(fine) == {"core.errors", "core.files", "version", "fe.assembly"}


def test_the_solver_imports_nothing_of_the_harness():
    """Every module of the solver's package (`flexmbd.mbd`) imports only from it, so that the
    solver can be read, run and tested without the case files; numba and llvmlite appear only in
    its compiled sub-package."""
    outside, compiling = [], []
    for rel, p in modules().items():
        source = p.read_text()
        if rel.startswith("mbd."):
            outside += [f"{rel} imports {m}" for m in sorted(imported(source)) if not m.startswith("mbd")]
        roots = {a.name.split(".")[0] for n in ast.walk(ast.parse(source)) if isinstance(n, ast.Import)
                 for a in n.names}
        roots |= {n.module.split(".")[0] for n in ast.walk(ast.parse(source))
                  if isinstance(n, ast.ImportFrom) and n.module and not n.level}
        if roots & {"numba", "llvmlite"} and not rel.startswith("mbd.compiled."):
            compiling.append(rel)
    assert not outside and not compiling, (outside, compiling)


def test_importing_the_solver_loads_nothing_else_of_flexmbd():
    code = ("import sys, flexmbd.mbd.integrate, flexmbd.mbd.constraints; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'flexmbd' and not m.startswith('flexmbd.mbd')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "['flexmbd']", out.stdout          # the package itself, whose __init__ is lazy


def test_the_cache_key_covers_every_file_with_compiled_code():
    """Every file that compiles (an njit or cfunc from the solver's jit) is in the hash naming the
    numba cache folder (`jit.compiled_sources`), with jit.py itself and the Model layout."""
    compiling = {p for p in modules().values() if re.search(r"@njit\b|\bcfunc\(", p.read_text())}
    hashed = set(jit.compiled_sources())
    assert ROOT / "mbd" / "dynamics.py" in compiling and compiling <= hashed, sorted(map(str, compiling - hashed))
    assert {ROOT / "mbd" / name for name in ("compiled/jit.py", "compiled/dense.py", "model.py", "compiled/entry.py")} <= hashed


def test_loading_a_case_imports_no_solver():
    code = ("import sys; from flexmbd import cases; "
            "cases.load('pendulum', ['solvers.exudyn-ffrf.dt=0.001', 'solvers.mujoco-rod.dt=1e-4']); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('exudyn', 'pinocchio', 'mujoco') "
            "or m.startswith('flexmbd.solvers') or m == 'flexmbd.harness.registry'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


LONGEST = 80        # lines a function may take, its def to its last line (generated tables aside: none today)


def function_lengths() -> list:
    """(lines, 'module:function') of every function of the package, longest first."""
    rows = []
    for rel, p in modules().items():
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                rows.append((node.end_lineno - node.lineno + 1, f"{rel}:{node.name}"))
    return sorted(rows, reverse=True)


def test_no_function_is_longer_than_80_lines():
    """A function that long does several jobs; the five longest are shown whether or not one is over."""
    rows = function_lengths()
    assert rows[0][0] <= LONGEST, rows[:5]
    assert len(rows) > 500 and rows[-1][0] >= 1


def test_the_length_count_sees_a_long_function():
    source = "def f():\n" + "    x = 1\n" * 90
    node = ast.parse(source).body[0]
    assert node.end_lineno - node.lineno + 1 == 91 > LONGEST
