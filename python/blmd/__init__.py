"""Identify a motor's inertia J and damping B (and any other parameter) from recorded traces.

The same library as the commands blmd-sim, blmd-ident, blmd-surface, blmd-tune and
blmd-design, called in process (docs/python.md):

- simulate(config, input=None, noise=None, seed=1) -> dict of NumPy arrays, as blmd-sim;
- identify(config, traces, ...) -> an IdentifyResult: the report of blmd-ident --report (it is
  that dict) with x, params, cov, success, message, fitted, residual and effects;
- write_config(result, path=None) -> the config of the identified model (--write-config);
- init_config(model) -> a starting config (blmd-sim --init-config);
- surface(config, traces, grid, ...) -> the cost over a grid, as blmd-surface;
- tune(config, report, loop, crossover, phase_margin, ...) -> blmd-tune's report;
- design(config, duration, limits, noise, ...) -> blmd-design's report.

Bad input raises InputError (a ValueError) with the commands' one-line message; a diverged
simulation or a fit that did not converge raises FitError (a RuntimeError).
"""

import copy
import functools
import json
import numbers
import os
import re
import tempfile
import warnings

import numpy as np

from . import _blmd
from ._blmd import InputError
from . import fleet  # noqa: E402  (blmd.fleet.run; Dask is imported only when it runs)

__all__ = ["simulate", "identify", "surface", "write_config", "init_config", "tune", "design",
           "IdentifyResult", "TuneResult", "DesignResult", "InputError", "FitError", "fleet",
           "__version__"]
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


# ---- messages in Python's terms ----

# The flags whose keyword is not the flag's name with '_' for '-'.
_KEYWORD_OF_FLAG = {"column": "columns", "scale": "scales", "trace": "traces",
                    "effect": "effects", "limit": "limits", "from-report": "report",
                    "option": "options", "init-config": "init_config"}


def _keyword(flag, renames=None):
    if renames and flag in renames:
        return renames[flag]
    return _KEYWORD_OF_FLAG.get(flag, flag.replace("-", "_"))


def _value_text(text):
    """A flag's value as Python: a number or a placeholder (HEADER) as it is, else quoted."""
    if text[:1] in "'\"":
        return text
    try:
        float(text)
        return text
    except ValueError:
        return text if text.isupper() else repr(text)


# Words that follow a flag in a sentence ("--duration is required") rather than its value.
_NOT_A_VALUE = ("is", "or", "and", "to", "of", "with", "for", "applies", "needs", "prints",
                "takes", "keeps", "not", "from", "=")


def _python_terms(message, renames=None):
    """The library's message (shared with the commands) with each flag named by the keyword
    argument that sets it: "--column i=HEADER" -> "columns={'i': HEADER}", "--scale w=0.1"
    -> "scales={'w': 0.1}", "--observe: ..." -> "observe: ...", "--error equation" ->
    "error='equation'". A Python user never typed a flag. `renames`: {flag: keyword} where a
    function names a flag otherwise (design's trace=)."""
    def mapping(match):
        flag, name, value = match.group(1), match.group(2), match.group(3)
        if value is None:
            return f"{_keyword(flag, renames)}[{name!r}]"
        return f"{_keyword(flag, renames)}={{{name!r}: {_value_text(value)}}}"

    message = re.sub(r"(?<![\w-])--(column|scale|initial|limit|noise) (\w+)(?:=([^\s:),;]+))?",
                     mapping, message)

    def flag(match):
        name, value = match.group(1), match.group(2)
        if value is None:
            return _keyword(name, renames)
        return f"{_keyword(name, renames)}={_value_text(value)}"

    words = "|".join(re.escape(word) + (" " if word != "=" else "") for word in _NOT_A_VALUE)
    # A value: up to a space, a comma, a closing bracket, or a colon that ends a prefix
    # ("--select t=2:3: no row" keeps "t=2:3").
    return re.sub(r"(?<![\w-])--([a-z][a-z0-9-]*)(?: (?!" + words + r")"
                  r"((?:[^\s,():]|:(?=[^\s]))+))?", flag, message)


