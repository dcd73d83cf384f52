"""Identify a motor's inertia J and damping B (and any other parameter) from recorded traces.

The same library as the commands blmd-sim, blmd-ident and blmd-surface, called in process
(docs/python.md):

- simulate(config, input=None, noise=None, seed=1) -> dict of NumPy arrays, as blmd-sim;
- identify(config, traces, ...) -> the report of blmd-ident --report, as a dict;
- surface(config, traces, grid, ...) -> the cost over a grid, as blmd-surface.

Bad input raises InputError (a ValueError) with the commands' one-line message; a diverged
simulation or a fit that did not converge raises FitError (a RuntimeError).
"""

import json
import numbers
import os
import warnings

import numpy as np

from . import _blmd
from ._blmd import InputError

__all__ = ["simulate", "identify", "surface", "InputError", "FitError", "__version__"]
__version__ = _blmd.__version__
InputError.__module__ = __name__
InputError.__doc__ = (
    "Bad input (config, trace, argument): the commands' exit 2. A ValueError whose message "
    "is the commands' one line (without 'error: ').")


class FitError(RuntimeError):
    """The work failed (the commands' exit 1): a simulation diverged, or the fit did not
    converge. For identify, `report` holds the report all the same (else None)."""

    def __init__(self, message, report=None):
        super().__init__(message)
        self.report = report


# The most worker threads the library uses (--threads caps at it, with a note).
_MAX_THREADS = 256


# ---- Python values -> the flags' text forms (app/request.h reads those) ----

