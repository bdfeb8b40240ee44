"""The report, a pure function of stored results (its pages never run a solver), and the
regression against the baselines (`regress.run`, which runs the solvers unless given stored results).

It imports the packages below it (the harness's stored results, the cases, the in-house solver's
linearization for the spectra); never the command line.
"""