def _in_python_terms(function=None, renames=None):
    """InputError raised by `function` with its message in Python's terms."""
    def decorate(function):
        @functools.wraps(function)
        def wrapped(*args, **kwargs):
            try:
                return function(*args, **kwargs)
            except InputError as error:
                text = str(error)
                translated = _python_terms(text, renames)
                if translated == text:
                    raise
                raise InputError(translated) from None
        return wrapped
    return decorate(function) if function is not None else decorate


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


def _array_columns(value, name, names):
    """A structured array (its field names) or a 2-D (n, k) array with `names` (one per
    column) as {name: column}."""
    if value.dtype.names:
        return {field: value[field] for field in value.dtype.names}
    if value.ndim != 2:
        raise InputError(f"{name}: a {value.ndim}-D array; a trace is a 2-D (samples, columns) "
                         "array with columns=[names], a structured array or a dict of columns")
    if names is None:
        raise InputError(f"{name}: a 2-D array of {value.shape[1]} columns needs their names: "
                         "columns=['t', 'u', ...], one per column")
    if len(names) != value.shape[1]:
        raise InputError(f"{name}: {len(names)} names in columns= for the array's "
                         f"{value.shape[1]} columns")
    return {str(column): value[:, k] for k, column in enumerate(names)}


def _trace_arg(value, name, array_names=None):
    """A path (str) or (name, columns) for the extension."""
    if isinstance(value, (str, os.PathLike)):
        return os.fspath(value)
    if _is_mapping(value):
        return (name, _columns(value))
    if isinstance(value, np.ndarray):
        return (name, _columns(_array_columns(value, name, array_names)))
    raise TypeError(f"{name}: expected a CSV path, a mapping column -> array or a 2-D array, "
                    f"not {type(value).__name__}")


def _trace_list(value, what, array_names=None):
    if value is None:
        return []
    if isinstance(value, (str, os.PathLike, np.ndarray)) or _is_mapping(value):
        value = [value]
    return [_trace_arg(item, f"{what}[{k}]", array_names) for k, item in enumerate(value)]


def _split_columns(columns):
    """identify's columns=: a mapping (or NAME=HEADER texts) maps standard columns to a CSV's
    headers (--column); a list of plain names names the columns of 2-D array traces.
    Returns (header mapping, array column names)."""
    if columns is None or isinstance(columns, str) or _is_mapping(columns):
        return columns, None
    names = [str(name) for name in columns]
    if any("=" in name for name in names):
        return names, None
    return None, names


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
    if isinstance(value, str):  # a number's text, as the command's flag takes it
        try:
            value = float(value)
        except ValueError:
            raise InputError(f"{flag}: must be a number > 0, not {value!r}") from None
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if not ok or not (float(value) > 0.0) or not np.isfinite(float(value)):
        raise InputError(f"{flag}: must be a number > 0, not {value!r}")
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


def _error_settings(settings, error, filter_hz, decimate, simulate_from=None):
    settings.kind = _choice(error, "--error", ["output", "equation"])
    settings.simulate_from = _choice(simulate_from, "--simulate-from", ["command", "reference"])
    if filter_hz is not None:
        settings.filter_hz = _positive(filter_hz, "--filter-hz")
    if decimate is not None:
        settings.decimate = _whole(decimate, "--decimate", 1, 1000)


def _resample(value):
    """resample=: None (as recorded), "auto" (the median step) or a step in seconds."""
    if value is None:
        return ""
    if isinstance(value, str):
        return value
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if not ok:
        raise InputError(f"--resample: expected a step in seconds > 0, or auto (the median "
                         f"step), not {value!r}")
    return _number_text(value)


def _trace_settings(settings, columns, scales, derive, select, split, initial_state, delimiter,
                    duplicate_time, resample):
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
    settings.resample = _resample(resample)


