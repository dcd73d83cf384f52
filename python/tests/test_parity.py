"""What a SciPy user expects of the package, each against the commands' numbers: identify's
result object (x, params, cov, fitted, residual, effects; still the report dict),
write_config, init_config, tune and design, bounds=, 2-D arrays as traces, and messages in
Python's terms."""

import json

import numpy as np
import pytest

import blmd
from conftest import assert_same_report, cli_error, read_csv, repo_path, run_command

NOLOAD = repo_path("configs/ganesh-noload.json")
NOLOAD_STEP = repo_path("testdata/ganesh-noload-step.csv")
SQUARE = repo_path("configs/ganesh-square.json")
SQUARE_TRACE = repo_path("testdata/ganesh-square.csv")
HIDDEN_COULOMB = repo_path("testdata/dc-hidden-coulomb.csv")
# Discovery restricted to two effects: a few seconds (the full set takes longer).
CANDIDATES = ["coulomb_friction", "load_torque"]


def arrays(path):
    return {name: np.array(values) for name, values in read_csv(path).items()}


def load_json(path):
    with open(path, encoding="utf-8") as file:
        return json.load(file)


def nrmse(measured, simulated, observe):
    """The report's NRMSE: the root of the mean over the observed columns of MSE / variance of
    the measured column (population variance, as the library's)."""
    ratios = [np.mean((measured[c] - simulated[c]) ** 2) / np.var(measured[c]) for c in observe]
    return float(np.sqrt(np.mean(ratios)))


# ---- identify's result ----

def test_identify_result_is_the_report_with_x_params_and_cov(tmp_path):
    report_path = tmp_path / "report.json"
    run_command("blmd-ident", "--config", NOLOAD, "--trace", NOLOAD_STEP, "--report",
                report_path, "--quiet")
    expected = load_json(report_path)
    result = blmd.identify(NOLOAD, NOLOAD_STEP)
    # Still the report: indexing, every field, json.dump.
    assert isinstance(result, dict) and isinstance(result, blmd.IdentifyResult)
    assert_same_report(result, expected)
    assert_same_report(json.loads(json.dumps(result)), expected)
    assert result.report == dict(result)
    assert result.success is True and isinstance(result.message, str) and result.message
    assert result.nfev == expected["fit"]["evaluations"]
    assert result.nit == expected["fit"]["iterations"]
    # x in the order of the report's correlation matrix, params by name.
    names = expected["correlation"]["names"]
    assert result.names == names and set(names) == {"J", "B"}
    assert isinstance(result.x, np.ndarray) and result.x.shape == (2,)
    for k, name in enumerate(names):
        assert result.x[k] == expected["parameters"][name]["value"]
        assert result.params[name] == expected["parameters"][name]["value"]
    # cov = diag(std) corr diag(std): its diagonal gives the report's std, its normalised
    # off-diagonal the report's correlation.
    std = np.array([expected["parameters"][name]["std"] for name in names])
    assert result.cov.shape == (2, 2)
    np.testing.assert_allclose(np.sqrt(np.diag(result.cov)), std, rtol=1e-12, atol=0.0)
    correlation = result.cov / np.outer(std, std)
    np.testing.assert_allclose(correlation, np.array(expected["correlation"]["matrix"]),
                               rtol=1e-12, atol=1e-15)
    assert result.effects == {}


def test_fitted_plus_residual_is_the_measured_trace():
    measured = arrays(NOLOAD_STEP)
    result = blmd.identify(NOLOAD, measured)
    observe = result["fit"]["observe"]
    assert len(result.fitted) == 1 and len(result.residual) == 1
    assert sorted(result.fitted[0]) == sorted(observe) == sorted(result.residual[0])
    for column in observe:
        fitted, residual = result.fitted[0][column], result.residual[0][column]
        assert fitted.shape == measured[column].shape
        np.testing.assert_allclose(fitted + residual, measured[column], rtol=1e-12, atol=1e-12)
        assert np.array_equal(residual, measured[column] - fitted)
    # The library's simulation of the final model: its error is the report's.
    assert nrmse(measured, result.fitted[0], observe) == pytest.approx(result["fit"]["nrmse"],
                                                                       rel=1e-9)


