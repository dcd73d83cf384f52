"""The Python package against the commands: the same data through blmd.simulate,
blmd.identify and blmd.surface and through blmd-sim, blmd-ident and blmd-surface must give
the same numbers (bit for bit where the command writes round-trip exact numbers; 1e-12
relative in the report), and bad input the same message."""

import json
import re
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import blmd
from conftest import assert_same_report, cli_error, read_csv, repo_path, run_command

NOLOAD = repo_path("configs/ganesh-noload.json")
NOLOAD_STEP = repo_path("testdata/ganesh-noload-step.csv")
SQUARE = repo_path("configs/ganesh-square.json")
HIDDEN_COULOMB = repo_path("testdata/dc-hidden-coulomb.csv")


def arrays(path):
    return {name: np.array(values) for name, values in read_csv(path).items()}


def load_json(path):
    with open(path, encoding="utf-8") as file:
        return json.load(file)


# ---- simulate ----

def test_simulate_equals_blmd_sim(tmp_path):
    out = tmp_path / "step.csv"
    run_command("blmd-sim", "--config", NOLOAD, "--out", out, "--noise", "i=1%", "--noise",
                "w=0.5", "--seed", 7, "--quiet")
    expected = read_csv(out)
    trace = blmd.simulate(NOLOAD, noise={"i": "1%", "w": 0.5}, seed=7)
    assert list(trace) == list(expected)
    for name, values in expected.items():
        assert isinstance(trace[name], np.ndarray) and trace[name].dtype == np.float64
        assert trace[name].tolist() == values, name  # exact: the CSV is round-trip exact


def test_simulate_input_equals_blmd_sim_input(tmp_path):
    config = repo_path("configs/ganesh-load1.json")
    recorded = repo_path("testdata/ganesh-square.csv")
    out = tmp_path / "replay.csv"
    run_command("blmd-sim", "--config", config, "--input", recorded, "--out", out,
                "--effect", "coulomb_friction:Tc=0.003", "--quiet")
    expected = read_csv(out)
    columns = arrays(recorded)
    from_arrays = blmd.simulate(config, input={"t": columns["t"], "u": columns["u"]},
                                effects={"coulomb_friction": {"Tc": 0.003}})
    from_path = blmd.simulate(config, input=recorded, effects=["coulomb_friction:Tc=0.003"])
    for trace in (from_arrays, from_path):
        assert list(trace) == list(expected)
        for name, values in expected.items():
            assert trace[name].tolist() == values, name


def test_simulate_config_dict_equals_path():
    by_path = blmd.simulate(NOLOAD, noise={"w": "2%"}, seed=3)
    by_dict = blmd.simulate(load_json(NOLOAD), noise=["w=2%"], seed=3)
    assert list(by_path) == list(by_dict)
    for name in by_path:
        assert np.array_equal(by_path[name], by_dict[name]), name


def test_simulate_diverged_is_fit_error(tmp_path):
    # A strong quadratic drag with a coarse step: the explicit step overshoots and diverges
    # (tests/cli/numerical_faults_test.cc).
    config = load_json(NOLOAD)
    config["effects"] = {"quadratic_drag": {"Cd": 0.1}}
    config["simulation"]["dt"] = 0.001
    config["experiment"]["sample_rate"] = 1000
    path = tmp_path / "coarse.json"
    path.write_text(json.dumps(config))
    _, stderr = run_command("blmd-sim", "--config", path, "--out", tmp_path / "x.csv", expect=1)
    with pytest.raises(blmd.FitError) as raised:
        blmd.simulate(str(path))
    assert isinstance(raised.value, RuntimeError)
    assert "error: " + str(raised.value) == stderr.strip()


# ---- identify ----

def cli_report(tmp_path, *args):
    report = tmp_path / "report.json"
    run_command("blmd-ident", *args, "--report", report, "--quiet")
    return load_json(report)


