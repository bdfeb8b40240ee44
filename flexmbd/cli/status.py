"""Exit statuses, one meaning each (README.md, and `EXIT` in the --help of the commands): 0 the
command did its work; 1 a difference: `regress` found a result moved or a solver failed, and with
--strict `run` a failed solver, `report` and `compare` a run that missed its tolerance, diverged
or was aborted, a stored result that could not be used, or nothing compared; 2 bad input or an
unusable file or location (one line on stderr naming it); 3 an internal error (one line on
stderr, the traceback saved to a file; --debug shows it); 130 / 143 ended by SIGINT / SIGTERM.

Why `report` and `compare` exit 0 over a fail unless --strict: their work is to write the pages,
and a fail is shown as a fail there (its colour and icon, the summary line, the --json verdicts).
`make report` is the project's main command on a fresh clone and runs every case on every solver;
some pairs miss their tolerances by design (a rigid peer, a linear model out of its range, see
each case's report.expected_failures), so an exit 1 on any fail would make the Makefile target
fail on every clone while the report it wrote is complete and right. A caller that wants a gate
asks for one (--strict). `regress` exists to be that gate: a moved result is exit 1 without it.
"""

OK, DIFFERENT, BAD_INPUT, INTERNAL = 0, 1, 2, 3

# what each command's exit status 0 and 1 mean (the module docstring; README.md's table)
EXIT = {"run": "Exit status: 0 once the result is stored, also that of a solver that failed (its status printed); "
               "1 with --strict when the solver failed; 2 bad input.",
        "report": "Exit status: 0 once the report is written, a fail shown as a fail on its pages, in the summary "
                  "line and in --json; 1 with --strict when a run missed its tolerance, diverged or was aborted, a "
                  "stored result could not be used, or nothing was compared; 2 bad input.",
        "compare": "Exit status: 0 once the page is written (OUT/compare/CASE/index.html), a fail shown as a fail "
                   "on it, in the summary line and in --json; 1 with --strict when a run missed its tolerance, "
                   "diverged or was aborted, a stored result could not be used, or nothing was compared; 2 bad "
                   "input.",
        "regress": "Exit status: 0 when nothing moved; 1 when a result moved beyond its tolerance or a solver "
                   "failed (with or without --strict); 2 bad input or a bad baseline."}
