#!/usr/bin/env python3
"""scikit-fem oracle for softsense's FE core (small-strain linear elasticity, P1 tetrahedra).

Called with one argument, a JSON job file (the protocol of tools/oracle/README.md):
  {"stage": "linear_elastic", "input": "/abs/problem.json", "output_dir": "/abs/dir",
   "params": {}, "repeat": 1}
The input file holds the problem in SI units:
  {"nodes": [[x,y,z],...], "tets": [[a,b,c,d],...], "young": E, "poisson": nu,
   "fixed": [node,...], "prescribed": [[node, ux, uy, uz],...], "forces": [[node, fx, fy, fz],...]}
Writes output_dir/result.json:
  {"library": "scikit-fem", "version": "...", "stage": "linear_elastic", "ok": true,
   "error": null, "points": N, "displacement": [[ux,uy,uz],...], "timings_ms": [...]}
"""
import json
import sys
import time
from pathlib import Path


def main():
    job = json.loads(Path(sys.argv[1]).read_text())
    out = Path(job["output_dir"])
    out.mkdir(parents=True, exist_ok=True)
    result = {"library": "scikit-fem", "stage": job.get("stage"), "ok": False, "error": None}
    try:
        import numpy as np
        import skfem
        from skfem import Basis, ElementTetP1, ElementVector, MeshTet, asm, condense, solve
        from skfem.models.elasticity import lame_parameters, linear_elasticity

        result["version"] = skfem.__version__
        if job.get("stage") != "linear_elastic":
            raise ValueError("unknown stage %r" % job.get("stage"))
        prob = json.loads(Path(job["input"]).read_text())
        p = np.asarray(prob["nodes"], dtype=float).T
        t = np.asarray(prob["tets"], dtype=np.int64).T
        timings = []
        for _ in range(int(job.get("repeat", 1))):
            t0 = time.perf_counter()
            mesh = MeshTet(p, t)
            basis = Basis(mesh, ElementVector(ElementTetP1()))
            K = asm(linear_elasticity(*lame_parameters(prob["young"], prob["poisson"])), basis)
            nd = basis.nodal_dofs  # (3, N): dof of (component, node)
            f = np.zeros(K.shape[0])
            for n, fx, fy, fz in prob.get("forces", []):
                f[nd[:, int(n)]] += [fx, fy, fz]
            x = np.zeros(K.shape[0])
            held = [int(v) for v in prob.get("fixed", [])]
            for n, ux, uy, uz in prob.get("prescribed", []):
                x[nd[:, int(n)]] = [ux, uy, uz]
                held.append(int(n))
            D = nd[:, sorted(set(held))].ravel()
            u = solve(*condense(K, f, x=x, D=D))
            timings.append((time.perf_counter() - t0) * 1e3)
        result["displacement"] = u[nd].T.tolist()
        result["points"] = int(p.shape[1])
        result["timings_ms"] = timings
        result["ok"] = True
    except Exception as e:  # reported, not raised: the Rust side decides
        result["error"] = "%s: %s" % (type(e).__name__, e)
    (out / "result.json").write_text(json.dumps(result))
    return 0 if result["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