def test_identify_arrays_equals_cli_report(tmp_path):
    expected = cli_report(tmp_path, "--config", NOLOAD, "--trace", NOLOAD_STEP)
    by_path = blmd.identify(NOLOAD, [NOLOAD_STEP])
    assert_same_report(by_path, expected)  # the same file: every field but the run time
    by_arrays = blmd.identify(NOLOAD, [arrays(NOLOAD_STEP)])
    # Columns in memory have no file: their path is traces[0], their hash that of the CSV
    # text the tool would write for them (64 hex digits, the same for the same arrays, and
    # another for other data).
    digest = by_arrays["trace"]["sha256"]
    assert by_arrays["trace"]["path"] == "traces[0]"
    assert re.fullmatch("[0-9a-f]{64}", digest)
    assert blmd.identify(NOLOAD, [arrays(NOLOAD_STEP)])["trace"]["sha256"] == digest
    shifted = arrays(NOLOAD_STEP)
    shifted["w"] = shifted["w"] * (1.0 + 1e-12)
    assert blmd.identify(NOLOAD, [shifted])["trace"]["sha256"] != digest
    assert_same_report(by_arrays, expected, ignore={"path", "sha256"})
    assert by_arrays["parameters"]["J"]["value"] == expected["parameters"]["J"]["value"]
    assert set(by_arrays["parameters"]) == {"J", "B"}


def test_identify_options_equal_cli_flags(tmp_path):
    # Method, observed columns, free parameters, start values and a method option as flags
    # and as arguments.
    expected = cli_report(tmp_path, "--config", NOLOAD, "--trace", NOLOAD_STEP, "--method",
                          "powell", "--observe", "w", "--free", "J,B", "--initial", "J=3e-05",
                          "--option", "algorithm=praxis", "--seed", 5)
    report = blmd.identify(NOLOAD, NOLOAD_STEP, method="powell", observe=["w"], free=["J", "B"],
                           initial={"J": 3e-5}, seed=5, algorithm="praxis")
    assert report["method"] == "powell" and report["fit"]["observe"] == ["w"]
    assert_same_report(report, expected)


def uneven_trace(tmp_path):
    """NOLOAD_STEP as a jittery logger writes it: every 7th row missing (a double step) and
    every 50th row followed by a row at the same stamp holding the next row's values."""
    columns = read_csv(NOLOAD_STEP)
    names = list(columns)
    rows = list(zip(*columns.values()))
    lines = [",".join(names)]
    for k, row in enumerate(rows):
        if k % 7 == 3:
            continue
        lines.append(",".join(repr(v) for v in row))
        if k % 50 == 0 and k + 1 < len(rows):
            lines.append(",".join(repr(v) for v in (row[0],) + rows[k + 1][1:]))
    path = tmp_path / "uneven.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_trace_keywords_compose_as_the_flags(tmp_path):
    # select, duplicate_time and resample together, from a path and from arrays: the report
    # of blmd-ident with the same flags (the arrays' path and hash aside). duplicate_time
    # applies to arrays too.
    uneven = uneven_trace(tmp_path)
    expected = cli_report(tmp_path, "--config", NOLOAD, "--trace", uneven, "--select", "t=0:",
                          "--duplicate-time", "mean", "--resample", "auto")
    assert expected["trace"]["samples"] == 10001  # the uniform grid, 0.1 ms from 0 to 1 s
    by_path = blmd.identify(NOLOAD, uneven, select="t=0:", duplicate_time="mean",
                            resample="auto")
    assert_same_report(by_path, expected)
    columns = {name: np.array(values) for name, values in read_csv(uneven).items()}
    by_arrays = blmd.identify(NOLOAD, columns, select="t=0:", duplicate_time="mean",
                              resample="auto")
    assert_same_report(by_arrays, expected, ignore={"path", "sha256"})
    # A step in seconds (a number) is the flag's --resample 0.0001.
    stepped = cli_report(tmp_path, "--config", NOLOAD, "--trace", uneven, "--duplicate-time",
                         "first", "--resample", "0.0001")
    assert_same_report(blmd.identify(NOLOAD, uneven, duplicate_time="first", resample=1e-4),
                       stepped)
    with pytest.raises(blmd.InputError, match=r"repeats .*; for several rows logged at one "
                                              r"instant use duplicate_time='first\|mean'$"):
        blmd.identify(NOLOAD, columns, select="t=0:")