def _with_bounds(config, bounds):
    """A copy of the config (a dict; a path is read) with identification.bounds[name] set to
    [lo, hi] for each entry of `bounds`: the library checks them as it checks the file's."""
    if not bounds:
        return config
    if not _is_mapping(bounds):
        raise TypeError("bounds: expected a dict name -> (lo, hi), as the config's "
                        "identification.bounds")
    if isinstance(config, (str, os.PathLike)):
        with open(os.fspath(config), encoding="utf-8") as file:
            config = json.load(file)
    elif _is_mapping(config):
        config = copy.deepcopy(dict(config))
    else:
        raise TypeError(f"config: expected a path or a dict, not {type(config).__name__}")
    identification = config.setdefault("identification", {})
    merged = dict(identification.get("bounds") or {})
    for name, pair in bounds.items():
        try:
            low, high = pair
        except (TypeError, ValueError):
            raise InputError(f"bounds[{name!r}]: expected (lo, hi), as the config's "
                             f"identification.bounds, not {pair!r}") from None
        merged[str(name)] = [low, high]
    identification["bounds"] = merged
    return config


class IdentifyResult(dict):
    """The outcome of blmd.identify, in SciPy's habits, that is also the report.

    As a dict it is the report of blmd-ident --report (result["parameters"]["J"]["value"]),
    so code that indexed the report keeps working. Its attributes:

    x: float64 array, the final model's free parameters in the order of `names` (that of the
        report's correlation matrix);
    names: the free parameters' names;
    params: {name: value} of the free parameters;
    cov: the covariance the 95 % intervals stand for, rows and columns in the order of x:
        diag(std) @ correlation @ diag(std) with the report's std and correlation
        (off-diagonal NaN when the report has no correlation matrix);
    success: the fit converged (False only with FitError's `report`); message: how it ended;
    nfev, nit: the final fit's cost evaluations and iterations (the report's fit block);
    fitted, residual: per fit trace (a list, the traces' order), {column: array}: the final
        model's observed columns simulated by the library on the trace's samples, and
        measured - simulated ({} for a trace the final model cannot simulate, the reason then
        in simulation_failure, else None);
    effects: {effect: {parameter: value}} of the final model (a config's "effects");
    report: the report as a plain dict.
    """

    def __init__(self, report, final, converged, termination):
        super().__init__(report)
        self.report = report
        self.names = list(final["names"])
        self.x = np.asarray(final["x"], dtype=np.float64)
        self.params = {name: float(value) for name, value in zip(self.names, self.x)}
        self.cov = np.asarray(final["cov"], dtype=np.float64)
        self.success = bool(converged)
        self.message = termination
        fit = report.get("fit", {})
        self.nfev = fit.get("evaluations")
        self.nit = fit.get("iterations")
        self.fitted = [dict(trace) for trace in final["fitted"]]
        self.residual = [dict(trace) for trace in final["residual"]]
        self.simulation_failure = final["simulation_failure"] or None
        self._config = json.loads(final["config"])
        self.effects = copy.deepcopy(self._config.get("effects", {}))

    def __repr__(self):
        nrmse = self.get("fit", {}).get("nrmse")
        return (f"IdentifyResult(success={self.success}, message={self.message!r}, "
                f"params={self.params}, nrmse={nrmse})")

    def __reduce__(self):
        # Pickled as its report and the attributes (a dict subclass with state).
        return (_restore_result, (type(self), dict(self), self.__dict__))


def _restore_result(cls, items, state):
    result = cls.__new__(cls)
    dict.update(result, items)
    result.__dict__.update(state)
    return result


# ---- the API ----

@_in_python_terms
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


