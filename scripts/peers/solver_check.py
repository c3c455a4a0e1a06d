#!/usr/bin/env python3
"""SciPy's trust-region solver against wiical-core's multi-position fit on the same window sets.

The core's solver must converge wherever an f64 trust-region solver
(SciPy ``least_squares``, method ``trf``) converges on the same windows, and say why when it
cannot. The sets (random subsets of the static windows of five real recordings, with the
core's outcome) come from the core's test suite:

    WIICAL_SOLVER_SETS=target/solver_sets.json \\
        cargo test -p wiical-core --test multipos -- --ignored dump_window_subsets_for_scipy
    target/peers-venv/bin/python scripts/peers/solver_check.py target/solver_sets.json

(``scripts/bench-peers`` creates ``target/peers-venv`` with numpy and SciPy.) SciPy starts from
the neutral point of the normalised frame (``common.scipy_fit``'s start); its result counts as
converged when ``status > 0`` and the bias stays within 100 pose spreads of the poses' centre
(further out is a sphere running off to infinity). Prints a table of (core outcome, SciPy
outcome) counts, then every set where SciPy converged and the core did not, with the
conditioning of SciPy's minimum, and every set where both converged but the RMS differs by more
than 0.1 %. Exit status 1 when the core fails with NotConverged/Diverged on a set where SciPy
converged to a well-conditioned minimum.
"""
import json
import sys
from collections import Counter

import numpy as np
from scipy.optimize import least_squares

import common


def scipy_outcome(means):
    m = np.asarray(means, dtype=np.float64)
    c, s = common._normalisation(m)
    y = (m - c) / s
    p0 = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0])
    sol = least_squares(
        lambda p: common._res_jac(p, y)[0],
        p0,
        jac=lambda p: common._res_jac(p, y)[1],
        method="trf",
        ftol=1e-12,
        xtol=1e-12,
        gtol=1e-12,
        max_nfev=2000,
    )
    converged = bool(sol.status > 0 and np.max(np.abs(sol.x[:3])) < 100.0)
    jac = common._res_jac(sol.x, y)[1]
    d = np.sqrt(np.sum(jac * jac, axis=0))
    scaled = (jac / np.where(d > 0, d, 1.0)).T @ (jac / np.where(d > 0, d, 1.0))
    ident = float(np.min(np.linalg.eigvalsh(scaled)))
    return converged, float(np.sqrt(np.mean(sol.fun**2))), ident, int(sol.status)


def main() -> int:
    with open(sys.argv[1], encoding="utf-8") as f:
        sets = json.load(f)
    table = Counter()
    bad = 0
    for x in sets:
        conv, rms, ident, status = scipy_outcome(x["means"])
        table[(x["core"], "scipy converged" if conv else "scipy failed")] += 1
        if conv and x["core"] != "ok":
            well = ident > 1e-4
            bad += int(well and x["core"] in ("NotConverged", "Diverged"))
            print(
                f"{x['file']} ({len(x['means'])} windows): core {x['core']}, SciPy status "
                f"{status}, rms {rms * 1e3:.4f} mg, identifiability {ident:.2e}"
            )
        elif conv and abs(x["core_rms_g"] - rms) > 1e-3 * rms + 1e-7:
            print(f"{x['file']}: rms core {x['core_rms_g']} g vs SciPy {rms} g")
    print()
    for (core, sp), n in sorted(table.items()):
        print(f"| {core:<20} | {sp:<16} | {n:>4} |")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