def test_identify_discover_equals_cli(tmp_path):
    expected = cli_report(tmp_path, "--config", SQUARE, "--trace", HIDDEN_COULOMB, "--discover",
                          "--candidates", "coulomb_friction,load_torque", "--max-effects", 1)
    report = blmd.identify(SQUARE, [arrays(HIDDEN_COULOMB)], discover=True,
                           candidates=["coulomb_friction", "load_torque"], max_effects=1)
    assert report["discovery"]["added"] == ["coulomb_friction"]
    assert_same_report(report, expected, ignore={"path", "sha256"})


def test_identify_baseline_equals_cli(tmp_path):
    # The drift guard reads the stored report with the commands' reader: the same comparison,
    # and the same one-line refusal of a file that is not a report.
    stored = tmp_path / "stored.json"
    run_command("blmd-ident", "--config", NOLOAD, "--trace", NOLOAD_STEP, "--report", stored)
    expected = cli_report(tmp_path, "--config", NOLOAD, "--trace", NOLOAD_STEP, "--baseline",
                          stored)
    report = blmd.identify(NOLOAD, [NOLOAD_STEP], baseline=stored)
    assert report["baseline"]["verdict"] == "unchanged"
    assert {name: p["verdict"] for name, p in report["baseline"]["parameters"].items()} == {
        "J": "same", "B": "same"}
    assert_same_report(report, expected)
    message = cli_error("blmd-ident", "--config", NOLOAD, "--trace", NOLOAD_STEP, "--baseline",
                        NOLOAD)
    with pytest.raises(blmd.InputError) as raised:
        blmd.identify(NOLOAD, [NOLOAD_STEP], baseline=NOLOAD)
    assert str(raised.value) == blmd._python_terms(message)
    assert message.endswith(":1:1: not a blmd-ident report (no \"tool\": \"blmd-ident\")")


def test_identify_config_dict_equals_path():
    by_path = blmd.identify(NOLOAD, [NOLOAD_STEP])
    by_dict = blmd.identify(load_json(NOLOAD), [NOLOAD_STEP])
    assert by_dict["config"]["path"] == "<config>"
    assert_same_report(by_dict, by_path, ignore={"path"}, rel=0.0)


class FrameLike:
    """What blmd needs of a pandas DataFrame: keys() and [column]; a text column is left
    out, as the CSV reader leaves out a text column the fit does not use."""

    def __init__(self, columns):
        self._columns = columns

    def keys(self):
        return list(self._columns)

    def __getitem__(self, name):
        return self._columns[name]


def test_identify_mapping_like_frame_equals_dict():
    columns = arrays(NOLOAD_STEP)
    frame = FrameLike({**{k: list(v) for k, v in columns.items()},
                       "note": ["x"] * len(columns["t"])})
    assert_same_report(blmd.identify(NOLOAD, frame), blmd.identify(NOLOAD, [columns]),
                       rel=0.0)


def test_identify_not_converged_is_fit_error(tmp_path):
    args = ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--max-evaluations", 3]
    report_path = tmp_path / "r.json"
    _, stderr = run_command("blmd-ident", *args, "--report", report_path, "--quiet", expect=1)
    with pytest.raises(blmd.FitError) as raised:
        blmd.identify(NOLOAD, NOLOAD_STEP, max_evaluations=3)
    assert "error: " + str(raised.value) == stderr.strip()
    assert_same_report(raised.value.report, load_json(report_path))


# ---- surface ----

def test_surface_equals_blmd_surface(tmp_path):
    out = tmp_path / "jb.csv"
    run_command("blmd-surface", "--config", NOLOAD, "--trace", NOLOAD_STEP, "--grid",
                "J=log:1e-5:5e-5:7", "--grid", "B=1e-5:5e-5:5", "--out", out, "--quiet")
    expected = read_csv(out)
    result = blmd.surface(NOLOAD, NOLOAD_STEP, {"J": ("log", 1e-5, 5e-5, 7), "B": (1e-5, 5e-5, 5)})
    assert result["axes"] == ["J", "B"] and result["cost"].shape == (7, 5)
    assert result["cost"].ravel().tolist() == expected["cost"]
    assert result["mse"]["i"].ravel().tolist() == expected["mse_i"]
    assert np.repeat(result["grid"]["J"], 5).tolist() == expected["J"]
    assert np.tile(result["grid"]["B"], 7).tolist() == expected["B"]
    with open(out, encoding="utf-8") as file:
        assert result["csv"] == file.read()  # byte for byte, metadata included
    best = int(np.argmin(expected["cost"]))
    assert result["minimum"] == {"J": expected["J"][best], "B": expected["B"][best],
                                 "cost": expected["cost"][best]}
    # Columns in memory: the same costs.
    from_arrays = blmd.surface(load_json(NOLOAD), arrays(NOLOAD_STEP),
                               {"J": "log:1e-5:5e-5:7", "B": (1e-5, 5e-5, 5)})
    assert np.array_equal(from_arrays["cost"], result["cost"])


