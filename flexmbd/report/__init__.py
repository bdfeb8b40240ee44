"""Report generation: a pure function of stored results (it never runs a solver)."""
