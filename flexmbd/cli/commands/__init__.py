"""The commands, one `cmd_NAME(args) -> exit status` each, grouped by what they work on: `runs`
(run, report, compare, regress), `catalogue` (list, modes, completion), `studies` (study,
import), `frames` (animate, export) and `records` (bench, history)."""