# ---- bad input: InputError, the commands' message with the flags named by the keywords ----

@pytest.mark.parametrize("call, flags", [
    (lambda: blmd.identify(repo_path("configs/missing.json"), NOLOAD_STEP),
     ["--config", repo_path("configs/missing.json"), "--trace", NOLOAD_STEP]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, observe=["q"]),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--observe", "q"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, observe=[]),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--observe", ""]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, method="newton"),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--method", "newton"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, free=["J", "Q"]),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--free", "J,Q"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, initial={"R": 10.0}),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--initial", "R=10"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, bogus=1),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--option", "bogus=1"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, columns={"w": "speed"}),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--column", "w=speed"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, select="t=2:3"),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--select", "t=2:3"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, bic_margin=-1),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--bic-margin", "-1"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, min_share=1.5),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--min-share", "1.5"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, max_effects=25),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--max-effects", "25"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, max_evaluations=1.5),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--max-evaluations", "1.5"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, seed=-1),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--seed", "-1"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, threads=1.5),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--threads", "1.5"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, error="bogus"),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--error", "bogus"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, error="equation"),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--error", "equation"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, decimate=0),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--decimate", "0"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, initial_state="x"),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--initial-state", "x"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, resample="fast"),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--resample", "fast"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, resample=0),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--resample", "0"]),
    (lambda: blmd.identify(NOLOAD, NOLOAD_STEP, candidates=["friction"], discover=True),
     ["--config", NOLOAD, "--trace", NOLOAD_STEP, "--candidates", "friction", "--discover"]),
])
def test_identify_bad_input_has_cli_message(call, flags):
    message = cli_error("blmd-ident", *flags)
    with pytest.raises(blmd.InputError) as raised:
        call()
    assert isinstance(raised.value, ValueError)
    assert str(raised.value) == blmd._python_terms(message)


def test_bad_arrays_name_the_trace():
    columns = arrays(NOLOAD_STEP)
    del columns["w"]
    with pytest.raises(blmd.InputError, match=r"^traces\[0\]: missing observed column 'w'"):
        blmd.identify(NOLOAD, [columns])
    columns = arrays(NOLOAD_STEP)
    columns["i"][10] = np.nan
    with pytest.raises(blmd.InputError,
                       match=r"^traces\[0\]:12:3: column 'i' is not a finite number \(nan\)"):
        blmd.identify(NOLOAD, [columns])
    columns = arrays(NOLOAD_STEP)
    columns["t"] = columns["t"][:-1]
    with pytest.raises(blmd.InputError, match="columns must be of one length"):
        blmd.identify(NOLOAD, [columns])


@pytest.mark.parametrize("call, flags", [
    (lambda: blmd.surface(NOLOAD, NOLOAD_STEP, {"Jx": (1e-5, 5e-5, 3)}),
     ["--grid", "Jx=1e-5:5e-5:3"]),
    (lambda: blmd.surface(NOLOAD, NOLOAD_STEP, {"J": (0, 5e-5, 3)}), ["--grid", "J=0:5e-5:3"]),
    (lambda: blmd.surface(NOLOAD, NOLOAD_STEP, {"J": (1e-5, 5e-5, 2000), "B": (1e-5, 1, 2000)}),
     ["--grid", "J=1e-5:5e-5:2000", "--grid", "B=1e-5:1:2000"]),
])
def test_surface_bad_input_has_cli_message(tmp_path, call, flags):
    message = cli_error("blmd-surface", "--config", NOLOAD, "--trace", NOLOAD_STEP, *flags,
                        "--out", tmp_path / "s.csv")
    with pytest.raises(blmd.InputError) as raised:
        call()
    assert str(raised.value) == blmd._python_terms(message)


