"""blmd.fleet.run (docs/fleet.md §7) on a real Dask LocalCluster: the same table as
blmd-ident --batch, line for line (save the timing column), error rows for bad rows, a
DataFrame with the table's columns, and a second run that reuses every finished row."""

import csv
import os
import signal
import shutil
import subprocess
import sys
import time

import pandas as pd
import pytest

import blmd
from conftest import BIN, repo_path, run_command

SQUARE = repo_path("configs/ganesh-square.json")
TRACE = repo_path("testdata/ganesh-square.csv")
NOLOAD_STEP = repo_path("testdata/ganesh-noload-step.csv")


def table_without_time(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    wall = rows[0].index("wall_time_s")
    return [row[:wall] + row[wall + 1:] for row in rows]


def write_manifest(folder):
    (folder / "bad.csv").write_text("t,u,i,w\n0,1,2,3\n0,1,2,3\n")
    manifest = folder / "fleet.csv"
    manifest.write_text(
        "id,trace,config,baseline,drive,date\n"
        f"a,{TRACE},{SQUARE},,ax1,2026-11-01\n"
        f"b,{NOLOAD_STEP},{SQUARE},,ax2,2026-11-01\n"
        f"c,{TRACE};{NOLOAD_STEP},{SQUARE},,ax3,2026-11-01\n"
        f"d,bad.csv,{SQUARE},,ax4,2026-11-01\n"
        f"a,{TRACE},{SQUARE},,ax1,2026-11-02\n")
    return manifest


def test_fleet_run_gives_the_commands_table(tmp_path):
    manifest = write_manifest(tmp_path)
    run_command("blmd-ident", "--batch", manifest, "--out", tmp_path / "cli", "--threads", "2",
                expect=1)
    table = blmd.fleet.run(manifest, out=tmp_path / "dask", workers=2)
    assert isinstance(table, pd.DataFrame)
    assert table_without_time(tmp_path / "cli" / "results.csv") == \
        table_without_time(tmp_path / "dask" / "results.csv")
    with open(tmp_path / "cli" / "results.csv", newline="") as f:
        header = next(csv.reader(f))
    assert list(table.columns) == header
    assert list(table["status"]) == ["ok", "ok", "ok", "error", "error"]
    assert "time 't' must strictly increase" in table["message"][3]
    assert table["message"][4].endswith("id 'a' repeats line 2")
    summary = table.attrs["summary"]
    assert (summary["rows"], summary["ok"], summary["error"], summary["exit_code"]) == (5, 3, 2, 1)
    assert (summary["ran"], summary["reused"]) == (4, 0)
    # Everything finished: a second run reuses every row and writes the same table.
    again = blmd.fleet.run(manifest, out=tmp_path / "dask", workers=1)
    assert (again.attrs["summary"]["ran"], again.attrs["summary"]["reused"]) == (0, 4)
    assert table_without_time(tmp_path / "dask" / "results.csv") == \
        table_without_time(tmp_path / "cli" / "results.csv")


def test_fleet_run_refuses_bad_flags_and_manifests_before_any_work(tmp_path):
    manifest = write_manifest(tmp_path)
    with pytest.raises(ValueError, match="--report: not for a batch row"):
        blmd.fleet.run(manifest, out=tmp_path / "out", args=["--report", "x.json"])
    with pytest.raises(ValueError, match="unknown column 'trac'"):
        (tmp_path / "m.csv").write_text("id,trac,config\n")
        blmd.fleet.run(tmp_path / "m.csv", out=tmp_path / "out")
    with pytest.raises(ValueError, match=r"drift_alpha: must be a number in \(0, 1\), not 0"):
        blmd.fleet.run(manifest, out=tmp_path / "out", drift_alpha=0)
    assert not (tmp_path / "out").exists()
