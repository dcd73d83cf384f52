#!/usr/bin/env python3
"""The schema tests of tests/CMakeLists.txt (schema/*.schema.json, scripts/validate-json).

  schema_test.py meta SCHEMA...
      each is a valid draft 2020-12 schema (Draft202012Validator.check_schema) with $schema,
      $id, title and description.
  schema_test.py run-and-validate --validator V --schema S [--stdout FILE] --run CMD...
      runs each CMD (a shell-like string, from the current directory) in order, each must
      exit 0; --stdout FILE takes the last command's standard output; then validates the
      files named by --check with V against S.
  schema_test.py mutate --validator V --schema S --expect valid|invalid [--pointer P]
                 --from FILE [--drop POINTER]... [--set POINTER=JSON]...
      writes FILE with the changes (the drops, then the sets) to a temporary file and asserts
      that V accepts it (exit 0), or refuses it: exit 2 and an `error: TEMP: P: ` line.
  schema_test.py drift --bin BIN_DIR --schema CONFIG_SCHEMA
      the config schema against the loader of the built commands: every object's keys, the
      models, each model's parameters (required or optional, > 0, >= 0 or any sign), the
      effects (their parameters, signs, and the models they apply to), the input types and
      their keys, the error kinds, the methods; each list as the commands' own error
      messages give it (blmd-sim --config with one wrong thing in an otherwise good config).
  schema_test.py validate-folder --validator V --report-schema R --surface-schema S DIR
      the reports the suite's tests wrote (tests/support/test_support.cc, BLMD_REPORT_SINK):
      DIR/report-*.json against R, DIR/surface-*.json against S; none is fine (no test that
      runs a command ran).
  schema_test.py bad-inputs --validator V --schema S --beyond NAME,... DIR
      every config of DIR (tests/bad-input/configs: each refused by the commands) is refused
      by V too (exit 2), except the listed ones, which need what a schema cannot check
      (bounds in order, a start inside its bounds, a file's existence, ...) and must pass.
"""
import argparse
import json
import os
import shlex
import subprocess
import sys
import tempfile

sys.dont_write_bytecode = True  # scripts/validate-json is loaded as a module: no __pycache__ there


def fail(message):
    sys.stderr.write("FAIL: " + message + "\n")
    sys.exit(1)


def meta(paths):
    from jsonschema import Draft202012Validator
    for path in paths:
        with open(path, encoding="utf-8") as stream:
            schema = json.load(stream)
        Draft202012Validator.check_schema(schema)
        if schema.get("$schema") != "https://json-schema.org/draft/2020-12/schema":
            fail(path + ": $schema is not draft 2020-12")
        for key in ("$id", "title", "description"):
            if not isinstance(schema.get(key), str) or not schema[key]:
                fail(path + ": no " + key)
        print("ok: %s (%s)" % (path, schema["title"]))


def validate(validator, schema, files):
    run = subprocess.run([sys.executable, validator, schema] + files, capture_output=True,
                         text=True, check=False)
    sys.stdout.write(run.stdout)
    sys.stderr.write(run.stderr)
    if run.returncode != 0:
        fail("%d file(s) not valid against %s (exit %d)" % (len(files), schema, run.returncode))


def run_and_validate(args):
    for k, command in enumerate(args.run):
        argv = shlex.split(command)
        last = k == len(args.run) - 1
        print("$ " + command + (" > " + args.stdout if last and args.stdout else ""))
        run = subprocess.run(argv, capture_output=True, text=True, check=False)
        if run.returncode != 0:
            sys.stderr.write(run.stdout + run.stderr)
            fail("exit %d: %s" % (run.returncode, command))
        if last and args.stdout:
            with open(args.stdout, "w", encoding="utf-8") as stream:
                stream.write(run.stdout)
    validate(args.validator, args.schema, args.check)


def split_pointer(pointer):
    return [p.replace("~1", "/").replace("~0", "~") for p in pointer.split("/")[1:]]


