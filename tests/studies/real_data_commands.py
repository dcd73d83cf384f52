"""The blmd-ident commands of docs/real-data.md that write a report, as one bash script: each
```sh block that writes under docs/real-data/, in order, in a subshell, with the real data's
folder substituted and `build/bin/blmd-ident` replaced by a shell function `blmd_ident` that
the caller's `prelude` defines (what to do with each command's arguments). The same
extraction as scripts/real-data-reports; used by the studies that rerun those commands."""
import os
import re


def script(root, data, prelude):
    page = open(os.path.join(root, "docs", "real-data.md"), encoding="utf-8").read()
    text = prelude
    for block in re.findall(r"```sh\n(.*?)```", page, flags=re.S):
        if "--report docs/real-data/" not in block:
            continue
        block = block.replace("../shared/realdata", data).replace("build/bin/blmd-ident",
                                                                    "blmd_ident")
        text += "(\n" + block + ")\n"
    return text
