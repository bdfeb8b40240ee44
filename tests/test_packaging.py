"""The package as a user installs it: a wheel built from the checkout, installed into a fresh
virtual environment outside the checkout, runs `flexmbd list`, `run` and `report` from a folder
outside it, finding the shipped cases and baselines in the installed package."""

import os
import shutil
import subprocess
import sys
import sysconfig
import venv
import zipfile
from pathlib import Path

import numpy
import pytest

pytestmark = pytest.mark.heavy(12)       # seconds, measured with both cores busy (tests/conftest.py)

ROOT = Path(__file__).resolve().parent.parent
SOURCES = ("flexmbd", "cases", "references", "pyproject.toml", "README.md")     # what the wheel is built from
FAST = "analytic,fe-linear"             # the cantilever's reference and a closed form: no compilation


def pip(*args) -> None:
    subprocess.run([sys.executable, "-m", "pip", "--quiet", *args], check=True, capture_output=True, text=True)


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> dict:
    """A wheel built from a copy of the checkout's sources (nothing written into the checkout) and
    installed into a fresh virtual environment without its dependencies, which it takes from this
    environment (a .pth file adding this environment's site-packages after its own, so that its
    own flexmbd is the one imported). Its wheel, folder, an empty working folder outside the
    checkout and the environment to run its commands in."""
    tmp = tmp_path_factory.mktemp("packaging")
    src = tmp / "src"
    src.mkdir()
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name, symlinks=True, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy(ROOT / name, src / name)
    pip("wheel", "--no-deps", "--no-build-isolation", "--no-index", "--wheel-dir", str(tmp / "dist"), str(src))
    [wheel] = (tmp / "dist").glob("flexmbd-*.whl")
    env_dir = tmp / "venv"
    venv.create(env_dir, with_pip=False)
    purelib = sysconfig.get_path("purelib", vars={"base": str(env_dir), "platbase": str(env_dir)})
    deps = Path(numpy.__file__).resolve().parent.parent                      # this environment's site-packages
    Path(purelib, "zz_dependencies.pth").write_text(f"import site; site.addsitedir({str(deps)!r})\n")
    pip("--python", str(env_dir / "bin" / "python"), "install", "--no-deps", "--no-index", str(wheel))
    work = tmp / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    # the compiled kernels are not what is tested here: compiled afresh for the new location (numba's
    # cache is per source file) they would take about 90 s of CPU; without the JIT the same code
    # runs as Python (jit.PURE_PYTHON), which the cantilever's system modes take in seconds
    env["NUMBA_DISABLE_JIT"] = "1"
    env["PATH"] = os.pathsep.join([str(env_dir / "bin"), env.get("PATH", "")])
    return {"wheel": wheel, "venv": env_dir, "work": work, "env": env}


def run(installed, *args):
    """A command in the installed environment, in its working folder outside the checkout."""
    return subprocess.run(list(args), cwd=installed["work"], env=installed["env"], capture_output=True, text=True)


def test_the_wheel_holds_the_cases_and_baselines(installed):
    names = set(zipfile.ZipFile(installed["wheel"]).namelist())
    cases = {p.relative_to(ROOT / "cases").as_posix() for p in (ROOT / "cases").rglob("*")
             if p.is_file() and p.suffix != ".py" and "__pycache__" not in p.parts}
    baselines = {p.relative_to(ROOT / "references").as_posix() for p in (ROOT / "references" / "baselines").rglob("*.csv")}
    assert cases and baselines
    assert {f"flexmbd/data/cases/{c}" for c in cases} <= names
    assert {f"flexmbd/data/references/{b}" for b in baselines} <= names
    assert not [n for n in names if n.startswith("flexmbd/data/") and n.endswith(".py")]      # data, no modules


def test_the_installed_package_is_imported_and_finds_its_cases(installed):
    code = "import flexmbd, flexmbd.core.resources as r; print(flexmbd.__file__); print(r.CASES); print(r.CHECKOUT)"
    got = run(installed, str(installed["venv"] / "bin" / "python"), "-c", code)
    assert got.returncode == 0, got.stderr
    module, cases, checkout = got.stdout.splitlines()
    venv_dir = installed["venv"].resolve()
    assert Path(module).resolve().is_relative_to(venv_dir) and Path(cases).is_relative_to(venv_dir)
    assert checkout == "None"                                                 # no git asked, no benchmark history


def test_list_run_and_report_run_outside_the_checkout(installed):
    listed = run(installed, "flexmbd", "list")
    assert listed.returncode == 0, listed.stderr
    assert "cantilever_step" in listed.stdout and "pendulum" in listed.stdout
    ran = run(installed, "flexmbd", "run", "cantilever_step", "--solver", "analytic", "--out", "out")
    assert ran.returncode == 0 and "ok" in ran.stdout, ran.stderr
    stored = installed["work"] / "out" / "results" / "cantilever_step"
    assert (stored / "analytic.csv").is_file() and (stored / "analytic.json").is_file()
    rep = run(installed, "flexmbd", "report", "--cases", "cantilever_step", "--solvers", FAST, "--out", "rep")
    assert rep.returncode == 0, rep.stderr
    page = (installed["work"] / "rep" / "cantilever_step" / "index.html").read_text()
    assert "fe-linear" in page and "analytic" in page
    # the regression against the shipped baselines, found in the installed package
    reg = run(installed, "flexmbd", "regress", "--cases", "cantilever_step", "--solvers", FAST, "--results", "rep")
    assert reg.returncode == 0, reg.stdout + reg.stderr


def test_an_installed_package_s_result_records_its_version_and_source_hash(installed):
    """Outside a checkout there is no git commit: the sidecar records flexmbd's version and the
    SHA-256 of the installed package's source files, by path and content, as a checkout's does."""
    import hashlib
    import json
    import flexmbd
    ran = run(installed, "flexmbd", "run", "cantilever_step", "--solver", "analytic", "--out", "provenance")
    assert ran.returncode == 0, ran.stderr
    meta = json.loads((installed["work"] / "provenance" / "results" / "cantilever_step" / "analytic.json").read_text())
    package = Path(sysconfig.get_path("purelib", vars={"base": str(installed["venv"]),
                                                       "platbase": str(installed["venv"])})) / "flexmbd"
    h = hashlib.sha256()
    for p in sorted(package.rglob("*.py")):
        h.update(p.relative_to(package).as_posix().encode() + b"\0" + p.read_bytes() + b"\0")
    assert meta["git_commit"] == "" and meta["flexmbd_version"] == flexmbd.__version__
    assert meta["source_sha256"] == h.hexdigest()