def mutate(args):
    with open(args.source, encoding="utf-8") as stream:
        document = json.load(stream)
    changes = [("drop", p) for p in args.drop or []] + [("set", p) for p in args.set or []]
    for kind, change in changes:
        where, value = (change, None) if kind == "drop" else change.split("=", 1)
        *parents, last = split_pointer(where)
        target = document
        for key in parents:
            target = target[int(key)] if isinstance(target, list) else target[key]
        if isinstance(target, list):
            last = int(last)
        if kind == "drop":
            if isinstance(target, dict) and last not in target:
                fail("%s has no %s to drop" % (args.source, where))
            del target[last]
        else:
            target[last] = json.loads(value)
    what = ", ".join(("no " + c) if k == "drop" else c for k, c in changes)
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "changed-" + os.path.basename(args.source))
        with open(path, "w", encoding="utf-8") as stream:
            json.dump(document, stream, indent=1)
        run = subprocess.run([sys.executable, args.validator, args.schema, path],
                             capture_output=True, text=True, check=False)
        sys.stdout.write(run.stdout)
        sys.stderr.write(run.stderr)
        if args.expect == "valid":
            if run.returncode != 0:
                fail("validate-json refused %s with %s (exit %d, expected 0)" %
                     (args.source, what, run.returncode))
            print("ok: valid with " + what)
            return
        if run.returncode != 2:
            fail("validate-json accepted %s with %s (exit %d, expected 2)" %
                 (args.source, what, run.returncode))
        wanted = "error: %s: %s: " % (path, args.pointer)
        if not any(line.startswith(wanted) for line in run.stderr.splitlines()):
            fail("no line starting %r in the output" % wanted)
        if any(not line.startswith("error: ") for line in run.stderr.splitlines()):
            fail("every line of the output should be one `error:` line")
    print("ok: refused, naming %s" % args.pointer)

# Minimal good configs per model; "identification": {"zz": 1} is the last thing the loader
# reads, so a config it reaches fails there (exit 2, nothing simulated): "accepted".
BASE = {
    "dc_servo": {"R": 12.6, "L": 0.283, "Kt": 0.04, "Kb": 0.04, "J": 2.26e-5, "B": 2.261e-5},
    "blmd": {"Ud": 310.0, "Rs": 1.0, "Ls": 0.004, "Ke": 0.3, "p": 3, "Kc": 1.1, "Kf": 0.5,
             "Kp": 8.0, "Ki": 16000.0, "Vtri": 10.0, "Tpwm": 0.0002, "delta": 2e-05,
             "J": 0.00119, "B": 0.0005},
    "rigid_load": {"J": 0.02, "B": 0.05},
}
ACCEPTED = "unknown key 'zz' in 'identification'"


class Loader:
    def __init__(self, bin_dir, folder):
        self.sim = os.path.join(bin_dir, "blmd-sim")
        self.folder = folder
        self.runs = 0

    def error(self, config):
        """The loader's error line for `config` (identification.zz appended unless given)."""
        config = dict(config)
        config.setdefault("identification", {"zz": 1})
        path = os.path.join(self.folder, "c.json")
        with open(path, "w", encoding="utf-8") as stream:
            json.dump(config, stream)
        run = subprocess.run([self.sim, "--config", path, "--out",
                              os.path.join(self.folder, "t.csv"), "--quiet"],
                             capture_output=True, text=True, check=False)
        self.runs += 1
        if run.returncode != 2:
            fail("blmd-sim exit %d (expected 2) for %s: %s" %
                 (run.returncode, json.dumps(config), run.stderr))
        return run.stderr.strip()

    def valid_list(self, config, marker):
        message = self.error(config)
        at = message.find(marker)
        if at < 0:
            fail("no %r in %r (config %s)" % (marker, message, json.dumps(config)))
        tail = message[at + len(marker):]
        for end in (")", "\n"):
            tail = tail.split(end)[0]
        return [n.strip() for n in tail.split(",") if n.strip()]


