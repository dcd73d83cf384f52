"""blmd.fleet: one identification per row of a manifest, as Dask tasks (docs/fleet.md).

``run(manifest, out=DIR)`` does what ``blmd-ident --batch MANIFEST --out DIR`` does, with the
rows as tasks of a Dask.distributed cluster: a ``LocalCluster`` on this machine by default, or
any scheduler (``client=`` a ``dask.distributed.Client`` or a scheduler address such as
``"tcp://10.0.0.5:8786"``; ``dask scheduler`` and ``dask worker`` processes, or SSH, Slurm,
Kubernetes deployments). Each task runs the command's own row runner in the worker's process
(the C++ library, with the GIL released) and writes the row's report and line into ``out``;
the table (``results.csv``, ``results.jsonl``) and ``fleet.html`` are then written by the same
code as the command's, so the two tables agree line for line.

The workers read the manifest's files and write into ``out`` by the paths given: on several
machines these must be on a shared file system (the same paths everywhere).

A task whose worker dies is run again by Dask on another worker; a row's files are written
atomically and the table is built from one line per manifest row, so no row is lost or
doubled. A row whose inputs and flags are unchanged since it finished (its key, a SHA-256 of
them) is not run again: an interrupted run, started again, runs only the unfinished rows.
"""

import json
import os

from . import _blmd

__all__ = ["run"]


def _run_rows(rows, common, out, baseline_dir, alpha, threads):
    """Rows on a worker, one after the other: each one's line of the table (a dict) and
    whether it was reused. A chunk run again (its worker lost) reuses the rows it finished."""
    results = []
    for row in rows:
        text, reused = _blmd.fleet_run_row(row, common, out, baseline_dir, alpha, threads)
        results.append((json.loads(text), reused))
    return results


def run(manifest, out, client=None, args=(), baseline_dir=None, new_baselines=False,
        drift_alpha=0.01, workers=None, retries=2, progress=None, chunk=None):
    """Identify every row of ``manifest`` as a Dask task; returns the table as a DataFrame.

    manifest: the manifest CSV (``id,trace,config,baseline``, docs/fleet.md).
    out: the output folder (created): <id>.json reports, rows/, results.csv, results.jsonl,
        fleet.html.
    client: None (a LocalCluster of ``workers`` processes, one thread each, closed at the
        end), a scheduler address, or a ``dask.distributed.Client`` (left open).
    args: blmd-ident flags every row gets, e.g. ``["--discover", "--method", "powell"]``.
    baseline_dir, new_baselines, drift_alpha: as ``--baseline-dir``, ``--new-baselines``,
        ``--drift-alpha``.
    retries: how often a task that raised is tried again (a lost worker is Dask's own
        matter: its tasks are rescheduled).
    progress: a callable ``progress(done, total)`` called as rows finish.
    chunk: rows per task (default: the rows spread over four tasks per worker thread, at most
        32 per task): fewer, longer tasks cost the scheduler less per row.

    The DataFrame has the columns of ``out/results.csv``; its ``attrs["summary"]`` holds the
    counts (rows, ok, drift, error, ran, reused) and the exit code the command would give.
    Raises ValueError (blmd.InputError) for a bad manifest or bad flags, before any work.
    """
    import pandas as pd
    from dask.distributed import Client, LocalCluster, as_completed

    common = [str(a) for a in args]
    _blmd.fleet_check_args(common)
    if not 0.0 < float(drift_alpha) < 1.0:
        raise _blmd.InputError(f"drift_alpha: must be a number in (0, 1), not {drift_alpha}")
    if new_baselines and not baseline_dir:
        raise _blmd.InputError(
            "new_baselines needs baseline_dir (where the baselines are kept)")
    rows = _blmd.fleet_manifest(os.fspath(manifest))
    out = os.fspath(out)
    _blmd.fleet_prepare(out)
    baseline_dir = os.fspath(baseline_dir) if baseline_dir else ""

    owned = []
    if client is None:
        cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1,
                               threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
        owned = [client, cluster]
    elif isinstance(client, str):
        client = Client(client)
        owned = [client]
    try:
        todo = [k for k, row in enumerate(rows) if not row["error"]]
        if chunk is None:
            threads = sum(client.nthreads().values()) or 1
            chunk = max(1, min(32, -(-len(todo) // (4 * threads))))
        futures = {}
        for start in range(0, len(todo), int(chunk)):
            part = todo[start:start + int(chunk)]
            future = client.submit(_run_rows, [rows[k] for k in part], common, out,
                                   baseline_dir, float(drift_alpha), 1, pure=False,
                                   retries=retries)
            futures[future] = part
        lines = [""] * len(rows)
        ran = reused = 0
        done = 0
        for future in as_completed(list(futures)):
            for k, (line, was_reused) in zip(futures[future], future.result()):
                lines[k] = json.dumps(line)
                reused += bool(was_reused)
                ran += not was_reused
                done += 1
            if progress is not None:
                progress(done, len(todo))
    finally:
        for thing in owned:
            thing.close()
    summary = _blmd.fleet_finish(rows, lines, out, baseline_dir, bool(new_baselines))
    summary.update(ran=ran, reused=reused)
    table = pd.read_csv(os.path.join(out, "results.csv"), dtype={"id": str, "drive": str,
                                                                  "date": str})
    table.attrs["summary"] = summary
    return table
