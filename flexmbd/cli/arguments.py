"""The argument parser of the `flexmbd` command: the options several commands share, each declared
once (`shared`, added by `option` and `options`; the groups --debug, where the runs go and the
frames' instants as parent parsers), each command's own arguments in one short function, and the
table of the commands (`COMMANDS`) that `parser` builds the tree from."""

from __future__ import annotations

import argparse
import math
from typing import Callable, NamedTuple

from flexmbd.core import resources
from flexmbd.harness import registry
from flexmbd.cli.status import EXIT
from flexmbd.cli.stdout import stdout_checked
from flexmbd.core.errors import InputError
from flexmbd.version import __version__

DESCRIPTION = ("Flexible multibody validation harness: cases, solvers, reports. Exit status: 0 the command did its "
               "work (a page shows a fail as a fail), 1 a difference: regress found one, or, with --strict, run, "
               "report or compare did (each command's --help says which), 2 bad input or an unusable file, 3 an "
               "internal error, 130 / 143 interrupted.")
CASE = "a case name from cases/ (see flexmbd list) or the path of a case TOML file"
OVERRIDE = "override a case value, e.g. materials.steel.E=2.1e11 (repeatable)"
STRICT = ("exit 1 when a run misses its tolerance, diverges or is aborted, a stored result cannot be used, or "
          "nothing is compared with a tolerance (without it: exit 0 once the pages are written)")
SIDECAR = "print the result's JSON sidecar on stdout"
VERDICTS = "print one JSON object on stdout (verdicts and accuracy rows)"


class Help(argparse.HelpFormatter):
    """Help that shows an option's default when it has a value worth showing."""

    def _get_help_string(self, action):
        text = action.help or ""
        if ("%(default)" not in text and action.option_strings and action.default not in (None, False)
                and action.default is not argparse.SUPPRESS):
            text += " (default: %(default)s)"
        return text


class Parser(argparse.ArgumentParser):
    """argparse with its errors as one line naming the option (exit 2), not a usage block."""

    def __init__(self, *a, **k):
        k.setdefault("formatter_class", Help)
        super().__init__(*a, **k)

    def error(self, message):
        where = self.prog.partition(" ")[2] or "command line"
        raise InputError(f"{where}: {' '.join(message.split())} (see {self.prog} --help)")


def _positive(text: str) -> float:
    """A finite positive number (an option's value): inf, like nan, is refused, since no run can
    last forever."""
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (x > 0 and math.isfinite(x)):
        raise argparse.ArgumentTypeError(f"must be a finite positive number, got {text}")
    return x


