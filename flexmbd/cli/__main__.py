"""`python -m flexmbd.cli`: the command, run as `flexmbd` runs it once its modules are loaded."""

from flexmbd.cli import exit_with, main

if __name__ == "__main__":
    exit_with(main())
