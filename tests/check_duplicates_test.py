#!/usr/bin/env python3
"""scripts/check-duplicates on a scratch tree: six code lines copied from one file into another
fail it (exit 1, both places named); once listed by --update the same tree passes; the copy
with its comments and spacing changed is still the same block.

    tests/check_duplicates_test.py SOURCE_DIR
"""
import os
import subprocess
import sys
import tempfile

SCRIPT = os.path.join(sys.argv[1], "scripts", "check-duplicates")
BLOCK = ["int total = 0;", "for (int k = 0; k < n; ++k) {", "total += weights[k] * values[k];",
         "if (total > limit) total = limit;", "counts[k] = total;", "}", "result.total = total;",
         "result.ok = total > 0;"]


def run(root, *flags):
    return subprocess.run([sys.executable, SCRIPT, "--root", root, *flags], capture_output=True,
                          text=True)


def main():
    failures = []
    with tempfile.TemporaryDirectory() as root:
        os.makedirs(os.path.join(root, "src"))
        os.makedirs(os.path.join(root, "scripts"))
        with open(os.path.join(root, "src", "a.cc"), "w") as f:
            f.write("void A() {\n" + "\n".join(BLOCK) + "\n}\n")
        with open(os.path.join(root, "src", "b.cc"), "w") as f:
            f.write("// another file\nvoid B() {\n  // the same, reformatted\n" +
                    "\n".join("    " + line.replace(" ", "  ") for line in BLOCK) + "\n}\n")
        with open(os.path.join(root, "src", "c.cc"), "w") as f:
            f.write("void C() {\n" + "\n".join(BLOCK[:4]) + "\n}\n")  # too short to count
        planted = run(root)
        if planted.returncode != 1:
            failures.append("a planted copy: exit %d, expected 1" % planted.returncode)
        if "src/a.cc:2 and src/b.cc:4: 7 code lines copied" not in planted.stderr:
            failures.append("the message names both places: " + planted.stderr)
        if run(root, "--update").returncode != 0 or run(root).returncode != 0:
            failures.append("after --update the known copy passes")
    for failure in failures:
        print("FAIL: " + failure)
    print("check-duplicates self-test: %d failure(s)" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
