"""Shell completion for the `flexmbd` command, generated from its argument parser.

    eval "$(flexmbd completion bash)"          # in ~/.bashrc
    autoload -U +X bashcompinit && bashcompinit && eval "$(flexmbd completion bash)"   # zsh

Completes the commands, each command's options, the case names (and *.toml files) where a case
goes, the solver names after --solver and in the comma lists of --solvers (--cases likewise),
an option's choices, and file names after the options that take a path.
"""

from __future__ import annotations

import argparse
import shlex

PATHS = {"--out", "--baseline", "--results", "--save", "--meta", "--vtk"}     # options whose value is a path
FREE = {"--set", "--t-end", "--frames", "--fps"}                                            # values nothing can suggest


def options(p: argparse.ArgumentParser) -> dict:
    """Command -> (its options, {option or positional: choices}, positional metavars (lower case,
    '...' after a repeatable one: 'case...'), options taking a value) of the parser `p`."""
    sub = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction))
    out = {}
    for name, sp in sub.choices.items():
        opts, choices, positional, valued = [], {}, [], []
        for a in sp._actions:
            if a.option_strings:
                opts += a.option_strings
                if a.nargs != 0:
                    valued += a.option_strings
                if a.choices:
                    choices[a.option_strings[-1]] = list(a.choices)
            else:
                more = "..." if a.nargs in ("*", "+") else ""     # "case...": one or more cases
                positional.append((a.metavar or a.dest).lower() + more)
                if a.choices:
                    choices[a.dest] = list(a.choices)
        out[name] = (opts, choices, positional, valued)
    return out


def bash(p: argparse.ArgumentParser, case_names, solver_names) -> str:
    """The bash completion script of the parser `p` (works in zsh through bashcompinit)."""
    q = lambda words: shlex.quote(" ".join(words))
    cmds = options(p)
    per_command = "".join(
        f"        {name}) opts={q(opts)}; kinds={q(pos)}; valued={q(val)}; words={q(cs.get(pos[0], []) if pos else [])};;\n"
        for name, (opts, cs, pos, val) in cmds.items())
    choices = "".join(f"        {opt}) COMPREPLY=($(compgen -W {q(ch)} -- \"$cur\")); return;;\n"
                      for opt, ch in sorted({o: c for _, (_, cs, _, _) in cmds.items()
                                             for o, c in cs.items() if o.startswith("-")}.items()))
    return f"""# flexmbd completion (bash; zsh: autoload -U +X bashcompinit && bashcompinit first)
_flexmbd_list() {{   # complete the last item of a comma-separated list from the words $1
    local prefix=""
    [[ "$cur" == *,* ]] && prefix="${{cur%,*}},"
    COMPREPLY=($(compgen -P "$prefix" -W "$1" -- "${{cur##*,}}"))
    compopt -o nospace 2>/dev/null
}}
_flexmbd() {{
    local cur="${{COMP_WORDS[COMP_CWORD]}}" prev="${{COMP_WORDS[COMP_CWORD-1]}}"
    local cases={q(case_names)} solvers={q(solver_names)}
    if [[ $COMP_CWORD -eq 1 ]]; then
        COMPREPLY=($(compgen -W {q(list(cmds) + ['--version', '--help', '--debug'])} -- "$cur")); return
    fi
    case "$prev" in
        --solver) COMPREPLY=($(compgen -W "$solvers" -- "$cur")); return;;
        --solvers) _flexmbd_list "$solvers"; return;;
        --cases) _flexmbd_list "$cases"; return;;
{choices}        {'|'.join(sorted(PATHS))}) COMPREPLY=($(compgen -f -- "$cur")); return;;
        {'|'.join(sorted(FREE))}) return;;
    esac
    local opts="" kinds="" valued="" words=""
    case "${{COMP_WORDS[1]}}" in
{per_command}    esac
    if [[ "$cur" == -* ]]; then
        COMPREPLY=($(compgen -W "$opts" -- "$cur"))
    elif [[ -n "$words" ]]; then
        COMPREPLY=($(compgen -W "$words" -- "$cur"))
    elif [[ "$kinds" == case* ]]; then
        local n=0 i
        for ((i = 2; i < COMP_CWORD; i++)); do
            [[ "${{COMP_WORDS[i]}}" != -* && " $valued " != *" ${{COMP_WORDS[i-1]}} "* ]] && n=$((n + 1))
        done
        if [[ $n -eq 0 || "$kinds" == "case..." ]]; then
            COMPREPLY=($(compgen -W "$cases" -- "$cur") $(compgen -f -X '!*.toml' -- "$cur"))
        else
            COMPREPLY=($(compgen -f -- "$cur"))
        fi
    fi
}}
complete -o filenames -F _flexmbd flexmbd
"""