def _count(text: str) -> int:
    """A whole number of at least 1 (an option's value)."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {n}")
    return n


# ---------------------------------------------------------------------------------------------
# what several commands share


def solver_names() -> str:
    return ", ".join(registry.NAMES)


def shared() -> dict:
    """The options several commands take, each declared once: its flag -> the keywords of
    `add_argument` (a command narrows one, its help most often, with `option`)."""
    return {
        "--json": dict(action="store_true", help="print one JSON object on stdout"),
        "--allow-large": dict(action="store_true", help="run even beyond the cost limits (README.md, Cost limits)"),
        "--strict": dict(action="store_true", help=STRICT),
        "--set": dict(action="append", metavar="KEY=VALUE", help=OVERRIDE),
        "--t-end": dict(type=_positive, default=None, metavar="SECONDS",
                        help="simulate this long instead of the case's duration"),
        "--out": dict(default="reports"),
        "--rerun": dict(action="store_true", help="run every solver again, also where a stored result has the same "
                        "case content, settings, versions and source (kept otherwise)"),
        "--solver": dict(required=True, help=f"one of: {solver_names()}"),
        "--solvers": dict(default=None, help=f"comma-separated solver names (default: all: {solver_names()})"),
    }


def option(p: argparse.ArgumentParser, flag: str, **changes) -> None:
    """The shared option `flag` (`shared`) added to `p`, with `changes` to its keywords."""
    p.add_argument(flag, **{**shared()[flag], **changes})


def options(p: argparse.ArgumentParser, *flags: str) -> None:
    """The shared options `flags` added to `p` as declared, in that order."""
    for flag in flags:
        option(p, flag)


def case(p: argparse.ArgumentParser) -> None:
    p.add_argument("case", help=CASE)


def debug_option() -> Parser:
    """--debug, which the command and every command take."""
    debug = Parser(add_help=False)
    debug.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help="show the traceback of an internal error on the terminal")
    return debug


def executor_options() -> Parser:
    """Where the runs go (executor.Where; docs/studies.md): one of --workers, --scheduler, --dask-local."""
    executors = Parser(add_help=False)
    on = executors.add_argument_group("where the runs go").add_mutually_exclusive_group()
    on.add_argument("--workers", type=_count, default=None, metavar="N",
                    help="local worker processes (default: one per core; 1: one run after another in this process)")
    on.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                    help="run on the Dask distributed cluster of this scheduler (docs/studies.md)")
    on.add_argument("--dask-local", type=_count, default=None, metavar="N",
                    help="run on a Dask LocalCluster of N worker processes started for the command")
    return executors


def frame_options() -> Parser:
    """The instants of animate and export, and the case they are of."""
    frames = Parser(add_help=False)
    frames.add_argument("--frames", type=_count, default=None, metavar="N",
                        help="instants evenly spread over the run, each at its nearest output sample (default: 100, "
                        "or every output sample of a shorter run; at most the run's output samples)")
    options(frames, "--t-end", "--set", "--allow-large")
    return frames


# ---------------------------------------------------------------------------------------------
# each command's own arguments, in the order its --help lists them


def list_arguments(s: Parser) -> None:
    s.add_argument("cases", nargs="*", metavar="CASE", help=CASE + " (default: every case in cases/)")
    option(s, "--json", help="print one JSON array on stdout")
    s.add_argument("--solvers", action="store_true", help="instead, which solver models what: rigid bodies, beams, "
                   "tip masses, ... (from each solver's own applies on probe cases; docs/solvers.md)")


def modes_arguments(s: Parser) -> None:
    case(s)
    option(s, "--set")
    s.add_argument("--save", metavar="DIR", help="also write each reduced body as DIR/CASE_BODY.npz")
    s.add_argument("--system", action="store_true",
                   help="the assembled system's frequencies (joint and modal coordinates, linearized)")
    s.add_argument("--about", choices=["initial", "equilibrium"], default="initial",
                   help="with --system: linearize about the initial state or the static equilibrium")
    s.add_argument("--sweep", metavar="KEY=START:STOP:N",
                   help="with --system: linearize at N evenly spaced values of a case key, the modes tracked by "
                        "their shapes (a frequency map); with --out, written as OUT/CASE_sweep.csv and .png")
    s.add_argument("--peers", metavar="SOLVER[,SOLVER]", default="",
                   help="with --system: also each solver's own eigen-solve of the same assembly (exudyn-beam, "
                        "exudyn-ffrf, fe-linear), its lowest frequencies beside flexmbd's")
    option(s, "--out", default=None, metavar="DIR", help="with --sweep: the folder of the map's table and figure")
    options(s, "--json", "--allow-large")


def run_arguments(s: Parser) -> None:
    case(s)
    option(s, "--solver")
    option(s, "--out", help="the report folder: the result goes to OUT/results/CASE/SOLVER.{csv,json}")
    options(s, "--t-end", "--set")
    option(s, "--json", help=SIDECAR)
    option(s, "--allow-large")
    option(s, "--strict", help="exit 1 when the solver fails (without it: exit 0 once the result is stored, its "
           "status printed)")


def import_arguments(s: Parser) -> None:
    case(s)
    s.add_argument("file", metavar="FILE.csv", help="a table of t [s] and any of the case's channels (SI units)")
    option(s, "--solver", metavar="NAME", help="the name the result goes by on the pages (not one of flexmbd's solvers)")
    s.add_argument("--meta", metavar="FILE.json", default=None,
                   help="solver_version, settings, status, wall_s, machine, date, description, ... (docs/plugins.md)")
    option(s, "--out", help="the report folder: the result goes to OUT/results/CASE/NAME.{csv,json}")
    option(s, "--set", help=OVERRIDE + "; the case version the result was computed for")
    option(s, "--json", help=SIDECAR)


def report_arguments(s: Parser) -> None:
    s.add_argument("--cases", default=None, help="comma-separated case names or paths (default: all)")
    option(s, "--solvers")
    option(s, "--out", help="the report folder (results in OUT/results)")
    s.add_argument("--no-run", action="store_true", help="rebuild the pages from the stored results only")
    options(s, "--rerun", "--allow-large")
    option(s, "--json", help=VERDICTS)
    option(s, "--strict")


def compare_arguments(s: Parser) -> None:
    case(s)
    option(s, "--solvers")
    option(s, "--out", help="the report folder (results in OUT/results, the page in OUT/compare/CASE; the report's "
           "own page OUT/CASE is left as it is)")
    option(s, "--t-end", help="simulate this long instead of the case's duration (as --set duration=SECONDS: the page "
           "and the stored results are of the case run that long)")
    options(s, "--set", "--rerun", "--allow-large")
    option(s, "--json", help=VERDICTS)
    option(s, "--strict")


def animate_arguments(s: Parser) -> None:
    case(s)
    option(s, "--solvers", required=True, metavar="A,B,...", help=f"comma-separated solver names: {solver_names()}")
    option(s, "--out", default=None, metavar="FILE.gif|FILE.mp4",
           help="the animation (default: reports/animations/CASE.gif, which the case page links)")
    s.add_argument("--fps", type=_count, default=20, help="frames per second")


def export_arguments(s: Parser) -> None:
    case(s)
    option(s, "--solver")
    s.add_argument("--vtk", required=True, metavar="DIR", help="the folder of the .vtu files and the .pvd")


def study_arguments(s: Parser) -> None:
    s.add_argument("cases", nargs="*", metavar="CASE", help=CASE)
    s.add_argument("--vary", action="append", metavar="KEY=V1,V2,...",
                   help="a case key and its values, coarse to fine (repeatable: the grid is their product)")
    option(s, "--solvers", help="comma-separated solver names (default: each case's report solvers; the case's "
           "reference runs too)")
    s.add_argument("--reference-at", default=None, choices=["each", "base"],
                   help="where each case's reference solver runs: at every point (each, the default) or once on the "
                   "case without the overrides (base: when the varied keys are a discretisation it does not read)")
    s.add_argument("--file", default=None, metavar="STUDY.toml", help="the study as a [study] table (cases, vary, "
                   "solvers, reference) instead of the arguments")
    option(s, "--out", default="reports/study", help="the study folder (its runs in OUT/points)")
    option(s, "--rerun", help="run every point again, also where a stored result has the key of its run (kept "
           "otherwise)")
    option(s, "--allow-large")


def completion_arguments(s: Parser) -> None:
    s.add_argument("shell", choices=["bash"], help="the shell")


def bench_arguments(s: Parser) -> None:
    option(s, "--json")
    s.add_argument("--quick", action="store_true", help="fewer sizes and settings (a smoke run)")
    s.add_argument("--no-work-precision", action="store_true", help="skip the (long) work-precision sweeps")
    option(s, "--out", default="reports/bench", help="folder of the plots and their page")
    s.add_argument("--results", metavar="DIR", help="a report folder (make report's reports/) whose stored "
                   "reference runs, where they belong to the current cases, are used instead of running them")


def history_arguments(s: Parser) -> None:
    option(s, "--out", help="the report folder (records in OUT/history/MACHINE/COMMIT.json; the page "
           "OUT/history.html)")
    s.add_argument("--add", action="append", metavar="DIR", help="first bring in the records of another report "
                   "folder or its history folder, e.g. another machine's (repeatable)")


def regress_arguments(s: Parser) -> None:
    s.add_argument("--baseline", default=str(resources.BASELINES),
                   help="folder of baselines BASELINE/CASE/SOLVER.csv (default: the shipped references/baselines)")
    s.add_argument("--results", default=None, metavar="DIR",
                   help="compare the results stored in the report folder DIR (DIR/results/CASE/SOLVER.json) instead "
                        "of running the solvers; needed for imported results")
    s.add_argument("--cases", default=None, help="comma-separated case names (default: every baseline's)")
    option(s, "--solvers", help="comma-separated solver names (default: every baseline's)")
    s.add_argument("--update", action="store_true", help="rewrite the baselines from fresh results")
    option(s, "--allow-large")
    option(s, "--json", help="print one JSON object on stdout (the compared channels)")
    option(s, "--strict", help="accepted for symmetry: a failed solver is always a difference")


# ---------------------------------------------------------------------------------------------
# the commands and the tree


class Command(NamedTuple):
    name: str
    help: str
    arguments: Callable[[Parser], None]
    groups: tuple = ()                      # the shared groups it takes beside --debug: "executors", "frames"
    description: str | None = None


COMMANDS = (
    Command("list", "the cases, with title, bodies and solvers", list_arguments),
    Command("modes", "retained mode frequencies (Hz) and labels per flexible body, or the system's (--system)",
            modes_arguments),
    Command("run", "one solver on one case", run_arguments, description=EXIT["run"]),
    Command("import", "bring in a result computed elsewhere, checked against the case's channels (docs/plugins.md)",
            import_arguments),
    Command("report", "every case on every available solver, and the report", report_arguments, ("executors",),
            EXIT["report"]),
    Command("compare", "run solvers on one case and write its page of their comparison (OUT/compare/CASE/)",
            compare_arguments, ("executors",), EXIT["compare"]),
    Command("animate", "an animation (GIF, or MP4 with ffmpeg) of several solvers' deformed shapes overlaid "
            "(docs/animation.md)", animate_arguments, ("frames",)),
    Command("export", "one solver's deformed shapes as a ParaView time series (.vtu files and a .pvd; "
            "docs/animation.md)", export_arguments, ("frames",)),
    Command("study", "a grid of overrides on cases and solvers: its table (Parquet) and figures (docs/studies.md)",
            study_arguments, ("executors",)),
    Command("completion", "print the shell completion script (bash; zsh through bashcompinit)", completion_arguments,
            description='bash: eval "$(flexmbd completion bash)" in ~/.bashrc; zsh: autoload -U +X bashcompinit && '
            'bashcompinit && eval "$(flexmbd completion bash)"'),
    Command("bench", "timing and work-precision against peers on this machine", bench_arguments),
    Command("history", "the page of each solver's accuracy and time on each case across commits, and of the bench "
            "runs (docs/history.md)", history_arguments),
    Command("regress", "compare fresh results with stored baselines (exit 1 if anything moved)", regress_arguments,
            ("executors",), EXIT["regress"]),
)


def command(name: str):
    """The function that runs the command `name`: `flexmbd.cli`'s cmd_NAME when the parser is
    built, so that one replaced there (a planted fault, in the tests) is the one that runs."""
    import flexmbd.cli
    return getattr(flexmbd.cli, f"cmd_{name}")


def parser() -> argparse.ArgumentParser:
    """The `flexmbd` command: --debug and --version, then each command of `COMMANDS` with --debug,
    its shared groups and its own arguments, its output checked (`stdout_checked`)."""
    debug = debug_option()
    p = Parser(prog="flexmbd", description=DESCRIPTION, parents=[debug])
    p.add_argument("--version", action="version", version=f"flexmbd {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser, metavar="COMMAND")
    groups = {"executors": executor_options(), "frames": frame_options()}
    for c in COMMANDS:
        s = sub.add_parser(c.name, help=c.help, parents=[debug, *(groups[g] for g in c.groups)],
                           description=c.description)
        c.arguments(s)
        s.set_defaults(func=stdout_checked(command(c.name)))
    return p
