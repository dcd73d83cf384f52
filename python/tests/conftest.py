"""Shared helpers of the Python package's tests: where the repository and the built commands
are, running a command, reading a CSV exactly (float() rounds correctly, as the library's
reader does), and comparing two reports number by number."""

import math
import os
import pathlib
import re
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
BIN = pathlib.Path(os.environ.get("BLMD_BIN_DIR", REPO / "build" / "bin"))


def repo_path(relative):
    return str(REPO / relative)


def run_command(tool, *args, expect=0):
    """Runs build/bin/<tool> from the repository root; returns (stdout, stderr)."""
    command = [str(BIN / tool), *map(str, args)]
    done = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == expect, (command, done.returncode, done.stderr)
    return done.stdout, done.stderr


def cli_error(tool, *args):
    """The one-line message of a command that exits 2, without 'error: ' and without the
    pointer to the command's --help that a flag's own check adds."""
    _, stderr = run_command(tool, *args, expect=2)
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), stderr
    return re.sub(r" \(see \S+ --help\)$", "", lines[0][len("error: "):])


def read_csv(path):
    """{column: list of floats} of a trace or surface CSV ('#' lines skipped)."""
    with open(path, encoding="utf-8") as file:
        lines = [line.rstrip("\n") for line in file if not line.startswith("#")]
    header = lines[0].split(",")
    columns = {name: [] for name in header}
    for line in lines[1:]:
        for name, field in zip(header, line.split(",")):
            columns[name].append(float(field) if field else math.nan)
    return columns


# Fields that differ between two runs on the same data, or name where the data came from.
VOLATILE = {"wall_time_s"}


def assert_same_report(actual, expected, ignore=frozenset(), where="report", rel=1e-12):
    """Every key of both, every string equal, every number within `rel` (relative)."""
    if isinstance(expected, dict):
        assert isinstance(actual, dict), where
        keys = set(expected) - VOLATILE - set(ignore)
        assert set(actual) - VOLATILE - set(ignore) == keys, (where, set(actual) ^ set(expected))
        for key in keys:
            assert_same_report(actual[key], expected[key], ignore, f"{where}.{key}", rel)
    elif isinstance(expected, list):
        assert isinstance(actual, list) and len(actual) == len(expected), where
        for k, (a, e) in enumerate(zip(actual, expected)):
            assert_same_report(a, e, ignore, f"{where}[{k}]", rel)
    elif isinstance(expected, bool) or expected is None or isinstance(expected, str):
        assert actual == expected, (where, actual, expected)
    else:
        assert isinstance(actual, (int, float)) and not isinstance(actual, bool), where
        assert actual == pytest.approx(expected, rel=rel, abs=0.0), (where, actual, expected)
