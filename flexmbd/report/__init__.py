"""The report, a pure function of stored results (its pages never run a solver), and the
regression against the baselines (`regress.run`, which runs the solvers unless given stored results)."""