def drift(args):
    with open(args.schema, encoding="utf-8") as stream:
        schema = json.load(stream)
    defs = schema["$defs"]
    problems = []

    def same(what, loader_names, schema_names):
        if sorted(loader_names) != sorted(schema_names):
            problems.append("%s: the commands accept %s, the schema %s" %
                            (what, sorted(loader_names), sorted(schema_names)))

    def minimum(entry):
        return ("> 0" if "exclusiveMinimum" in entry else ">= 0" if "minimum" in entry
                else "any")

    with tempfile.TemporaryDirectory() as folder:
        loader = Loader(args.bin, folder)
        good = {"model": "dc_servo", "parameters": BASE["dc_servo"]}
        keys = "valid keys: "
        same("top-level keys", loader.valid_list(dict(good, zz=1), keys),
             [k for k in schema["properties"] if k != "$schema"])
        # A config may name its schema for editors; the loader accepts it (a string).
        if ACCEPTED not in loader.error(dict(good, **{"$schema": "x"})):
            fail("the commands refuse \"$schema\", which the schema allows")
        same("models", loader.valid_list({"model": "zz", "parameters": {}}, "(valid: "),
             schema["properties"]["model"]["enum"])
        same("simulation keys", loader.valid_list(dict(good, simulation={"zz": 1}), keys),
             defs["simulation"]["properties"])
        experiment = defs["experiment"]["properties"]
        same("experiment keys", loader.valid_list(dict(good, experiment={"zz": 1}), keys),
             experiment)
        # experiment.pid: each model's keys are the shared definition's less those its
        # branch of the schema forbids ("not": {}): dc_servo's PID, rigid_load's sampled loop.
        for model in ("dc_servo", "rigid_load"):
            branch = next(rule["then"] for rule in schema["allOf"]
                          if rule.get("if", {}).get("properties", {}).get("model", {})
                          .get("const") == model)
            forbidden = (branch.get("properties", {}).get("experiment", {})
                         .get("properties", {}).get("pid", {}).get("properties", {}))
            same("experiment.pid keys (%s)" % model,
                 loader.valid_list({"model": model, "parameters": BASE[model],
                                    "experiment": {"pid": {"zz": 1}}}, keys),
                 [k for k in experiment["pid"]["properties"]
                  if forbidden.get(k) != {"not": {}} and "not" not in forbidden.get(k, {})])
        same("experiment.initial keys",
             loader.valid_list(dict(good, experiment={"initial": {"zz": 1}}), keys),
             experiment["initial"]["properties"])
        same("identification keys", loader.valid_list(dict(good, identification={"zz": 1}),
                                                      keys), defs["identification"]["properties"])
        same("identification.error",
             loader.valid_list(dict(good, identification={"error": "zz"}), "is not one of: "),
             defs["identification"]["properties"]["error"]["enum"])
        # Input types and their keys.
        types = loader.valid_list(dict(good, experiment={"input": {"type": "zz"}}), "(valid: ")
        same("input types", types, defs["input"]["properties"]["type"]["enum"])
        for rule in defs["input"]["allOf"]:
            kind = rule["if"]["properties"]["type"]["const"]
            same("input %s keys" % kind, loader.valid_list(
                dict(good, experiment={"input": {"type": kind, "zz": 1}}), keys),
                rule["then"]["properties"])
        # Models: their parameters, which are required, and their signs.
        for model in schema["properties"]["model"]["enum"]:
            entry = defs[model + "_parameters"]
            names = loader.valid_list({"model": model, "parameters": {"zz": 1}}, keys)
            same(model + " parameters", names, entry["properties"])
            base = {"model": model, "parameters": BASE[model]}
            if model == "blmd":
                base["simulation"] = {"dt": 1e-6}
            for name in names:
                without = {k: v for k, v in BASE[model].items() if k != name}
                required = ACCEPTED not in loader.error(dict(base, parameters=without))
                if required != (name in entry["required"]):
                    problems.append("%s.%s: the commands %s it, the schema %s" % (
                        model, name, "require" if required else "do not require",
                        "requires it" if name in entry["required"] else "does not"))
                sign = "any"
                for value, if_refused in ((0, "> 0"), (-1, ">= 0")):
                    if ACCEPTED not in loader.error(dict(base, parameters=dict(BASE[model],
                                                                                **{name: value}))):
                        sign = if_refused
                        break
                if sign != minimum(entry["properties"].get(name, {})):
                    problems.append("%s.%s: the commands take %s, the schema %s" % (
                        model, name, sign, minimum(entry["properties"].get(name, {}))))
        # Effects: names, parameters, signs, models.
        effects = loader.valid_list(dict(good, effects={"zz": {}}), "(valid: ")
        same("effects", effects, schema["properties"]["effects"]["properties"])
        rules = {r["if"]["properties"]["model"]["const"]: r["then"] for r in schema["allOf"]
                 if "model" in r["if"].get("properties", {})}
        for effect in effects:
            entry = defs.get("effect_" + effect, {"properties": {}})
            checked = False  # parameters and signs once; applicability for every model
            for model in schema["properties"]["model"]["enum"]:
                base = {"model": model, "parameters": BASE[model]}
                if model == "blmd":
                    base["simulation"] = {"dt": 1e-6}
                message = loader.error(dict(base, effects={effect: {"zz": 1}}))
                applies = "does not apply" not in message
                in_schema = effect in rules[model]["properties"]["effects"]["propertyNames"]["enum"]
                if applies != in_schema:
                    problems.append("effect %s on %s: the commands %s it, the schema %s" % (
                        effect, model, "accept" if applies else "refuse",
                        "allows it" if in_schema else "does not"))
                if not applies or checked:
                    continue
                checked = True
                names = loader.valid_list(dict(base, effects={effect: {"zz": 1}}), keys)
                same("effect %s parameters" % effect, names, entry["properties"])
                values = {n: 1.0 for n in names}
                for name in names:
                    sign = "any"
                    for value, if_refused in ((0, "> 0"), (-1, ">= 0")):
                        if ACCEPTED not in loader.error(dict(
                                base, effects={effect: dict(values, **{name: value})})):
                            sign = if_refused
                            break
                    if sign != minimum(entry["properties"].get(name, {})):
                        problems.append("effect %s.%s: the commands take %s, the schema %s" % (
                            effect, name, sign, minimum(entry["properties"].get(name, {}))))
        # Methods, from blmd-ident (checked before any trace is read).
        with open(os.path.join(folder, "c.json"), "w", encoding="utf-8") as stream:
            json.dump(good, stream)
        run = subprocess.run([os.path.join(args.bin, "blmd-ident"), "--config",
                              os.path.join(folder, "c.json"), "--trace", "none.csv",
                              "--method", "zz"], capture_output=True, text=True, check=False)
        message = run.stderr
        at = message.find("(valid: ")
        if at < 0:
            fail("blmd-ident --method zz: no list of methods in %r" % message)
        same("methods", [m.strip() for m in message[at + 8:].split(")")[0].split(",")],
             defs["identification"]["properties"]["method"]["enum"])
    for line in problems:
        sys.stderr.write("FAIL: drift: " + line + "\n")
    if problems:
        fail("%d difference(s) between config.schema.json and the loader" % len(problems))
    print("ok: config.schema.json agrees with the loader (%d blmd-sim runs)" % loader.runs)


