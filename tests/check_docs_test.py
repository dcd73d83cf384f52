#!/usr/bin/env python3
"""The docs check against the binary (scripts/check-docs): it fails on a planted change of an
expected number (naming the file and line), and ignores a change of a wall time. (That it
passes on the committed docs is the test docs_outputs, which runs the same pages.)
Usage: check_docs_test.py SOURCE_DIR BUILD_DIR"""
import os
import re
import subprocess
import sys
import tempfile

source, build = sys.argv[1], sys.argv[2]
script = os.path.join(source, "scripts", "check-docs")
env = dict(os.environ, BUILD_DIR=build)


def check(path):
    return subprocess.run([sys.executable, script, path], cwd=source, env=env,
                          capture_output=True, text=True)


readme = os.path.join(source, "README.md")
text = open(readme, encoding="utf-8").read()
with tempfile.TemporaryDirectory() as tmp:
    # A planted change of an expected number: the NRMSE of the fit line.
    match = re.search(r"^fit: NRMSE ([0-9.]+)", text, flags=re.M)
    assert match, "README has no fit line under a generated block"
    planted = text.replace(match.group(0), "fit: NRMSE " + str(float(match.group(1)) * 1.1), 1)
    path = os.path.join(tmp, "README.md")
    open(path, "w", encoding="utf-8").write(planted)
    result = check(path)
    assert result.returncode == 1, (result.returncode, result.stderr)
    line = planted[: planted.index("fit: NRMSE")].count("\n") + 1
    assert f"README.md:{line}: expected `fit: NRMSE" in result.stderr, result.stderr
    # A wall time is not compared.
    timed = re.sub(r"(iterations, )[0-9.]+ s", r"\g<1>123.4 s", text, count=1)
    assert timed != text
    open(path, "w", encoding="utf-8").write(timed)
    result = check(path)
    assert result.returncode == 0, result.stderr
print("check-docs: fails on a planted number, ignores wall times")