def test_discovered_effects_carry_their_values_and_write_config_round_trips(tmp_path):
    cli_config = tmp_path / "cli.json"
    run_command("blmd-ident", "--config", SQUARE, "--trace", HIDDEN_COULOMB, "--observe", "i,w",
                "--discover", "--candidates", ",".join(CANDIDATES), "--write-config",
                cli_config, "--quiet")
    result = blmd.identify(SQUARE, HIDDEN_COULOMB, observe=["i", "w"], discover=True,
                           candidates=CANDIDATES)
    assert result["discovery"]["added"] == ["coulomb_friction"]
    assert set(result.effects) == {"coulomb_friction"}
    assert result.effects["coulomb_friction"]["Tc"] == result.params["Tc"]
    assert result.params["Tc"] == pytest.approx(0.012, rel=0.05)  # the hidden effect's truth
    # The final model's three free parameters: x, cov as the report's headline.
    assert result.names == result["correlation"]["names"] == ["J", "B", "Tc"]
    std = np.array([result["parameters"][name]["std"] for name in result.names])
    np.testing.assert_allclose(np.sqrt(np.diag(result.cov)), std, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(result.cov / np.outer(std, std),
                               np.array(result["correlation"]["matrix"]), rtol=1e-12, atol=1e-15)
    # blmd-ident --write-config's document, number for number.
    path = tmp_path / "written.json"
    written = blmd.write_config(result, path)
    assert load_json(path) == written
    assert_same_report(written, load_json(cli_config))
    # The written model, simulated on the trace's input, has the report's final error.
    measured = arrays(HIDDEN_COULOMB)
    replay = blmd.simulate(written, input={"t": measured["t"], "u": measured["u"]})
    assert nrmse(measured, replay, ["i", "w"]) == pytest.approx(result["fit"]["nrmse"],
                                                                rel=1e-9)
    # A report without its result (e.g. read back from a file) and the config that was fitted.
    from_report = blmd.write_config(json.loads(json.dumps(result)), base_config=SQUARE)
    assert from_report["parameters"] == written["parameters"]
    assert from_report["effects"] == written["effects"]
    with pytest.raises(blmd.InputError, match="base_config"):
        blmd.write_config(json.loads(json.dumps(result)))


def test_init_config_equals_blmd_sim_init_config(tmp_path):
    for model in ("dc_servo", "blmd", "rigid_load"):
        stdout, _ = run_command("blmd-sim", "--init-config", model)
        path = tmp_path / f"{model}.json"
        config = blmd.init_config(model, path)
        assert config == json.loads(stdout)
        assert path.read_text() == stdout
    with pytest.raises(blmd.InputError, match=r"^init_config: .*dc_servo"):
        blmd.init_config("dc_motor")


# ---- tune and design: the commands' reports ----

VOLATILE_PATHS = {"wall_time_s", "path", "sha256", "from_report", "config_notes", "notes"}


def test_tune_equals_blmd_tune(tmp_path):
    fit = tmp_path / "fit.json"
    run_command("blmd-ident", "--config", SQUARE, "--trace", SQUARE_TRACE, "--report", fit,
                "--quiet")
    flags = ["--loop", "speed", "--crossover", 3, "--phase-margin", 60, "--limit", "u=24",
             "--limit", "i=4"]
    out = tmp_path / "tune.json"
    closed = tmp_path / "closed.json"
    run_command("blmd-tune", "--config", SQUARE, "--from-report", fit, *flags, "--report", out,
                "--write-config", closed, "--quiet")
    expected = load_json(out)
    tuned = blmd.tune(SQUARE, report=fit, loop="speed", crossover=3, phase_margin=60,
                      limits={"u": 24, "i": 4})
    assert isinstance(tuned, dict) and tuned.success
    assert_same_report(tuned, expected)
    assert_same_report(tuned.config, load_json(closed))
    assert tuned["controller"]["kp"] == expected["controller"]["kp"]
    # The report as a dict (an IdentifyResult is one): the same gains.
    in_memory = blmd.tune(SQUARE, report=blmd.identify(SQUARE, SQUARE_TRACE), loop="speed",
                          crossover=3, phase_margin=60, limits=["u=24", "i=4"])
    assert_same_report(in_memory, expected, ignore=VOLATILE_PATHS)
    # Any other flag by its name, parsed by the command's own flag set.
    stepped = blmd.tune(SQUARE, report=fit, loop="speed", crossover=3, phase_margin=60,
                        limits={"u": 24}, step=5.0)
    run_command("blmd-tune", "--config", SQUARE, "--from-report", fit, "--loop", "speed",
                "--crossover", 3, "--phase-margin", 60, "--limit", "u=24", "--step", 5,
                "--report", out, "--quiet")
    assert_same_report(stepped, load_json(out))


TWO_MASS = {
    "name": "two-mass", "model": "rigid_load",
    "parameters": {"J": 2e-3, "B": 0.04, "Kt": 0.5},
    "effects": {"two_mass": {"inertia_ratio": 1.5, "anti_resonance_hz": 40,
                             "shaft_damping_ratio": 0.02, "load_damping_share": 0.0}},
    "experiment": {"input": {"type": "step", "amplitude": 1}, "duration": 1}}


def test_identify_from_the_reference_equals_blmd_ident(tmp_path):
    """simulate_from= is --simulate-from: a closed-loop record fitted from its reference r."""
    truth = dict(TWO_MASS, name="loop", effects={})
    truth["simulation"] = {"dt": 1e-4}
    truth["experiment"] = {"input": {"type": "square", "amplitude": 20, "period": 0.5},
                           "duration": 2, "sample_rate": 1000,
                           "pid": {"loop": "speed", "Kp": 0.3, "Ki": 6, "u_max": 50,
                                   "sample_rate": 1000, "delay": 1}}
    truth["identification"] = {"free": ["J", "B"], "observe": ["w"]}
    config = tmp_path / "loop.json"
    config.write_text(json.dumps(truth))
    trace = tmp_path / "loop.csv"
    run_command("blmd-sim", "--config", config, "--out", trace, "--noise", "w=1%", "--seed", 3,
                "--quiet")
    out = tmp_path / "ident.json"
    run_command("blmd-ident", "--config", config, "--trace", trace, "--simulate-from",
                "reference", "--report", out, "--quiet")
    fitted = blmd.identify(config, trace, simulate_from="reference")
    assert_same_report(fitted, load_json(out), ignore=VOLATILE_PATHS)
    assert any("identified from the reference" in n for n in fitted["notes"])
    with pytest.raises(blmd.InputError, match=r"^simulate_from: sometimes not in"):
        blmd.identify(config, trace, simulate_from="sometimes")


def test_tune_notch_equals_blmd_tune(tmp_path):
    """notch= is --notch: the notch designed at the resonance (auto) and the refusal (off)."""
    config = tmp_path / "two-mass.json"
    config.write_text(json.dumps(TWO_MASS))
    out = tmp_path / "tune.json"
    flags = ["--loop", "speed", "--crossover", 20, "--phase-margin", 60, "--limit", "u=5",
             "--sample-rate", 1000]
    run_command("blmd-tune", "--config", config, *flags, "--report", out, "--quiet")
    tuned = blmd.tune(config, loop="speed", crossover=20, phase_margin=60, limits={"u": 5},
                      sample_rate=1000, notch="auto")
    assert_same_report(tuned, load_json(out))
    assert tuned["sampled_loop"]["notch"]["source"] == "designed"
    assert tuned.config["experiment"]["pid"]["notch"]["frequency"] == \
        tuned["sampled_loop"]["notch"]["frequency_hz"]
    done = run_command("blmd-tune", "--config", config, *flags, "--notch", "off", expect=1)
    with pytest.raises(blmd.FitError) as raised:
        blmd.tune(config, loop="speed", crossover=20, phase_margin=60, limits={"u": 5},
                  sample_rate=1000, notch="off")
    assert "error: " + str(raised.value) == done[1].strip()
    with pytest.raises(blmd.InputError, match=r"notch"):
        blmd.tune(config, loop="speed", crossover=20, phase_margin=60, limits={"u": 5},
                  sample_rate=1000, notch="sometimes")


def test_tune_refusal_and_bad_input(tmp_path):
    flags = ["--loop", "speed", "--crossover", 3000, "--phase-margin", 60, "--limit", "u=24"]
    done = run_command("blmd-tune", "--config", SQUARE, *flags, expect=1)
    with pytest.raises(blmd.FitError) as raised:
        blmd.tune(SQUARE, loop="speed", crossover=3000, phase_margin=60, limits={"u": 24})
    assert "error: " + str(raised.value) == done[1].strip()
    assert str(raised.value).startswith("cannot tune: ")
    with pytest.raises(blmd.InputError, match=r"^phase_margin is required"):
        blmd.tune(SQUARE, loop="speed", crossover=3, limits={"u": 24})
    with pytest.raises(TypeError):
        blmd.tune(SQUARE, loop="speed", crossover=3, phase_margin=60, write_config="x.json")
    # A keyword that is no flag of the command: Python's TypeError, naming it.
    with pytest.raises(TypeError, match=r"unknown option\(s\) bogus "):
        blmd.tune(SQUARE, loop="speed", crossover=3, phase_margin=60, limits={"u": 24}, bogus=2)
    with pytest.raises(blmd.InputError, match=r"^integral_ratio applies to the position loop"):
        blmd.tune(SQUARE, loop="speed", crossover=3, phase_margin=60, limits={"u": 24},
                  integral_ratio=2)


def test_design_equals_blmd_design(tmp_path):
    out = tmp_path / "design.json"
    chosen = tmp_path / "chosen.json"
    run_command("blmd-design", "--config", SQUARE, "--duration", 1, "--limit", "u=12",
                "--noise", "i=0.014", "--noise", "w=2.5", "--family", "square", "--report",
                out, "--write-config", chosen, "--quiet")
    expected = load_json(out)
    designed = blmd.design(SQUARE, duration=1, limits={"u": 12}, noise={"i": 0.014, "w": 2.5},
                           family="square")
    assert designed.success
    assert_same_report(designed, expected)
    assert_same_report(designed.config, load_json(chosen))
    message = cli_error("blmd-design", "--config", SQUARE, "--duration", 1, "--noise", "i=0.01",
                        "--noise", "w=2")
    with pytest.raises(blmd.InputError) as raised:
        blmd.design(SQUARE, duration=1, noise={"i": 0.01, "w": 2})
    assert str(raised.value) == blmd._python_terms(message)
    assert "--" not in str(raised.value) and "limits={'u': V}" in str(raised.value)


# ---- arguments ----

def test_bounds_are_the_configs_identification_bounds(tmp_path):
    config = load_json(NOLOAD)
    config["identification"]["bounds"] = {"J": [1e-7, 2.0e-5], "B": [1e-8, 1e-2]}
    path = tmp_path / "bounded.json"
    path.write_text(json.dumps(config))
    report_path = tmp_path / "report.json"
    run_command("blmd-ident", "--config", path, "--trace", NOLOAD_STEP, "--report",
                report_path, "--quiet")
    expected = load_json(report_path)
    result = blmd.identify(NOLOAD, NOLOAD_STEP, bounds={"J": (1e-7, 2.0e-5)})
    assert result["parameters"]["J"]["bounds"] == [1e-7, 2.0e-5]
    assert result.params["J"] <= 2.0e-5  # the truth, 2.26e-5, lies above the bound
    assert_same_report(result, expected, ignore={"path", "sha256"})
    with pytest.raises(blmd.InputError, match=r"identification\.bounds"):
        blmd.identify(NOLOAD, NOLOAD_STEP, bounds={"J": 1e-5})


def test_two_d_arrays_are_the_same_fit_as_columns():
    columns = arrays(NOLOAD_STEP)
    names = list(columns)
    table = np.column_stack([columns[name] for name in names])
    by_columns = blmd.identify(NOLOAD, columns)
    by_table = blmd.identify(NOLOAD, table, columns=names)
    assert_same_report(by_table, by_columns, rel=0.0)
    structured = np.zeros(table.shape[0], dtype=[(name, "f8") for name in names])
    for name in names:
        structured[name] = columns[name]
    assert_same_report(blmd.identify(NOLOAD, structured), by_columns, rel=0.0)
    with pytest.raises(blmd.InputError, match=r"columns=\["):
        blmd.identify(NOLOAD, table)
    grid = {"J": ("log", 1e-5, 5e-5, 5)}
    assert np.array_equal(blmd.surface(NOLOAD, table, grid, columns=names)["cost"],
                          blmd.surface(NOLOAD, columns, grid)["cost"])


def test_errors_are_in_python_terms():
    columns = arrays(NOLOAD_STEP)
    del columns["w"]
    with pytest.raises(blmd.InputError) as raised:
        blmd.identify(NOLOAD, columns)
    message = str(raised.value)
    assert "columns={'w': HEADER}" in message and "--" not in message, message
    with pytest.raises(blmd.InputError) as raised:
        blmd.identify(NOLOAD, NOLOAD_STEP, observe=["q"])
    assert str(raised.value).startswith("observe: 'q' is not an output"), str(raised.value)
    with pytest.raises(blmd.InputError,
                       match=r": no row matches select='t=2:3' \('t' holds 0 \.\.\. 1\)$"):
        blmd.identify(NOLOAD, NOLOAD_STEP, select="t=2:3")
    with pytest.raises(blmd.InputError, match=r": columns=\{'w': 'speed'\}: no column 'speed'"):
        blmd.identify(NOLOAD, NOLOAD_STEP, columns={"w": "speed"})


def test_tune_and_design_write_no_file_for_dicts(monkeypatch):
    # A config, a report and a recorded input given in memory reach the library as they are:
    # no temporary file is made (every way the package could make one fails the test).
    import tempfile

    def refuse(*args, **kwargs):
        raise AssertionError("a temporary file was made")

    for name in ("mkstemp", "mkdtemp", "NamedTemporaryFile", "TemporaryDirectory"):
        monkeypatch.setattr(tempfile, name, refuse)
    config = load_json(SQUARE)
    fit = blmd.identify(config, SQUARE_TRACE)
    tuned = blmd.tune(config, report=dict(fit), loop="speed", crossover=3, phase_margin=60,
                      limits={"u": 24})
    assert tuned.success and tuned["from_report"]["path"] == "<report>"
    trace = read_csv(SQUARE_TRACE)
    designed = blmd.design(config, report=fit, trace={"t": trace["t"], "u": trace["u"],
                                                      "i": trace["i"], "w": trace["w"]},
                           noise={"i": 0.014, "w": 2.5})
    assert designed.success and designed.config is None
    assert designed["from_report"]["path"] == "<report>"


def test_tune_takes_the_flags_own_names_and_number_texts():
    # The command's flag names (limit=) and numbers as text (as the flags take them) give the
    # same gains; a keyword that is no option of the command is a TypeError naming it.
    plain = blmd.tune(SQUARE, loop="speed", crossover=3, phase_margin=60, limits={"u": 24})
    aliased = blmd.tune(SQUARE, loop="speed", crossover="3", phase_margin="60", limit=["u=24"],
                        fail_on_warning=True)
    assert aliased["controller"]["kp"] == plain["controller"]["kp"]
    with pytest.raises(TypeError, match=r"limits and limit name the same option"):
        blmd.tune(SQUARE, loop="speed", crossover=3, phase_margin=60, limits={"u": 24},
                  limit=["u=24"])
    with pytest.raises(blmd.InputError, match=r"^crossover: must be a number > 0, not 'x'"):
        blmd.tune(SQUARE, loop="speed", crossover="x", phase_margin=60, limits={"u": 24})
    with pytest.raises(blmd.InputError, match=r"^limits: expected a dict"):
        blmd.tune(SQUARE, loop="speed", crossover=3, phase_margin=60, limits=24)
