"""Calibrate many recordings on a Dask cluster: the wiical package mapped over files.

Each task reads one file and runs the residual analysis (the GIL is released inside, so
threads of a worker run in parallel too); the driver collects one small summary row per
file. A file that cannot be analysed is a row with its error, never a failed job.

    python examples/dask_batch.py DIR_OR_GLOB [--scheduler tcp://host:8786] [--workers 2]

Without --scheduler a local cluster of --workers processes is started (what the test does);
with it, the same code runs on any Dask cluster whose workers have `pip install wiical`.
For resumable runs on one machine, `wiical batch` does the same from the command line.
"""

from __future__ import annotations

import argparse
import glob
import os
from typing import Any, Dict, List

import wiical


def summarise(path: str) -> Dict[str, Any]:
    """One file → one row: the verdict, the error before and after, the effects named."""
    try:
        rep = wiical.analyze(path)
    except wiical.WiicalError as e:
        return {"file": path, "ok": False, "error": str(e)}
    return {
        "file": path,
        "ok": True,
        "windows": rep["static_windows"],
        "verdict": rep["quality"]["verdict"],
        "base_cv_mg": rep["base"]["cv_rms_mg"],
        "final_cv_mg": rep["final"]["cv_rms_mg"],
        "effects": [e["name"] for e in rep["effects"]],
    }


def files_of(spec: str) -> List[str]:
    if os.path.isdir(spec):
        return sorted(
            os.path.join(d, f)
            for d, _, names in os.walk(spec)
            for f in names
            if not f.startswith(".")
        )
    return sorted(glob.glob(spec))


def run(files: List[str], scheduler: str | None = None, workers: int = 2) -> List[Dict[str, Any]]:
    """Maps [`summarise`] over `files` on a Dask cluster and gathers the rows in file order."""
    from dask.distributed import Client, LocalCluster

    if scheduler is None:
        cluster = LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
        )
        client = Client(cluster)
    else:
        cluster, client = None, Client(scheduler)
    try:
        futures = client.map(summarise, files, pure=False)
        return client.gather(futures)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("inputs", help="a directory or a quoted glob pattern")
    ap.add_argument("--scheduler", help="address of a running Dask scheduler")
    ap.add_argument("--workers", type=int, default=2, help="local cluster size")
    a = ap.parse_args()
    rows = run(files_of(a.inputs), a.scheduler, a.workers)
    for r in rows:
        if r["ok"]:
            print(f"{r['file']}: {r['verdict']}, {r['windows']} windows, CV "
                  f"{r['base_cv_mg']:.3f} -> {r['final_cv_mg']:.3f} mg, effects {r['effects']}")
        else:
            print(f"{r['file']}: {r['error']}")


if __name__ == "__main__":
    main()
