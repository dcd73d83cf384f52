#!/usr/bin/env python3
"""scripts/check-registry-names on a scratch tree with the repository's registries: a model
name and an effect name compared outside them fail it (exit 1, each place named), a model's
own name inside its folder and a name in a comment do not.

    tests/check_registry_names_test.py SOURCE_DIR
"""
import os
import shutil
import subprocess
import sys
import tempfile

SOURCE = sys.argv[1]
SCRIPT = os.path.join(SOURCE, "scripts", "check-registry-names")


def main():
    failures = []
    with tempfile.TemporaryDirectory() as root:
        os.makedirs(os.path.join(root, "src", "sim"))
        os.makedirs(os.path.join(root, "src", "app"))
        shutil.copy(os.path.join(SOURCE, "src", "sim", "effects.cc"),
                    os.path.join(root, "src", "sim", "effects.cc"))
        shutil.copytree(os.path.join(SOURCE, "include", "blmd", "sim"),
                        os.path.join(root, "include", "blmd", "sim"))
        with open(os.path.join(root, "src", "app", "design.cc"), "w") as f:
            f.write('// the rigid_load model and "coulomb_friction" in a comment count for nothing\n'
                    'double PerInput(const Config& c) {\n'
                    '  if (std::string(c.model->name()) == "rigid_load") return 1.0;\n'
                    '  if (Has(c, "coulomb_friction")) return 2.0;\n'
                    '  return 0.0;\n}\n')
        planted = subprocess.run([sys.executable, SCRIPT, "--root", root], capture_output=True,
                                 text=True)
        if planted.returncode != 1:
            failures.append("planted names: exit %d, expected 1" % planted.returncode)
        for expected in ('src/app/design.cc:3: the model name "rigid_load"',
                         'src/app/design.cc:4: the effect name "coulomb_friction"'):
            if expected not in planted.stderr:
                failures.append("missing '%s' in: %s" % (expected, planted.stderr))
        if "design.cc:1:" in planted.stderr:
            failures.append("a comment counted: " + planted.stderr)
        if "2 name(s) outside the registries" not in planted.stderr:
            failures.append("the count: " + planted.stderr)
        os.remove(os.path.join(root, "src", "app", "design.cc"))
        clean = subprocess.run([sys.executable, SCRIPT, "--root", root], capture_output=True,
                               text=True)
        if clean.returncode != 0:
            failures.append("the registries alone (each model's own name in its folder): exit "
                            "%d: %s" % (clean.returncode, clean.stderr))
    for failure in failures:
        print("FAIL: " + failure)
    print("check-registry-names self-test: %d failure(s)" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