@_in_python_terms
def identify(config, traces, method=None, discover=False, candidates=None, observe=None,
             validate=None, seed=1, threads=0, *, free=None, initial=None, max_evaluations=0,
             bic_margin=10.0, min_share=0.1, max_effects=3, error=None, filter_hz=None, decimate=None,
             simulate_from=None, columns=None, scales=None, derive=None, select=None, split=None,
             initial_state="config", delimiter=None, duplicate_time=None, resample=None,
             verbose=False, baseline=None, bounds=None, **options):
    """Identifies the free parameters, as blmd-ident; returns an IdentifyResult, which is its
    --report JSON as a dict and has x, names, params, cov, success, message, fitted,
    residual and effects (see IdentifyResult).

    config: a path or a dict. traces: a CSV path or a mapping column -> 1-D array (a pandas
    DataFrame works), or a list of them (one fit over all). method: 'ceres', 'powell', 'fsd'
    or 'classic' (None: the config's, else ceres). discover: find the effects the model
    lacks and refit (--discover), candidates restricting them. observe, free: lists of
    names (None: the config's). validate: held-out traces. initial: {name: start value}.
    Every other keyword is a method option (--option KEY=VALUE), e.g. algorithm='praxis'.
    The keyword-only arguments are blmd-ident's flags of the same name (docs/cli.md §2).
    baseline: a stored report (a path) whose free parameters this fit is compared with, as
    blmd-ident --baseline; the comparison is the report's "baseline" entry.
    bounds: {name: (lo, hi)}, set in a copy of the config's identification.bounds (a config
    path is then read as a dict: named <config>). columns: {name: header} maps a CSV's
    headers; a list of names names the columns of 2-D array traces.
    Raises InputError for bad input and FitError when the fit did not converge (its
    `report` attribute holds the report).
    """
    config = _with_bounds(config, bounds)
    columns, array_names = _split_columns(columns)
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
    _error_settings(settings.error, error, filter_hz, decimate, simulate_from)
    _trace_settings(settings.preparation, columns, scales, derive, select, split, initial_state,
                    delimiter, duplicate_time, resample)
    text, converged, termination, final = _blmd.identify(
        _config_arg(config), settings, _trace_list(traces, "traces", array_names),
        _trace_list(validate, "validate", array_names))
    result = IdentifyResult(json.loads(text), final, converged, termination)
    if not converged:
        raise FitError("the fit did not converge: " + termination, result)
    return result


def _grid_text(name, spec):
    if isinstance(spec, str):
        return f"{name}={spec}"
    return f"{name}=" + ":".join(
        item if isinstance(item, str) else _number_text(item) for item in spec)


@_in_python_terms
def surface(config, traces, grid, observe=None, threads=0, *, force=False, error=None,
            filter_hz=None, decimate=None, simulate_from=None, columns=None, scales=None, derive=None,
            select=None, split=None, initial_state="config", delimiter=None,
            duplicate_time=None, resample=None):
    """The cost over a 1-D or 2-D grid of parameters, as blmd-surface.

    traces: one trace (a CSV path, a mapping column -> array, a 2-D array with columns=[names]
    or a structured array; a list of one is accepted; split= cuts it into experiments).
    grid: {"J": (lo, hi, n), "B": ("log", lo, hi, n)} (or "log:lo:hi:n" strings), the first
    axis outermost. Returns a dict: "axes" (names),
    "grid" {name: values}, "cost" (shape (n1,) or (n1, n2); inf where the simulation failed),
    "mse" {column: array of that shape}, "observe", "minimum" and "local_minima"
    ({name: value, ..., "cost": c}), "failed_points", "failure_reasons", and "csv" (the
    text blmd-surface --out writes).
    """
    columns, array_names = _split_columns(columns)
    trace_args = _trace_list(traces, "traces", array_names)
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
    _error_settings(settings.error, error, filter_hz, decimate, simulate_from)
    _trace_settings(settings.preparation, columns, scales, derive, select, split, initial_state,
                    delimiter, duplicate_time, resample)
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


# ---- configs ----

