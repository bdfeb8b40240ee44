"""The suite's slow parts done once: flexmbd's kernel compiled by one process while the other
xdist worker runs tests that never need it, and what several test files read (a report of the
cantilever) made once per session and shared by the workers through a file lock. The test files
start heaviest first, so that no long file starts last (`make test`: one file per core at a time).
"""

import contextlib
import fcntl
import io
import os
import pickle
from pathlib import Path

import pytest

# Scheduling comes from each file's marker: `heavy(SECONDS)` on the files that take longest (their
# time measured with both cores busy), `kernel_free` on the files none of whose tests compiles or
# loads flexmbd's kernel, in this process or any it starts. The longest heavy file starts first and
# compiles the kernel on one worker while the other runs the kernel-free files; it has more than 2
# tests, so that pytest-xdist gives that worker no second file before it ends. A kernel-free file
# that did need the kernel would compile it a second time alongside, which costs time and changes
# no result.


def pytest_configure(config):
    """pytest-xdist hands out files in the order of `pytest_collection_modifyitems`, not by their
    number of tests (its default)."""
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def seconds(item) -> float:
    """A test's file's measured time when the file is marked heavy, else 0."""
    mark = item.get_closest_marker("heavy")
    return float(mark.args[0]) if mark else 0.0


def kernel_free(node) -> bool:
    return node.get_closest_marker("kernel_free") is not None


def pytest_collection_modifyitems(session, config, items):
    """The longest heavy file (it compiles the kernel), the kernel-free files (another worker runs
    them meanwhile), the other heavy files longest first, then every other file; a file's tests in
    their order."""
    files = {}                                  # file -> (its heavy seconds, kernel-free, its place)
    for item in items:
        files.setdefault(item.path, (seconds(item), kernel_free(item), len(files)))
    heavy = sorted((f for f, (s, _, _) in files.items() if s), key=lambda f: (-files[f][0], files[f][2]))
    free = [f for f, (s, free, _) in files.items() if free and not s]
    rank = {f: k for k, f in enumerate(heavy[:1] + free + heavy[1:])}
    items.sort(key=lambda item: (rank.get(item.path, len(rank)), files[item.path][2]))


@contextlib.contextmanager
def locked(path: Path):
    """An exclusive lock on `path` (created), held by one process of the session at a time."""
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


@pytest.fixture(scope="session")
def shared_dir(tmp_path_factory) -> Path:
    """A folder of this session's temporary base shared by its xdist workers (each has a base of
    its own below it)."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if base.name == f"popen-{os.environ.get('PYTEST_XDIST_WORKER')}" else base


def once(shared: Path, name: str, build) -> Path:
    """shared/name, made by build(folder) by the first process of the session to ask for it while
    the others wait; read-only to the tests (copy it to change it)."""
    folder, done = shared / name, shared / f"{name}.done"
    with locked(shared / f"{name}.lock"):
        if not done.exists():
            build(folder)
            done.touch()
    return folder


@pytest.fixture(scope="session")
def compiled_kernel(shared_dir) -> None:
    """flexmbd's kernel, its compiled integrators and the compiled functions of a run (its energies,
    a loop's constraints), compiled (or loaded from numba's cache) by one process at a time: the
    first compiles them (about 40 s of one core), the others load them from the cache. A
    session fixture that needs them asks for this one (pytest sets up session fixtures before
    module ones)."""
    from flexmbd import cases
    from flexmbd.fe import flexbody
    from flexmbd.harness import registry
    from flexmbd.mbd import integrate
    from flexmbd.mbd.compiled import jit
    from flexmbd.solvers.build import from_case
    if jit.PURE_PYTHON:                                 # NUMBA_DISABLE_JIT=1: nothing to compile
        return
    with locked(shared_dir / "kernel.lock"):
        case = cases.load("pendulum")
        integrate.warm_up(from_case(case.modelled, flexbody.for_case(case.modelled)))
        for case in (case, cases.load("four_bar_swing")):
            assert registry.run(case, "flexmbd", 0.01).ok


@pytest.fixture(scope="module", autouse=True)
def _kernel_first(request):
    """The kernel compiled before a module's first fixture or test (`compiled_kernel`), unless
    the module is marked kernel_free."""
    if not kernel_free(request.node):
        request.getfixturevalue("compiled_kernel")


# cantilever_step by analytic, its reference fe-linear and pinocchio, which does not apply to it
CANTILEVER_REPORT = ["report", "--cases", "cantilever_step", "--solvers", "analytic,fe-linear,pinocchio", "--strict"]


@pytest.fixture(scope="session")
def cantilever_argv() -> list:
    """The command of `cantilever_report` (without its --out): run again on a copy of the report,
    it keeps every run and page."""
    return list(CANTILEVER_REPORT)


@pytest.fixture(scope="session")
def cantilever_report(shared_dir, compiled_kernel) -> Path:
    """The report folder of `flexmbd CANTILEVER_REPORT --out FOLDER` (every run passes: exit 0,
    checked), made once per session; what the command said on stderr is FOLDER.stderr beside it."""
    def build(out: Path) -> None:
        from flexmbd.cli import main
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main([*CANTILEVER_REPORT, "--out", str(out)])
        Path(f"{out}.stderr").write_text(err.getvalue())
        assert code == 0, err.getvalue()
    return once(shared_dir, "cantilever_report", build)


@pytest.fixture(scope="session")
def cantilever_run(shared_dir):
    """cantilever_run(solver): a fresh copy of the Result of `registry.run` of `solver` on the shipped
    cantilever_step (its whole duration), run once per session. flexmbd's run needs the kernel
    (compiled before any module not marked kernel_free)."""
    from flexmbd import cases
    from flexmbd.harness import registry

    def build(folder: Path, solver: str) -> None:
        folder.mkdir()
        (folder / "result.pickle").write_bytes(pickle.dumps(registry.run(cases.load("cantilever_step"), solver)))

    def get(solver: str):
        folder = once(shared_dir, f"cantilever_step.{solver}", lambda f: build(f, solver))
        return pickle.loads((folder / "result.pickle").read_bytes())
    return get
