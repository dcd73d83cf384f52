#!/usr/bin/env python3
"""Tests scripts/check-links on small pages made here (ctest docs_links_selftest).

Usage: check_links_test.py SOURCE_DIR

A page with one dead link must fail (exit 1) with exactly `FILE:LINE: dead link TARGET`;
dead anchors (in the page, in another page) likewise; links inside code, external links,
and anchors made by GitHub's heading rules (punctuation dropped, a space per hyphen,
duplicates numbered, inline code and links reduced to their text) must pass. Exit 0 when
every case behaves, 1 otherwise.
"""

import os
import subprocess
import sys
import tempfile

GOOD = """# The page

## 3.1 `ceres` — Levenberg-Marquardt (default)

## Cost: J·B, 95 % intervals & more!

## Repeated

## Repeated

## A [linked](other.md) *emphasised* heading

Links that live: [other](other.md), [its heading](other.md#second-heading),
[a folder](sub/), [here](#the-page), [Ceres](#31-ceres--levenberg-marquardt-default),
[cost](#cost-jb-95--intervals--more), [second repeat](#repeated-1),
[linked heading](#a-linked-emphasised-heading), [explicit anchor](#custom-id),
![an image](sub/figure.svg), <a href="other.md#second-heading">html</a>,
[external](https://example.com/missing.md), [mail](mailto:someone@example.com),
[reference][ref], `[in code](missing-in-code.md)`.

<a id="custom-id"></a>

```
[in a fenced block](missing-in-fence.md)
```

[ref]: other.md#first-heading
"""

OTHER = """First heading
=============

## Second heading
"""

BAD = """# Bad

A dead file: [gone](missing.md).

A dead anchor here: [nowhere](#no-such-heading), and in another page:
[nope](other.md#nope).
"""


def run(script, cwd, *files):
    return subprocess.run([sys.executable, script, *files], cwd=cwd, capture_output=True,
                          text=True)


def main(argv):
    if len(argv) != 1:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    script = os.path.join(os.path.abspath(argv[0]), "scripts", "check-links")
    failures = []
    with tempfile.TemporaryDirectory() as folder:
        os.makedirs(os.path.join(folder, "sub"))
        for name, text in (("good.md", GOOD), ("other.md", OTHER), ("bad.md", BAD),
                           ("sub/figure.svg", "<svg/>")):
            with open(os.path.join(folder, name), "w", encoding="utf-8") as f:
                f.write(text)

        # The brief's case: one dead link, the exact message, exit 1.
        with open(os.path.join(folder, "one.md"), "w", encoding="utf-8") as f:
            f.write("# One\n\nSee [the missing page](missing.md) for more.\n")
        result = run(script, folder, "one.md")
        if result.returncode != 1 or result.stdout != "one.md:3: dead link missing.md\n":
            failures.append("one dead link: exit %d, stdout %r (expected 1 and %r)" % (
                result.returncode, result.stdout, "one.md:3: dead link missing.md\n"))

        result = run(script, folder, "bad.md")
        expected = ("bad.md:3: dead link missing.md\n"
                    "bad.md:5: dead link #no-such-heading\n"
                    "bad.md:6: dead link other.md#nope\n")
        if result.returncode != 1 or result.stdout != expected:
            failures.append("dead anchors: exit %d, stdout %r (expected 1 and %r)" % (
                result.returncode, result.stdout, expected))

        result = run(script, folder, "good.md", "other.md")
        if result.returncode != 0 or result.stdout != "":
            failures.append("live links: exit %d, stdout %r, stderr %r (expected 0, nothing)" % (
                result.returncode, result.stdout, result.stderr))
        elif "13 relative links in 2 files, 0 dead" not in result.stderr:
            failures.append("live links: the count line is %r" % result.stderr.strip())

        # A path given from another folder is printed as given.
        result = run(script, os.path.dirname(folder),
                     os.path.join(os.path.basename(folder), "one.md"))
        shown = os.path.join(os.path.basename(folder), "one.md")
        if result.stdout != "%s:3: dead link missing.md\n" % shown:
            failures.append("path as given: stdout %r" % result.stdout)

        result = run(script, folder, "absent.md")
        if result.returncode != 2 or not result.stderr.startswith("error: absent.md:"):
            failures.append("unreadable page: exit %d, stderr %r (expected 2, error: ...)" % (
                result.returncode, result.stderr))

    for failure in failures:
        print("FAIL: " + failure)
    if not failures:
        print("check-links self-test: 5 cases pass")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
