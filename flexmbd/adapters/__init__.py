"""Solvers other than the in-house one, each behind the interface described in `flexmbd.solvers`.

Conventions of external codes are converted only inside these modules.
"""
