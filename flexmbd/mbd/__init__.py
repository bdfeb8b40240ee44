"""The in-house solver: the recursive dynamics of modally reduced flexible bodies in joint
coordinates (docs/formulation.md), readable and usable without the harness around it.

    spatial      6-D spatial algebra and rotations
    joints       the one joint switch: codes, coordinate counts, transforms, motion subspaces
    profiles     prescribed joint motions and load factors in time
    invariants   the inertia shape invariants of a reduced body (its arrays, by name)
    model        the Model arrays (constants) and the Data workspace
    dynamics     the recursive algorithms: kinematics, articulated-body inertias, accelerations
    constraints  closed loops on the tree: cut joints' rows, assembly, projection
    integrate/   the time integrators, one module a method (a run's end as `Ended`, progress told to
                 what it is handed)
    linearize    the equations linearized about a state: the system's modes, damping ratios, labels
    compiled/    the one place numba appears: compiling (`jit`), small dense loops (`dense`), the
                 Model and a Data as one compiled object (`bound`) and the one compiled entry (`entry`)
    tree         a Model from plain descriptions of bodies and joints (examples/two_link_chain.py)
    cache        the user's cache folder, where the compiled code is kept

It imports nothing else of flexmbd (tests/test_layers.py); the harness says a case in its terms
(`flexmbd.solvers.build`: bodies and joints for `tree.model`) and reads what the solver returns.
"""
