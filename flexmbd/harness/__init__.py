"""What runs solvers and what a run is, knowing no solver by its code: the registry (`registry`:
built-in solvers and plug-ins found by module name, `run` the one place a solver's return or
exception becomes a `results.Result`), the contract a solver meets (`channels.Trajectory` in,
channels out; `results.Status`), the comparisons (`metrics`), fatigue damage from a stress
history (`durability`: rainflow cycles, S-N curves, Miner damage), the cost of a run asked of its
solver (`cost`), running many runs on a pool or a cluster (`executor`, `progress`), what each
solver models (`capabilities`) and runs of other codes read from files (`external`).

It imports the core, the FE package, the cases and the solver package (`flexmbd.mbd`, for the
compiled code's cache key); the solvers sit above it and are loaded by name.
"""