def load_validator(path):
    """scripts/validate-json as a module, to run it in process (one import for many files)."""
    import importlib.machinery
    import importlib.util
    loader = importlib.machinery.SourceFileLoader("validate_json", path)
    spec = importlib.util.spec_from_loader("validate_json", loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def bad_inputs(args):
    import contextlib
    import io
    validate_json = load_validator(args.validator)
    beyond = set(filter(None, args.beyond.split(",")))
    names = sorted(n for n in os.listdir(args.folder) if n.endswith(".json"))
    if not names:
        fail("no configs in " + args.folder)
    for name in sorted(beyond):
        if name not in names:
            fail("--beyond names %s, which is not in %s" % (name, args.folder))
    for name in names:
        errors = io.StringIO()
        with contextlib.redirect_stderr(errors):
            code = validate_json.main(["validate-json", "--quiet", args.schema,
                                       os.path.join(args.folder, name)])
        errors = errors.getvalue()
        if name in beyond:
            if code != 0:
                fail("%s: expected to pass the schema (a command-only check), got exit %d: %s" %
                     (name, code, errors.strip()))
            print("passes the schema (the commands refuse it): " + name)
        else:
            if code != 2 or not errors.startswith("error: "):
                fail("%s: the commands refuse it, the schema should too (exit %d)" %
                     (name, code))
            print("refused: " + errors.strip().splitlines()[0])


def validate_folder(args):
    import contextlib
    import io
    validate_json = load_validator(args.validator)
    names = sorted(os.listdir(args.folder)) if os.path.isdir(args.folder) else []
    groups = (("report-", args.report_schema), ("surface-", args.surface_schema))
    bad = 0
    for prefix, schema in groups:
        files = [os.path.join(args.folder, n) for n in names
                 if n.startswith(prefix) and n.endswith(".json")]
        if not files:
            print("no %s*.json in %s" % (prefix, args.folder))
            continue
        errors = io.StringIO()
        with contextlib.redirect_stderr(errors):
            code = validate_json.main(["validate-json", "--quiet", schema] + files)
        lines = errors.getvalue().splitlines()
        sys.stderr.write("".join(line + "\n" for line in lines[:200]))
        invalid = len({line.split(": ")[1] for line in lines if line.startswith("error: ")})
        print("%d %s*.json file(s) of the suite's tests: %d valid, %d not, against %s" %
              (len(files), prefix, len(files) - invalid, invalid, os.path.basename(schema)))
        bad += code != 0
    if bad:
        fail("reports written by the tests do not match the schemas (the files stay in %s)" %
             args.folder)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("meta")
    p.add_argument("schemas", nargs="+")
    p = sub.add_parser("run-and-validate")
    p.add_argument("--validator", required=True)
    p.add_argument("--schema", required=True)
    p.add_argument("--stdout")
    p.add_argument("--run", action="append", required=True)
    p.add_argument("--check", action="append", required=True)
    p = sub.add_parser("mutate")
    p.add_argument("--validator", required=True)
    p.add_argument("--schema", required=True)
    p.add_argument("--expect", choices=("valid", "invalid"), required=True)
    p.add_argument("--pointer", help="with --expect invalid: the place the error names")
    p.add_argument("--from", dest="source", required=True)
    p.add_argument("--drop", action="append")
    p.add_argument("--set", action="append")
    p = sub.add_parser("drift")
    p.add_argument("--bin", required=True)
    p.add_argument("--schema", required=True)
    p = sub.add_parser("validate-folder")
    p.add_argument("--validator", required=True)
    p.add_argument("--report-schema", required=True)
    p.add_argument("--surface-schema", required=True)
    p.add_argument("folder")
    p = sub.add_parser("bad-inputs")
    p.add_argument("--validator", required=True)
    p.add_argument("--schema", required=True)
    p.add_argument("--beyond", default="")
    p.add_argument("folder")
    args = parser.parse_args()
    if args.command == "meta":
        meta(args.schemas)
    elif args.command == "run-and-validate":
        run_and_validate(args)
    elif args.command == "mutate":
        if args.expect == "invalid" and not args.pointer:
            parser.error("--expect invalid needs --pointer")
        if not args.drop and not args.set:
            parser.error("mutate needs a --drop or a --set")
        mutate(args)
    elif args.command == "drift":
        drift(args)
    elif args.command == "validate-folder":
        validate_folder(args)
    else:
        bad_inputs(args)


if __name__ == "__main__":
    main()
