"""Time and peak memory of reducing a solid mesh: the paper's cantilever (1.5 x 0.015 x 0.01 m,
steel) as hex20 meshes of about 5,000 to 64,000 DOFs, assembled (`fe.solid.stiffness`,
`scalar_mass`) and reduced to 12 clamped-interface modes (`fe.solid.clamped_modes`: sparse
shift-invert Lanczos; nothing dense of the mesh size), each in a fresh process so that its peak
resident memory is its own. Run from the repository root:

    .venv/bin/python benchmarks/solid_reduction.py [nx x ny x nz ...]

(default: 60x2x2 150x4x2 300x4x3). Prints one row per mesh: DOFs, assembly and eigen time (s),
peak resident memory (MB), and the first two bending frequencies against Euler-Bernoulli.
"""

import json
import resource
import subprocess
import sys
import time

import numpy as np

L, H, B, E, NU, RHO = 1.5, 0.015, 0.01, 2.06e11, 0.29, 7820.0


def one(n: tuple) -> dict:
    from flexmbd.fe import mesh, solid
    t0 = time.perf_counter()
    m = mesh.box(L, H, B, n, "hex20")
    K, Ms = solid.stiffness(m, E, NU), solid.scalar_mass(m, RHO)
    t1 = time.perf_counter()
    f, _ = solid.clamped_modes(K, Ms, m.node_sets["x0"], 12, m.nodes)
    t2 = time.perf_counter()
    eb = lambda I: 1.875104068711961 ** 2 / (2 * np.pi * L ** 2) * np.sqrt(E * I / (RHO * B * H))
    return {"mesh": "x".join(map(str, n)), "dofs": K.shape[0], "assembly_s": t1 - t0, "modes_s": t2 - t1,
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "f1_vs_eb": f[0] / eb(H * B ** 3 / 12) - 1, "f2_vs_eb": f[1] / eb(B * H ** 3 / 12) - 1}


if __name__ == "__main__":
    if sys.argv[1:2] == ["--one"]:
        print(json.dumps(one(tuple(int(a) for a in sys.argv[2].split("x")))))
        sys.exit(0)
    print(f"{'mesh':>10} {'DOFs':>7} {'assembly s':>11} {'modes s':>8} {'peak MB':>8} {'f1/EB-1':>9} {'f2/EB-1':>9}")
    for arg in sys.argv[1:] or ["60x2x2", "150x4x2", "300x4x3"]:
        out = subprocess.run([sys.executable, __file__, "--one", arg], capture_output=True, text=True, check=True)
        r = json.loads(out.stdout)
        print(f"{r['mesh']:>10} {r['dofs']:>7} {r['assembly_s']:>11.2f} {r['modes_s']:>8.2f} {r['peak_mb']:>8.0f}"
              f" {r['f1_vs_eb']:>9.2e} {r['f2_vs_eb']:>9.2e}")