def test_simulate_bad_input_has_cli_message(tmp_path):
    message = cli_error("blmd-sim", "--config", NOLOAD, "--out", tmp_path / "x.csv", "--noise",
                        "q=1")
    with pytest.raises(blmd.InputError) as raised:
        blmd.simulate(NOLOAD, noise={"q": 1})
    assert str(raised.value) == blmd._python_terms(message)
    bad = load_json(NOLOAD)
    bad["parameters"]["Jx"] = 1.0
    with pytest.raises(blmd.InputError, match=r"^<config>:\d+:\d+: .*'Jx'"):
        blmd.simulate(bad)


# ---- the GIL ----

def test_gil_is_released_during_work():
    # While a sweep runs in another thread, this thread keeps running Python: the longest gap
    # between its iterations stays far below the sweep's duration.
    done = threading.Event()
    elapsed = []

    def work():
        started = time.perf_counter()
        blmd.surface(NOLOAD, NOLOAD_STEP, {"J": ("log", 1e-5, 5e-5, 400)}, threads=1)
        elapsed.append(time.perf_counter() - started)
        done.set()

    worker = threading.Thread(target=work)
    last = time.perf_counter()
    longest = 0.0
    worker.start()
    while not done.is_set():
        now = time.perf_counter()
        longest = max(longest, now - last)
        last = now
    worker.join()
    assert elapsed[0] > 0.2, elapsed  # long enough to tell
    assert longest < elapsed[0] / 2, (longest, elapsed)


# ---- Ctrl-C ----

def test_ctrl_c_stops_a_surface(tmp_path):
    # A sweep of minutes on one thread, interrupted after it started: KeyboardInterrupt within
    # a fraction of a second (the progress callback checks Python's signals), not minutes.
    script = tmp_path / "sweep.py"
    script.write_text(
        "import signal, blmd\n"
        # Python's own handler, even when started with SIGINT ignored (a background job).
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "print('started', flush=True)\n"
        f"blmd.surface({NOLOAD!r}, {NOLOAD_STEP!r}, {{'J': ('log', 1e-5, 5e-5, 8000)}},\n"
        "             threads=1)\n"
        "print('finished', flush=True)\n")
    process = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    assert process.stdout.readline() == "started\n"
    time.sleep(1.0)  # well inside the sweep: reading the trace takes milliseconds
    interrupted = time.perf_counter()
    process.send_signal(signal.SIGINT)
    try:
        stdout, stderr = process.communicate(timeout=60)
    finally:
        process.kill()
    took = time.perf_counter() - interrupted
    assert process.returncode != 0 and "KeyboardInterrupt" in stderr, stderr
    assert "finished" not in stdout
    assert took < 5.0, took


def test_identifications_in_parallel_threads_equal_sequential():
    sequential = [blmd.identify(NOLOAD, NOLOAD_STEP, threads=1),
                  blmd.identify(SQUARE, HIDDEN_COULOMB, threads=1)]
    results = [None, None]

    def run(k, config, trace):
        results[k] = blmd.identify(config, trace, threads=1)

    workers = [threading.Thread(target=run, args=(0, NOLOAD, NOLOAD_STEP)),
               threading.Thread(target=run, args=(1, SQUARE, HIDDEN_COULOMB))]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    for result, expected in zip(results, sequential):
        assert_same_report(result, expected, rel=0.0)


def test_reports_from_arrays_follow_the_report_schema():
    # The report of a fit on arrays, with discovery and a held-out trace, is a valid report
    # (schema/report.schema.json, draft 2020-12).
    jsonschema = pytest.importorskip("jsonschema")
    schema = load_json(repo_path("schema/report.schema.json"))
    report = blmd.identify(SQUARE, [arrays(HIDDEN_COULOMB)], discover=True,
                           candidates=["coulomb_friction", "load_torque"],
                           validate=[arrays(repo_path("testdata/ganesh-square.csv"))])
    # The held-out trace has no friction, so the held-out error refuses the Coulomb term.
    assert report["discovery"]["added"] == []
    assert report["validation"]["traces"] == ["validate[0]"]
    errors = list(jsonschema.Draft202012Validator(schema).iter_errors(report))
    assert errors == []