def _write_text(path, text):
    """Writes `text` to `path` whole or not at all (a temporary file renamed), as the
    commands write their outputs."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    handle, temporary = tempfile.mkstemp(dir=directory, prefix=".blmd-", suffix=".tmp")
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as file:
            file.write(text)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def _report_effects(report):
    """{effect: {parameter: value}} of the report's final model, from what it holds: the
    parameters of the effects discovery added (its steps), at their final values."""
    values = {name: p["value"] for name, p in report.get("parameters", {}).items()
              if p.get("value") is not None}
    effects = {}
    for step in (report.get("discovery") or {}).get("steps", []):
        name = step.get("effect")
        if name in report.get("effects", []):
            effects[name] = {key: values.get(key, value)
                             for key, value in (step.get("parameters") or {}).items()}
    return effects, values


@_in_python_terms
def write_config(result, path=None, base_config=None):
    """The config of the identified model: the config document with the fitted values in
    "parameters", the final model's effects with theirs in "effects", the free parameters and
    their bounds in "identification" and the provenance in "notes": what blmd-ident
    --write-config writes (the same C++ code). Returned as a dict, and written to `path`
    (JSON, two-space indent) when given.

    result: an IdentifyResult. A report given as a plain dict (e.g. read from a --report
    file) holds no config: then base_config (a path or a dict: the config that was fitted)
    is patched with the report's parameter values and the effects discovery added (only
    "parameters" and "effects" change).
    """
    if isinstance(result, IdentifyResult) and base_config is None:
        config = copy.deepcopy(result._config)
    elif _is_mapping(result):
        if base_config is None:
            raise InputError("write_config: a report given as a dict holds no config: give the "
                             "config that was fitted as base_config=, or pass the result of "
                             "blmd.identify")
        effects, values = _report_effects(result)
        if isinstance(result, IdentifyResult):
            effects = result.effects
        config = json.loads(_blmd.model_config(_config_arg(base_config), effects, values))
    else:
        raise TypeError("write_config: expected the result of blmd.identify or a report dict, "
                        f"not {type(result).__name__}")
    if path is not None:
        _write_text(path, json.dumps(config, indent=2) + "\n")
    return config


def init_config(model="dc_servo", path=None):
    """A starting config for `model` ('dc_servo', 'blmd' or 'rigid_load'): what blmd-sim
    --init-config MODEL prints (every parameter at its typical value, an experiment that
    excites J and B, units and ranges under "notes"). Returned as a dict, and written to
    `path` (the command's text, byte for byte) when given."""
    if not isinstance(model, str):
        raise TypeError(f"model: expected a model name, not {type(model).__name__}")
    try:
        text = _blmd.starting_config(model)
    except InputError as error:
        raise InputError(f"init_config: {error}") from None
    if path is not None:
        _write_text(path, text)
    return json.loads(text)


# ---- tune and design: their settings from the keyword arguments ----

def _flag_value(value):
    if isinstance(value, str):
        return value
    return _number_text(value)


class TuneResult(dict):
    """blmd.tune's outcome: blmd-tune's JSON report (it is that dict; also `report`), with
    `config` the closed-loop config that --write-config writes (blmd.simulate runs it) and
    `success` True (a refused request raises FitError)."""

    def __init__(self, report, config):
        super().__init__(report)
        self.report = report
        self.config = config
        self.success = True


class DesignResult(dict):
    """blmd.design's outcome: blmd-design's JSON report (it is that dict; also `report`),
    with `config` the config with the chosen experiment that --write-config writes (None
    when a recorded trace was evaluated) and `success` True."""

    def __init__(self, report, config):
        super().__init__(report)
        self.report = report
        self.config = config
        self.success = True


_OUTPUT_FLAGS = ("report_path", "write_config", "write_input", "json", "quiet", "config_path")


# blmd-tune's options beyond the named arguments: keyword -> (TuneSettings field, check); the
# checks are the command's flags' (positive numbers, whole numbers).
_TUNE_OPTIONS = {
    "step": ("step", "--step"),
    "duration": ("duration", "--duration"),
    "integral_ratio": ("integral_ratio", "--integral-ratio"),
    "filter_ratio": ("filter_ratio", "--filter-ratio"),
    "sample_rate": ("sample_rate_hz", "--sample-rate"),
    "current_bandwidth": ("current_bandwidth_hz", "--current-bandwidth"),
    "position_crossover": ("position_crossover_hz", "--position-crossover"),
    "delay": ("delay_samples", "--delay"),
    "threads": ("threads", "--threads"),
    "notch": ("notch", "--notch"),
}


def _json_source(value, name, required=False):
    """A path as (path, None), a dict (a config, a report) as ("<name>", its JSON text)."""
    if value is None and not required:
        return None
    if isinstance(value, (str, os.PathLike)):
        return (os.fspath(value), None)
    if _is_mapping(value):
        return (f"<{name}>", json.dumps(dict(value), indent=2, default=_json_default))
    raise TypeError(f"{name}: expected a path or a dict, not {type(value).__name__}")


def _limit_texts(limits, flag="--limit"):
    """{'u': 24, 'i': 4} (or ['u=24'], or 'u=24') as the texts of a NAME=VALUE flag."""
    if limits is None:
        return []
    if isinstance(limits, str):
        return [limits]
    if _is_mapping(limits):
        return [f"{name}={_flag_value(value)}" for name, value in limits.items()]
    if isinstance(limits, (list, tuple)):
        return [_flag_value(item) for item in limits]
    raise InputError(f"{flag}: expected a dict NAME -> VALUE or NAME=VALUE texts, not "
                     f"{limits!r}")


def _check_options(command, options, known, refused):
    """The keywords a function passes on to its command's settings: `fail_on_warning` (the
    command's exit code: a call has none) dropped; an output of the command (`refused`) or a
    name the command does not know is a TypeError naming it."""
    options.pop("fail_on_warning", None)
    unknown = [key for key in options if key not in known]
    outputs = [key for key in unknown if key in refused]
    if outputs:
        raise TypeError(f"{outputs[0]}: not an option here (the result holds it; write it "
                        "yourself)")
    if unknown:
        raise TypeError(f"{command}: unknown option(s) {', '.join(unknown)} "
                        f"(not a flag of blmd-{command}; see blmd-{command} --help)")


def _aliases(options, names, given):
    """The flags' own names (limit=, column=, scale=) for the keywords the functions name in
    the plural: moved into `given` ({keyword: value}); both at once is an error."""
    for flag_name, keyword in names.items():
        if flag_name in options:
            if given.get(keyword) is not None:
                raise TypeError(f"{keyword} and {flag_name} name the same option; give one")
            given[keyword] = options.pop(flag_name)
    return given


@_in_python_terms
def tune(config, report=None, loop="speed", crossover=None, phase_margin=None, limits=None,
         **options):
    """PI (loop='speed') or PID (loop='position') gains for a crossover (Hz) and a phase
    margin (degrees), as blmd-tune (docs/tuning.md). Every argument is the flag of that name
    (report: --from-report; limits: {'u': volts, 'i': amps} or ['u=24'] as --limit), and the
    other keywords are blmd-tune's options of the same name (step=, duration=,
    integral_ratio=, filter_ratio=, sample_rate=, delay=, current_bandwidth=,
    position_crossover=, threads=).

    config, report: paths or dicts (an IdentifyResult is a report). Returns a TuneResult: the
    command's JSON report as a dict, and .config, the closed-loop config. A request the plant
    cannot meet raises FitError('cannot tune: ...'), the command's exit 1 and message.
    """
    limits = _aliases(options, {"limit": "limits"}, {"limits": limits})["limits"]
    _check_options("tune", options, _TUNE_OPTIONS, _OUTPUT_FLAGS + ("from_report", "loop"))
    settings = _blmd.TuneSettings()
    if loop is None:
        raise InputError("--loop is required")
    settings.loop = _choice(loop, "--loop", ["speed", "position"])
    if crossover is None:
        raise InputError("--crossover is required")
    if phase_margin is None:
        raise InputError("--phase-margin is required")
    settings.crossover_hz = _positive(crossover, "--crossover")
    settings.phase_margin_deg = _positive(phase_margin, "--phase-margin")
    settings.limits = _limit_texts(limits)
    for key, value in options.items():
        field, flag = _TUNE_OPTIONS[key]
        if value is None:
            continue
        if key == "threads":
            value = _threads(value)
        elif key == "delay":
            value = _whole(int(value) if isinstance(value, str) and value.isdigit() else value,
                           flag)
        elif key == "notch":
            value = _choice(value, flag, ["auto", "off"])
        else:
            value = _positive(value, flag)
        setattr(settings, field, value)
    text, refused_request, refusal, closed_loop = _blmd.tune(
        _json_source(config, "config", required=True), _json_source(report, "report"), settings)
    if refused_request:
        raise FitError("cannot tune: " + refusal)
    return TuneResult(json.loads(text), json.loads(closed_loop))


# blmd-design's reading of a recorded trace (trace=): blmd-ident's trace flags, by keyword.
_DESIGN_TRACE_OPTIONS = ("columns", "scales", "derive", "select", "split", "initial_state",
                         "delimiter", "duplicate_time", "resample", "no_header", "sample_rate")


@_in_python_terms(renames={"trace": "trace"})
def design(config, duration=None, limits=None, noise=None, *, family=None, target=None,
           trace=None, report=None, threads=0, **options):
    """The experiment that best determines the free parameters within the drive's limits, as
    blmd-design (docs/design.md): duration (s), limits ({'u': volts, 'i': amps} or
    ['u=12'], --limit), noise ({'i': 0.014, 'w': '1%'}, --noise), family
    ('square'|'steps'|'prbs'|'chirp'|'all'), target (names: A-optimal for them), trace (a
    recorded input to evaluate instead of searching: a CSV path or a mapping of columns),
    report (--from-report: a path, a report dict or an IdentifyResult), threads; the
    keywords columns=, scales=, derive=, select=, split=, initial_state=, delimiter=,
    duplicate_time=, resample=, no_header= and sample_rate= read the trace (as blmd-ident's
    flags of those names).

    Returns a DesignResult: the command's JSON report as a dict, and .config. When no design
    meets the limits, FitError('no design: ...') with the report in its `report` attribute.
    """
    if "from_report" in options:  # the flag's own name, as the command has it
        if report is not None:
            raise TypeError("design: report and from_report name the same report; give one")
        report = options.pop("from_report")
    limits = _aliases(options, {"limit": "limits"}, {"limits": limits})["limits"]
    _aliases(options, {"column": "columns", "scale": "scales"}, options)
    _check_options("design", options, _DESIGN_TRACE_OPTIONS, _OUTPUT_FLAGS)
    settings = _blmd.DesignSettings()
    if duration is not None:
        settings.duration = _positive(duration, "--duration")
    settings.limits = _limit_texts(limits)
    settings.noises = _limit_texts(noise, "--noise")
    settings.family = _choice(family, "--family", ["square", "steps", "prbs", "chirp", "all"]) or \
        "all"
    settings.target = _names_text(target) or ""
    settings.threads = _threads(0 if threads is None else threads)
    columns, array_names = _split_columns(options.get("columns"))
    preparation = settings.trace
    _trace_settings(preparation, columns, options.get("scales"), options.get("derive"),
                    options.get("select"), options.get("split"),
                    options.get("initial_state") or "config", options.get("delimiter"),
                    options.get("duplicate_time"), options.get("resample"))
    if options.get("no_header") is not None:
        preparation.no_header = _names_text(options["no_header"])
    if options.get("sample_rate") is not None:
        preparation.sample_rate = _positive(options["sample_rate"], "--sample-rate")
    settings.trace = preparation
    trace_arg = None if trace is None else _trace_arg(trace, "trace", array_names)
    text, ok, reason, chosen = _blmd.design(_json_source(config, "config", required=True), settings,
                                            _json_source(report, "report"), trace_arg)
    report_dict = json.loads(text)
    if not ok:
        raise FitError("no design: " + reason, report_dict)
    return DesignResult(report_dict, json.loads(chosen) if chosen else None)
