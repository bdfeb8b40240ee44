"""The solvers, each behind the interface of `flexmbd.harness.registry` (its docstring): the
in-house one (`inhouse`: a case as an `flexmbd.mbd` Model via `build`, integrated, its states as a
`channels.Trajectory`; `linearize` for a case's system modes) and the peers (`exudyn_ffrf`,
`exudyn_beam`, `mujoco_rod`, `mujoco_rigid`, `pinocchio_rigid`, `fe_linear`, `analytic`), with
what several peers share (`common`, `exudyn_common`, `mujoco_common`, `pinocchio_model`).

Conventions of external codes are converted only inside these modules. Each solver declares its
own knowledge (cost model, compile cost, line style). The package imports the harness below it;
the registry loads these modules by name, as it loads plug-ins.
"""
