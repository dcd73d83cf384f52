#!/usr/bin/env python3
"""The fleet study of docs/fleet.md §8, measured on this machine: the synthetic fleet's two
nights through blmd-ident --batch and the score; throughput (2 threads against 1, a
LocalCluster of 2 workers against 1, Dask's per-record overhead against the command); the
multi-machine path (a `dask scheduler` and two `dask worker` processes on the loopback
address); a worker killed mid-run; a batch interrupted and restarted. Prints one JSON object.

Usage: study.py STUDY_DIR [--bin build/bin] [--subset 200] [--steps all|fleet|throughput|cluster|faults]
STUDY_DIR: made by make_fleet.py. Needs blmd on PYTHONPATH (build/python).
"""
import argparse
import csv
import json
import os
import signal
import statistics
import subprocess
import sys
import time

import blmd

HERE = os.path.dirname(os.path.abspath(__file__))


def table(path):
    """The table without its timing column, as lists."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    wall = rows[0].index("wall_time_s")
    return [r[:wall] + r[wall + 1:] for r in rows]


def cli(bin_dir, manifest, out, *more):
    start = time.perf_counter()
    done = subprocess.run([os.path.join(bin_dir, "blmd-ident"), "--batch", manifest, "--out", out,
                           "--no-progress", *more], capture_output=True, text=True)
    return time.perf_counter() - start, done


def subset(manifest, n, path):
    with open(manifest) as f:
        lines = f.readlines()
    with open(path, "w") as f:
        f.writelines(lines[: n + 1])
    return path


def wait_for(predicate, timeout):
    end = time.time() + timeout
    while time.time() < end:
        if predicate():
            return True
        time.sleep(0.2)
    return False


def main():
    p = argparse.ArgumentParser()
    p.add_argument("study")
    p.add_argument("--bin", default=os.path.join(HERE, "..", "..", "build", "bin"))
    p.add_argument("--subset", type=int, default=200)
    p.add_argument("--steps", default="all")
    a = p.parse_args()
    os.chdir(a.study)
    steps = a.steps.split(",")
    run_all = "all" in steps
    out = {}
    bin_dir = os.path.abspath(a.bin)

    if run_all or "fleet" in steps:
        t1, d1 = cli(bin_dir, "baseline.csv", "night1", "--baseline-dir", "base",
                     "--new-baselines", "--threads", "2")
        t2, d2 = cli(bin_dir, "current.csv", "night2", "--baseline-dir", "base", "--threads", "2")
        score = json.loads(subprocess.run([sys.executable, os.path.join(HERE, "score.py"), ".",
                                           "night2/results.csv"], capture_output=True,
                                          text=True).stdout)
        out["fleet"] = {"night1_s": round(t1, 1), "night1_exit": d1.returncode,
                        "night1_summary": d1.stdout.splitlines()[0],
                        "night2_s": round(t2, 1), "night2_exit": d2.returncode,
                        "night2_summary": d2.stdout.splitlines()[0], "score": score}
        print(json.dumps(out["fleet"], indent=1), file=sys.stderr, flush=True)

    sub = subset("current.csv", a.subset, "subset.csv")
    if run_all or "throughput" in steps:
        r = {}
        for name, more in (("cli_1_thread", ["--threads", "1"]), ("cli_2_threads", ["--threads", "2"])):
            t, d = cli(bin_dir, sub, "tp-" + name, "--baseline-dir", "base", *more)
            r[name + "_s"] = round(t, 2)
        for workers in (1, 2):
            start = time.perf_counter()
            blmd.fleet.run(sub, out=f"tp-dask-{workers}", baseline_dir="base", workers=workers)
            r[f"dask_{workers}_workers_s"] = round(time.perf_counter() - start, 2)
        r["threads_speedup"] = round(r["cli_1_thread_s"] / r["cli_2_threads_s"], 2)
        r["workers_speedup"] = round(r["dask_1_workers_s"] / r["dask_2_workers_s"], 2)
        r["dask_overhead_1_worker"] = round(r["dask_1_workers_s"] / r["cli_1_thread_s"] - 1, 3)
        r["dask_overhead_2_workers"] = round(r["dask_2_workers_s"] / r["cli_2_threads_s"] - 1, 3)
        r["same_table_cli_dask"] = table("tp-cli_2_threads/results.csv") == \
            table("tp-dask-2/results.csv")
        r["rows"] = a.subset
        out["throughput"] = r
        print(json.dumps(r, indent=1), file=sys.stderr, flush=True)

    if run_all or "cluster" in steps or "faults" in steps:
        # A scheduler and two workers as separate processes on the loopback address.
        env = dict(os.environ)
        procs = [subprocess.Popen(["dask", "scheduler", "--host", "127.0.0.1", "--port", "8786",
                                   "--no-dashboard"], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL, env=env)]
        time.sleep(3)
        workers = [subprocess.Popen(["dask", "worker", "tcp://127.0.0.1:8786", "--nthreads",
                                     "1", "--no-nanny", "--no-dashboard"],
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                    env=env) for _ in range(2)]
        procs += workers
        from dask.distributed import Client
        client = Client("tcp://127.0.0.1:8786")
        client.wait_for_workers(2, timeout=60)
        try:
            if run_all or "cluster" in steps:
                start = time.perf_counter()
                blmd.fleet.run("current.csv", out="cluster", baseline_dir="base",
                               client=client)
                out["cluster"] = {
                    "workers": len(client.scheduler_info()["workers"]),
                    "seconds": round(time.perf_counter() - start, 1),
                    "same_table_as_cli": table("cluster/results.csv") ==
                    table("night2/results.csv")}
                print(json.dumps(out["cluster"]), file=sys.stderr, flush=True)
            if run_all or "faults" in steps:
                # A worker killed (SIGKILL) once a tenth of the rows have finished.
                total = sum(1 for _ in open("current.csv")) - 1
                import threading
                result = {}

                def go():
                    result["table"] = blmd.fleet.run("current.csv", out="killed",
                                                     baseline_dir="base", client=client)
                thread = threading.Thread(target=go)
                thread.start()
                rows_dir = os.path.join("killed", "rows")
                wait_for(lambda: os.path.isdir(rows_dir) and
                         len(os.listdir(rows_dir)) >= total // 10, 600)
                finished_at_kill = len(os.listdir(rows_dir))
                workers[0].send_signal(signal.SIGKILL)
                thread.join()
                t = result["table"]
                out["worker_killed"] = {
                    "rows_finished_at_kill": finished_at_kill,
                    "rows": len(t), "unique_ids": int(t["id"].nunique()),
                    "same_table_as_cli": table("killed/results.csv") ==
                    table("night2/results.csv")}
                print(json.dumps(out["worker_killed"]), file=sys.stderr, flush=True)
        finally:
            client.close()
            for proc in procs:
                proc.kill()
        if run_all or "faults" in steps:
            # A batch interrupted (SIGINT) once a quarter of its rows have finished, then run
            # again: only the unfinished rows run.
            proc = subprocess.Popen([os.path.join(bin_dir, "blmd-ident"), "--batch",
                                     "current.csv", "--out", "interrupted", "--baseline-dir",
                                     "base", "--threads", "2", "--no-progress"],
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            total = sum(1 for _ in open("current.csv")) - 1
            rows_dir = os.path.join("interrupted", "rows")
            wait_for(lambda: os.path.isdir(rows_dir) and len(os.listdir(rows_dir)) >= total // 4,
                     600)
            proc.send_signal(signal.SIGINT)
            proc.wait()
            finished = len(os.listdir(rows_dir))
            t, d = cli(bin_dir, "current.csv", "interrupted", "--baseline-dir", "base",
                       "--threads", "2")
            out["interrupted"] = {"exit_at_interrupt": proc.returncode,
                                  "rows_finished_before": finished,
                                  "restart_summary": d.stdout.splitlines()[0],
                                  "same_table_as_cli": table("interrupted/results.csv") ==
                                  table("night2/results.csv")}
            print(json.dumps(out["interrupted"]), file=sys.stderr, flush=True)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