def _number_text(value):
    """A number as a flag would take it; floats round-trip exactly (repr)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        return repr(float(value))
    return str(value)


def _names_text(value):
    """None (not given), or the names joined by ',' ("i,w"); a string is taken as it is."""
    if value is None:
        return None
    if isinstance(value, str):
        return value
    return ",".join(str(name) for name in value)


def _assignments(value, flag):
    """A mapping NAME -> VALUE (or NAME=VALUE strings) as the texts of a repeatable flag."""
    if value is None:
        return []
    if isinstance(value, str):
        return [value]
    if _is_mapping(value):
        return [f"{name}={_number_text(value[name])}" for name in value.keys()]
    try:
        return [str(item) for item in value]
    except TypeError:
        raise InputError(f"{flag}: expected a dict NAME -> VALUE, not {type(value).__name__}")


def _is_mapping(value):
    # dict, and whatever quacks like one (a pandas DataFrame: keys() and [name]).
    return hasattr(value, "keys") and hasattr(value, "__getitem__")


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON")


def _config_arg(config):
    """(path, None) for a file, ("<config>", JSON text) for a dict (messages name <config>
    with the line:column of json.dumps(config, indent=2))."""
    if isinstance(config, (str, os.PathLike)):
        return (os.fspath(config), None)
    if _is_mapping(config):
        return ("<config>", json.dumps(dict(config), indent=2, default=_json_default))
    raise TypeError(f"config: expected a path or a dict, not {type(config).__name__}")


def _columns(value):
    """A mapping column -> 1-D array as {name: float64 array}; columns that are not numbers
    (a text timestamp, a state name) are left out, as the commands leave out a CSV's text
    columns."""
    columns = {}
    for name in value.keys():
        try:
            columns[str(name)] = np.asarray(value[name], dtype=np.float64)
        except (TypeError, ValueError):
            continue
    return columns


def _trace_arg(value, name):
    """A path (str) or (name, columns) for the extension."""
    if isinstance(value, (str, os.PathLike)):
        return os.fspath(value)
    if _is_mapping(value):
        return (name, _columns(value))
    raise TypeError(f"{name}: expected a CSV path or a mapping column -> array, "
                    f"not {type(value).__name__}")


def _trace_list(value, what):
    if value is None:
        return []
    if isinstance(value, (str, os.PathLike)) or _is_mapping(value):
        value = [value]
    return [_trace_arg(item, f"{what}[{k}]") for k, item in enumerate(value)]


def _choice(value, flag, valid):
    if value is None:
        return ""
    if value not in valid:
        raise InputError(f"{flag}: {value} not in {{{','.join(valid)}}}")
    return value


def _whole(value, flag, low=0, high=None):
    ok = isinstance(value, numbers.Integral) and not isinstance(value, bool) and value >= low
    if ok and high is not None:
        ok = value <= high
    if not ok:
        if high is None:
            raise InputError(f"{flag}: must be a whole number >= {low}, not {value}")
        raise InputError(f"{flag}: Value {value} not in range {low} to {high}")
    return int(value)


def _integer(value, flag):
    """Any whole number, as the flags that take an int without a range check."""
    if not isinstance(value, numbers.Integral) or isinstance(value, bool):
        raise InputError(f"Could not convert: {flag} = {value}")
    return int(value)


def _positive(value, flag):
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if not ok or not (float(value) > 0.0) or not np.isfinite(float(value)):
        raise InputError(f"{flag}: must be a number > 0, not {value}")
    return float(value)


def _share(value, flag):
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if not ok or not (0.0 <= float(value) <= 1.0):
        raise InputError(f"{flag}: must be a number in [0, 1], not {value}")
    return float(value)


def _threads(value):
    threads = _whole(value, "--threads")
    if threads > _MAX_THREADS:
        warnings.warn(f"threads={threads} is more than {_MAX_THREADS}: using {_MAX_THREADS}")
        threads = _MAX_THREADS
    return threads


def _delimiter(value):
    if value == "\t":
        value = "tab"
    return _choice(value, "--delimiter", [",", ";", "tab"])


def _error_settings(settings, error, filter_hz, decimate):
    settings.kind = _choice(error, "--error", ["output", "equation"])
    if filter_hz is not None:
        settings.filter_hz = _positive(filter_hz, "--filter-hz")
    if decimate is not None:
        settings.decimate = _whole(decimate, "--decimate", 1, 1000)


def _trace_settings(settings, columns, scales, derive, select, split, initial_state, delimiter,
                    duplicate_time):
    settings.delimiter = _delimiter(delimiter)
    settings.duplicate_time = _choice(duplicate_time, "--duplicate-time",
                                      ["error", "first", "mean"])
    settings.columns = _assignments(columns, "--column")
    settings.scales = _assignments(scales, "--scale")
    settings.derives = _assignments(derive, "--derive")
    settings.selects = [select] if isinstance(select, str) else list(select or [])
    settings.split = split or ""
    settings.initial_state = _choice(initial_state, "--initial-state", ["config", "trace"]) or \
        "config"


# ---- the API ----

def simulate(config, input=None, noise=None, seed=1, *, effects=None, delimiter=None,
             duplicate_time=None):
    """Simulates the config's model and experiment, as blmd-sim.

    config: a path or a dict (the config JSON). input: None (the config's experiment), a
    CSV path or a mapping with 't' and 'u' arrays (and 'open' for a dc_servo coast-down):
    the model is driven by u held between samples and sampled at t (blmd-sim --input).
    noise: {column: sigma} with sigma in column units, or "P%" of the column's peak |value|
    (blmd-sim --noise; or the flag's texts, ["i=1%"]), added in order from one generator
    seeded with `seed`.
    effects: {name: {parameter: value}} effects the config does not declare (--effect).
    Returns {column: numpy array} in the CSV's column order (t first).
    """
    if noise is None or _is_mapping(noise):
        noise_specs = [f"{column}={sigma if isinstance(sigma, str) else _number_text(sigma)}"
                       for column, sigma in (noise or {}).items()]
    else:  # the flag's own texts, "i=1%"
        noise_specs = [noise] if isinstance(noise, str) else [str(spec) for spec in noise]
    effect_specs = []
    if _is_mapping(effects):
        for name, values in effects.items():
            effect_specs.append(name + ":" + ",".join(
                f"{key}={_number_text(value)}" for key, value in values.items()))
    elif effects is not None:
        effect_specs = [effects] if isinstance(effects, str) else list(effects)
    dialect = _blmd.DialectSettings()
    dialect.delimiter = _delimiter(delimiter)
    dialect.duplicate_time = _choice(duplicate_time, "--duplicate-time",
                                     ["error", "first", "mean"])
    input_arg = None if input is None else _trace_arg(input, "input")
    names, columns, failure = _blmd.simulate(_config_arg(config), effect_specs, noise_specs,
                                             _whole(seed, "--seed"), input_arg, dialect)
    if failure:
        raise FitError(failure)
    return dict(zip(names, columns))


def identify(config, traces, method=None, discover=False, candidates=None, observe=None,
             validate=None, seed=1, threads=0, *, free=None, initial=None, max_evaluations=0,
             bic_margin=10.0, min_share=0.1, max_effects=3, error=None, filter_hz=None, decimate=None,
             columns=None, scales=None, derive=None, select=None, split=None,
             initial_state="config", delimiter=None, duplicate_time=None, verbose=False,
             baseline=None, **options):
    """Identifies the free parameters, as blmd-ident; returns its --report JSON as a dict.

    config: a path or a dict. traces: a CSV path or a mapping column -> 1-D array (a pandas
    DataFrame works), or a list of them (one fit over all). method: 'ceres', 'powell', 'fsd'
    or 'classic' (None: the config's, else ceres). discover: find the effects the model
    lacks and refit (--discover), candidates restricting them. observe, free: lists of
    names (None: the config's). validate: held-out traces. initial: {name: start value}.
    Every other keyword is a method option (--option KEY=VALUE), e.g. algorithm='praxis'.
    The keyword-only arguments are blmd-ident's flags of the same name (docs/cli.md §2).
    baseline: a stored report (a path) whose free parameters this fit is compared with, as
    blmd-ident --baseline; the comparison is the report's "baseline" entry.
    Raises InputError for bad input and FitError when the fit did not converge (its
    `report` attribute holds the report).
    """
    settings = _blmd.IdentSettings()
    settings.baseline = "" if baseline is None else os.fspath(baseline)
    settings.method = method or ""
    settings.discover = bool(discover)
    settings.candidates = _names_text(candidates)
    settings.observe = _names_text(observe)
    settings.free = _names_text(free)
    settings.initials = _assignments(initial, "--initial")
    settings.method_options = [f"{key}={_number_text(value)}" for key, value in options.items()]
    settings.seed = _whole(seed, "--seed")
    settings.threads = _threads(threads)
    settings.max_evaluations = _integer(max_evaluations, "--max-evaluations")
    settings.bic_margin = _positive(bic_margin, "--bic-margin")
    settings.min_share = _share(min_share, "--min-share")
    settings.max_effects = _whole(max_effects, "--max-effects", 1, 20)
    settings.verbose = bool(verbose)
    _error_settings(settings.error, error, filter_hz, decimate)
    _trace_settings(settings.preparation, columns, scales, derive, select, split, initial_state,
                    delimiter, duplicate_time)
    text, converged, termination = _blmd.identify(
        _config_arg(config), settings, _trace_list(traces, "traces"),
        _trace_list(validate, "validate"))
    report = json.loads(text)
    if not converged:
        raise FitError("the fit did not converge: " + termination, report)
    return report


def _grid_text(name, spec):
    if isinstance(spec, str):
        return f"{name}={spec}"
    return f"{name}=" + ":".join(
        item if isinstance(item, str) else _number_text(item) for item in spec)


def surface(config, traces, grid, observe=None, threads=0, *, force=False, error=None,
            filter_hz=None, decimate=None, columns=None, scales=None, derive=None,
            select=None, split=None, initial_state="config", delimiter=None,
            duplicate_time=None):
    """The cost over a 1-D or 2-D grid of parameters, as blmd-surface.

    traces: one trace (a CSV path or a mapping column -> array; a list of one is accepted;
    split= cuts it into experiments). grid: {"J": (lo, hi, n), "B": ("log", lo, hi, n)}
    (or "log:lo:hi:n" strings), the first axis outermost. Returns a dict: "axes" (names),
    "grid" {name: values}, "cost" (shape (n1,) or (n1, n2); inf where the simulation failed),
    "mse" {column: array of that shape}, "observe", "minimum" and "local_minima"
    ({name: value, ..., "cost": c}), "failed_points", "failure_reasons", and "csv" (the
    text blmd-surface --out writes).
    """
    trace_args = _trace_list(traces, "traces")
    if len(trace_args) != 1:
        raise InputError(f"--trace: one trace (got {len(trace_args)}); cut one file into "
                         "experiments with split=COLUMN")
    if not _is_mapping(grid):
        raise TypeError("grid: expected a dict name -> (lo, hi, n) or ('log', lo, hi, n)")
    settings = _blmd.SweepSettings()
    settings.grids = [_grid_text(name, spec) for name, spec in grid.items()]
    settings.observe = _names_text(observe)
    settings.threads = _threads(threads)
    settings.force = bool(force)
    _error_settings(settings.error, error, filter_hz, decimate)
    _trace_settings(settings.preparation, columns, scales, derive, select, split, initial_state,
                    delimiter, duplicate_time)
    raw = _blmd.surface(_config_arg(config), settings, trace_args[0])
    axes = list(raw["names"])
    shape = tuple(len(values) for values in raw["values"])
    cost = raw["cost"].reshape(shape)

    def point(flat_index):
        index = np.unravel_index(flat_index, shape)
        out = {name: float(raw["values"][a][index[a]]) for a, name in enumerate(axes)}
        out["cost"] = float(raw["cost"][flat_index])
        return out

    return {
        "axes": axes,
        "grid": {name: raw["values"][a] for a, name in enumerate(axes)},
        "log": {name: bool(raw["log"][a]) for a, name in enumerate(axes)},
        "observe": list(raw["observe"]),
        "cost": cost,
        "mse": {column: raw["mse"][:, c].reshape(shape)
                for c, column in enumerate(raw["observe"])},
        "minimum": None if raw["best"] is None else point(raw["best"]),
        "local_minima": [point(k) for k in raw["minima"]],
        "failed_points": int(raw["failed"]),
        "failure_reasons": dict(raw["failure_reasons"]),
        "csv": raw["csv"],
        "wall_time_s": raw["wall_time_s"],
    }
