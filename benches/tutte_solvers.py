"""Solvers for the Tutte system of a disk, side by side with scipy and CHOLMOD.

    python benches/tutte_solvers.py [--sizes 100000 1000000] [--gs-max-iter 3000]

The disk is a generated bumpy blob with a polar cap cut away. For each size:

* spherify ``sp.tutte`` end to end (weights, assembly, solve, exact flip check)
  with ``solver="auto"``, ``"cg"`` (IC(0)), ``"cg_jacobi"`` and
  ``"gauss_seidel"`` (iterations to a relative residual of 1e-8; Gauss-Seidel
  is capped at ``--gs-max-iter`` sweeps and then reports the residual reached);
* on the same matrix, assembled here with scipy from the same mesh (uniform
  weights: the graph Laplacian's interior block), ``scipy.sparse.linalg.spsolve``
  (SuperLU) and, where scikit-sparse is installed, one CHOLMOD factorisation
  plus the two solves.

Both right-hand sides (x and y) are solved in every case. Times are medians of
``--repeats`` runs; the machine is shared, so compare the ratios.
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Callable, Dict, List

import numpy as np
import scipy.sparse as sparse
import scipy.sparse.linalg as sla

import spherify as sp


def capped_disk(n_vertices: int) -> sp.Mesh:
    blob = sp.datasets.bumpy_blob(n_vertices=n_vertices)
    V, F = blob.vertices, blob.faces
    z = V[F].mean(axis=1)[:, 2]
    keep = z < np.quantile(z, 0.97)
    used = np.unique(F[keep])
    remap = np.full(len(V), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return sp.Mesh(V[used], remap[F[keep]])


def laplacian_system(mesh: sp.Mesh):
    """Interior block of the uniform-weight Laplacian and the two right-hand sides."""
    F = mesh.faces
    n = mesh.n_vertices
    i = np.concatenate([F[:, 0], F[:, 1], F[:, 2], F[:, 1], F[:, 2], F[:, 0]])
    j = np.concatenate([F[:, 1], F[:, 2], F[:, 0], F[:, 0], F[:, 1], F[:, 2]])
    W = sparse.coo_matrix((np.ones(len(i)), (i, j)), shape=(n, n)).tocsr()
    W.data[:] = 1.0  # each undirected edge once per direction
    L = sparse.diags(np.asarray(W.sum(axis=1)).ravel()) - W
    loop = sp.boundary_loop(mesh)
    t = 2 * np.pi * np.arange(len(loop)) / len(loop)
    boundary_uv = np.stack([np.cos(t), np.sin(t)], axis=1)
    free = np.setdiff1d(np.arange(n), loop)
    A = L[free][:, free].tocsc()
    B = -(L[free][:, loop] @ boundary_uv)
    return A, B


def median(job: Callable[[], object], repeats: int) -> float:
    times: List[float] = []
    for _ in range(repeats):
        start = time.perf_counter()
        job()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--gs-max-iter", type=int, default=3000)
    parser.add_argument("--solvers", nargs="+", default=["auto", "cg", "cg_jacobi", "gauss_seidel"],
                        help="spherify solvers to time (default: all)")
    args = parser.parse_args()
    try:
        from sksparse.cholmod import cholesky
    except ImportError:
        cholesky = None

    print("| unknowns | method | seconds | iterations | rel. residual | vs auto |")
    print("|---:|---|---:|---:|---:|---:|")
    for size in args.sizes:
        mesh = capped_disk(size)
        A, B = laplacian_system(mesh)
        n = A.shape[0]
        rows: Dict[str, tuple] = {}
        for solver in dict.fromkeys(["auto"] + args.solvers):
            max_iter = args.gs_max_iter if solver == "gauss_seidel" else 100_000
            state = {}

            def run() -> None:
                try:
                    _, info = sp.tutte(mesh, solver=solver, tol=1e-8, max_iter=max_iter,
                                       return_info=True)
                    state.update(iterations=info.iterations, residual=info.residual,
                                 solver=info.solver)
                except sp.ConvergenceError as err:
                    state.update(iterations=err.state["iterations"],
                                 residual=err.state["residual"], solver=solver + " (capped)")

            seconds = median(run, 1 if solver == "gauss_seidel" else args.repeats)
            rows[f"spherify {solver} -> {state['solver']}"] = (seconds, state["iterations"],
                                                              state["residual"])
        spsolve_x = None

        def scipy_job() -> None:
            nonlocal spsolve_x
            spsolve_x = sla.spsolve(A, B)

        seconds = median(scipy_job, args.repeats)
        residual = np.linalg.norm(A @ spsolve_x - B) / np.linalg.norm(B)
        rows["scipy spsolve (SuperLU)"] = (seconds, 0, residual)
        if cholesky is not None:
            chol_x = None

            def cholmod_job() -> None:
                nonlocal chol_x
                chol_x = cholesky(A)(B)

            seconds = median(cholmod_job, args.repeats)
            residual = np.linalg.norm(A @ chol_x - B) / np.linalg.norm(B)
            rows["CHOLMOD (scikit-sparse)"] = (seconds, 0, residual)
        auto = next(v[0] for k, v in rows.items() if k.startswith("spherify auto"))
        for name, (seconds, iterations, residual) in rows.items():
            print(f"| {n} | {name} | {seconds:.3f} | {iterations} | {residual:.1e} | "
                  f"{seconds / auto:.2f} |", flush=True)


if __name__ == "__main__":
    main()
