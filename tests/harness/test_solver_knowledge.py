"""What belongs to one solver is declared on its module (flexmbd's inhouse.py, each peer's adapter):
its cost model (`stages`), its look on the figures (`STYLE`) and, for flexmbd, how long its first
run compiles (`COMPILE_S`). cost.py, the executor and the figures ask the module instead of
naming solvers, and the compile notices all say the one measured number."""

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import flexmbd
from flexmbd import cases, cli
from flexmbd.harness import cost, executor, registry
from flexmbd.solvers import linearize, inhouse
from flexmbd.mbd.compiled import jit
from flexmbd.report import figures, spectra

ROOT = Path(flexmbd.__file__).resolve().parent

# the figures' table of the built-in solvers as it was written in report/figures.py before each
# module declared its own: the looks must not change
LOOKS = {"flexmbd": ("#1f77b4", "o"), "fe-linear": ("#7f7f7f", "s"), "analytic": ("#8c564b", "D"),
         "exudyn-ffrf": ("#ff7f0e", "^"), "exudyn-beam": ("#2ca02c", "v"), "mujoco-rod": ("#d62728", "<"),
         "pinocchio": ("#9467bd", ">"), "mujoco": ("#e377c2", "P")}


def source(name: str) -> ast.Module:
    """The parsed source of a built-in solver's module."""
    return ast.parse((ROOT.parent / (registry.BUILT_IN[name].replace(".", "/") + ".py")).read_text())


@pytest.mark.parametrize("name", list(registry.BUILT_IN))
def test_every_built_in_module_declares_its_style_and_cost(name):
    tree = source(name)
    assigned = {t.id for node in tree.body if isinstance(node, ast.Assign) for t in node.targets
                if isinstance(t, ast.Name)}
    functions = {node.name: node for node in tree.body if isinstance(node, ast.FunctionDef)}
    assert "STYLE" in assigned and set(figures.declared(name, "STYLE")) == {"color", "marker"}
    assert [a.arg for a in functions["stages"].args.args] == ["case", "t_end", "settings"]
    mod = registry.module(name)
    if mod is not None:                                 # its engine is installed: the declarations as imported
        assert callable(mod.stages) and (mod.STYLE["color"], mod.STYLE["marker"]) == LOOKS[name]


def test_the_figures_looks_are_the_ones_they_were():
    assert figures.STYLE == LOOKS and list(figures.STYLE) == list(LOOKS)
    assert figures.looks(list(LOOKS)) == {s: (*look, "-") for s, look in LOOKS.items()}
    plug_in = figures.looks(["flexmbd", "a-plug-in"])["a-plug-in"]   # any other name: a hashed combination
    assert plug_in in figures.EXTRA


def test_a_style_is_read_without_importing_the_engine():
    code = ("import sys; from flexmbd.report import figures; "
            "assert figures.STYLE['exudyn-ffrf'] == ('#ff7f0e', '^'); "
            "print(sorted(m for m in ('exudyn', 'mujoco', 'pinocchio', 'flexmbd.solvers.inhouse') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=dict(os.environ, PYTHONPATH=str(ROOT.parent)))
    assert out.stdout.strip() == "[]"


def test_cost_names_no_solver():
    """No solver's name in cost.py: not compared, not a key (its stages come from the solver's module)."""
    text = (ROOT / "harness" / "cost.py").read_text()
    names = set(registry.BUILT_IN)
    strings = [n.value for n in ast.walk(ast.parse(text)) if isinstance(n, ast.Constant) and isinstance(n.value, str)]
    assert not [s for s in strings if s in names]
    assert not re.search(r"""[=!]=\s*["'](%s)""" % "|".join(map(re.escape, names)), text)
    imported = {f"{n.module}.{a.name}" for n in ast.walk(ast.parse(text)) if isinstance(n, ast.ImportFrom)
                for a in n.names}
    assert not [m for m in imported if m.startswith("flexmbd.solvers")]


def test_cost_stages_are_the_modules_own_and_the_output():
    case = cases.load("pendulum")
    for name in registry.BUILT_IN:
        if registry.status_for(case, name):
            continue
        own = registry.module(name).stages(case, 0.1, registry.settings(case, name))
        assert cost.stages(case, name, 0.1) == own + [cost.output(case, 0.1)], name


def test_the_executor_adds_the_modules_compile(monkeypatch):
    case = cases.load("pendulum")
    jobs = [(case, "analytic"), (case, "flexmbd")]
    monkeypatch.setattr(jit, "is_cached", lambda: True)
    _, cached = executor._longest_first(jobs, [0, 1])
    monkeypatch.setattr(jit, "is_cached", lambda: False)
    _, cold = executor._longest_first(jobs, [0, 1])
    assert cold[1] == pytest.approx(cached[1] + inhouse.COMPILE_S) and cold[0] == cached[0]


class Stop(Exception):
    pass


def test_the_three_notices_say_the_one_number(monkeypatch, capsys):
    """flexmbd's run, `modes --system` and the report's spectra say how long the compile takes, from
    inhouse.COMPILE_S (measured: docs/performance.md, "cold compile")."""
    case = cases.load("pendulum")
    monkeypatch.setattr(jit, "is_cached", lambda: False)
    said = []

    def stop(*a, **k):
        raise Stop
    monkeypatch.setattr(inhouse.integrate, "warm_up", stop)          # the run stops right after its notice
    with pytest.raises(Stop):
        inhouse.run(case, 0.01, {})
    said.append(capsys.readouterr().err)
    monkeypatch.setattr(linearize, "for_case", lambda *a, **k: [])
    assert cli.system_modes(case, "initial", True) == 0
    said.append(capsys.readouterr().err)
    monkeypatch.setattr(spectra, "spectral_modes", lambda c: None)
    spectra.prepare([case], said.append)
    numbers = [re.findall(r"compiling the solver's kernel .*\(about (\d+) s; cached afterwards\)", s) for s in said]
    assert numbers == [[f"{round(inhouse.COMPILE_S, -1):.0f}"]] * 3, said
    assert 30 <= inhouse.COMPILE_S <= 60                                 # docs/performance.md: about 41 s
