#!/usr/bin/env python3
"""The HTML report in a real browser (docs/report.md, "How it is tested").

Headless Chromium opens the report and
  1. dumps the DOM it built: every expected plot is there (the count is derived from the
     JSON report of the same run, not from the HTML), each an inline <svg> with a drawn
     curve, and nothing runs (no <script>); the linear views: the correlation table holds
     the report's matrix, the frequency- and step-response sections are there, and each Bode
     and coherence plot has the report's number of points;
  2. takes a screenshot of the whole page (kept as an artefact), which must not be blank;
  3. opens each figure alone, enlarged through its #fig-N anchor (the CSS :target zoom), and
     takes a screenshot of it: each must show a plot (enough non-white pixels, many
     colours, and pixels of the exact blue or vermilion of the curves);
  4. logs to stderr throughout: no console message (uncaught error, failed resource load)
     may appear;
  5. lays the page out in a 1280x800 window (a laptop's first screen) inside a measuring
     frame: the final model's J and B cards, with the report's values and 95 % intervals,
     lie within it, above the figures of merit.
Usage: check_report.py --chromium BIN --html REPORT.html --json REPORT.json --out DIR
Exit 0 when every check passes, 1 otherwise (the failed checks are listed)."""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from png_stats import stats  # noqa: E402

FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--hide-scrollbars", "--enable-logging=stderr", "--v=0",
]
CURVE_COLOURS = ["#0072b2", "#d55e00"]  # Okabe-Ito blue (fit), vermilion (after discovery)
CONSOLE = re.compile(r"CONSOLE|Uncaught|Failed to load resource|net::ERR_")

failures = []


def check(condition, what):
    print(("ok:   " if condition else "FAIL: ") + what)
    if not condition:
        failures.append(what)


def chromium(binary, arguments, url, log_path):
    """Runs Chromium once with a fresh profile; returns stdout, appends stderr to the log."""
    with tempfile.TemporaryDirectory(prefix="blmd-chromium-") as profile:
        run = subprocess.run([binary, *FLAGS, f"--user-data-dir={profile}", *arguments, url],
                             capture_output=True, timeout=300)
    with open(log_path, "ab") as log:
        log.write(run.stderr)
    if run.returncode != 0:
        failures.append(f"chromium exited with {run.returncode} on {url}")
    return run.stdout.decode("utf-8", "replace")


def expected_plots(report):
    """Per trace and observed column: the trace, its first transient (where u has a step), its
    residual; per column the autocorrelation; one cost slice per free parameter. When discovery added an
    effect, also per trace and column the residual after discovery, and one slice per
    parameter of the final model."""
    observe = report["fit"]["observe"]
    traces = len(report["traces"])
    discovery = report.get("discovery")
    # The first fit's free parameters: the headline is the final model (schema 2), the first
    # fit is under discovery.before.
    first = discovery["before"] if discovery and "before" in discovery else report
    free = [name for name, p in first["parameters"].items() if p.get("free")]
    count = 3 * len(observe) * traces + len(observe) + len(free)
    if discovery and discovery.get("added"):
        count += len(observe) * traces + len(discovery["parameters_after"])
    # The adequacy check (docs/discovery.md §7): the residual against each flagged state.
    if discovery and discovery.get("adequacy", {}).get("ok"):
        count += sum(1 for t in discovery["adequacy"].get("tests", []) if t.get("flagged"))
    # The linear views: Bode magnitude, phase and coherence per output of the frequency
    # response; a step response per output with a final value.
    frequency = report.get("frequency_response", {})
    if frequency.get("available"):
        count += 3 * len(frequency["outputs"])
    step = report.get("step_response", {})
    if step.get("available"):
        count += sum(1 for o in step["outputs"].values() if "rise_time_s" in o)
    return count


def check_linear_views(report, dom):
    """The correlation table (n x n cells of the report's matrix), the frequency-response and
    step-response sections, and each Bode plot with as many points as the report has."""
    correlation = report.get("correlation", {})
    if correlation.get("available"):
        n = len(correlation["names"])
        cells = re.findall(r'<td class="num rho[^"]*" data-rho="([^"]+)"', dom)
        check(len(cells) == n * n, f"correlation table with {len(cells)} cells (expected {n}x{n})")
        matrix = [v for row in correlation["matrix"] for v in row]
        close = all(abs(float(c) - v) <= 1e-5 * max(1.0, abs(v)) for c, v in zip(cells, matrix))
        check(close, "correlation cells hold the report's matrix")
    frequency = report.get("frequency_response", {})
    check(('id="frequency-response"' in dom) == ("frequency_response" in report),
          "frequency-response section present")
    check(('id="step-response"' in dom) == ("step_response" in report), "step-response section present")
    for column, output in frequency.get("outputs", {}).items():
        for kind in ("bode-magnitude", "bode-phase", "coherence"):
            found = re.findall(rf'data-kind="{kind}" data-column="{column}" data-points="(\d+)"', dom)
            check(found == [str(len(output["f_hz"]))],
                  f"{kind} of {column}: {found} points (expected {len(output['f_hz'])})")


MEASURE = """<!doctype html><html><body style="margin:0">
<iframe id="f" src="REPORT" width="1280" height="800" style="border:0"></iframe>
<pre id="out">pending</pre>
<script>
document.getElementById("f").addEventListener("load", function () {
  var doc = document.getElementById("f").contentDocument, rows = [];
  doc.querySelectorAll(".card").forEach(function (card) {
    var r = card.getBoundingClientRect();
    rows.push({name: card.getAttribute("data-name") || "", estimate: card.classList.contains("estimate"),
               text: card.innerText.replace(/\\s+/g, " "), top: r.top, bottom: r.bottom});
  });
  document.getElementById("out").textContent = JSON.stringify(rows);
});
</script></body></html>"""


def number_in(text, value):
    """Whether `text` shows `value` to its printed digits (4-5 significant)."""
    for word in re.findall(r"[-+]?\d*\.?\d+(?:[eE][-+]?\d+)?", text):
        x = float(word)
        if x == value or abs(x - value) <= 1e-3 * abs(value):
            return True
    return False


def check_headline(binary, html, report, out):
    page = os.path.join(out, "measure.html")
    with open(page, "w", encoding="utf-8") as f:
        f.write(MEASURE.replace("REPORT", "file://" + html))
    log = os.path.join(out, "chromium-measure.log")
    open(log, "wb").close()
    dom = chromium(binary, ["--allow-file-access-from-files", "--virtual-time-budget=10000",
                            "--dump-dom"], "file://" + page, log)
    found = re.search(r'<pre id="out">(.*?)</pre>', dom, flags=re.S)
    rows = []
    if found:
        try:
            rows = json.loads(found.group(1).replace("&amp;", "&").replace("&lt;", "<")
                              .replace("&gt;", ">").replace("&quot;", '"'))
        except ValueError:
            rows = []
    check(bool(rows), f"the measuring page laid out the report's cards ({len(rows)} found)")
    cards = {row["name"]: row for row in rows if row["estimate"]}
    merit = [row for row in rows if not row["estimate"]]
    for name in ("J", "B"):
        p = report["parameters"][name]
        card = cards.get(name)
        check(card is not None, f"a headline card for {name}")
        if card is None:
            continue
        check(card["bottom"] <= 800, f"{name}'s card lies in the first 1280x800 screen "
              f"(bottom at {card['bottom']:.0f} px)")
        check(number_in(card["text"], p["value"]), f"{name}'s card shows {p['value']:.5g}: {card['text']!r}")
        ci = p.get("ci95")
        if ci:
            check(number_in(card["text"], ci[0]) and number_in(card["text"], ci[1]),
                  f"{name}'s card shows its 95 % interval [{ci[0]:.4g}, {ci[1]:.4g}]")
        check(all(card["bottom"] <= row["top"] + 1 for row in merit),
              f"{name}'s card comes before the figures of merit")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--chromium", default="/usr/bin/chromium")
    parser.add_argument("--html", required=True)
    parser.add_argument("--json", required=True)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    url = "file://" + os.path.abspath(args.html)
    log = os.path.join(args.out, "chromium.log")
    open(log, "wb").close()
    report = json.load(open(args.json))
    source = open(args.html, encoding="utf-8").read()
    # A trace whose u has no step gets a note instead of its first-transient plots.
    expected = expected_plots(report) - source.count("No first-transient view") * len(
        report["fit"]["observe"])

    # 1. The DOM as the browser built it.
    dom = chromium(args.chromium, ["--dump-dom"], url, log)
    with open(os.path.join(args.out, "dom.html"), "w", encoding="utf-8") as f:
        f.write(dom)
    svgs = re.findall(r"<svg\b.*?</svg>", dom, flags=re.S)
    figures = re.findall(r'<figure class="plot" id="(fig-\d+)" data-kind="([\w-]+)"', dom)
    check(len(svgs) == expected, f"{len(svgs)} <svg> elements in the rendered DOM (expected {expected})")
    check(len(figures) == expected, f"{len(figures)} figures in the rendered DOM (expected {expected})")
    check(source.count("<svg ") == expected, f"{source.count('<svg ')} <svg> in the file (expected {expected})")
    drawn = sum(1 for svg in svgs if re.search(r'<path class="curve" d="M[^"]+"', svg))
    check(drawn == expected, f"{drawn} of {len(svgs)} plots have a drawn curve")
    check("<script" not in dom and "<script" not in source, "no <script> in the page")
    check_linear_views(report, dom)
    kinds = {}
    for _, kind in figures:
        kinds[kind] = kinds.get(kind, 0) + 1
    print(f"      plots by kind: {kinds}")

    # 2. The whole page.
    page_png = os.path.join(args.out, "report.png")
    chromium(args.chromium, ["--window-size=1280,6000", f"--screenshot={page_png}"], url, log)
    check(os.path.exists(page_png), f"screenshot written: {page_png}")
    if os.path.exists(page_png):
        s = stats(page_png, CURVE_COLOURS)
        print(f"      page: {s['width']}x{s['height']}, {s['non_white']} non-white pixels, "
              f"{s['distinct_colours']} colours, curve pixels {s['colours']}")
        check(s["width"] == 1280 and s["height"] == 6000, "page screenshot is 1280x6000")
        check(s["non_white"] > 0.03 * s["pixels"], "page screenshot is not blank (> 3 % non-white)")
        check(s["distinct_colours"] > 500, "page screenshot has > 500 colours")
        check(min(s["colours"].values()) > 1000, "page shows both curve colours (> 1000 px each)")

    # 3. Each figure alone, enlarged by its #fig-N anchor.
    for figure_id, kind in figures:
        png = os.path.join(args.out, f"{figure_id}.png")
        chromium(args.chromium, ["--window-size=1000,620", f"--screenshot={png}"], f"{url}#{figure_id}", log)
        if not os.path.exists(png):
            check(False, f"{figure_id} ({kind}): screenshot written")
            continue
        s = stats(png, CURVE_COLOURS)
        curve = max(s["colours"].values())
        check(s["non_white"] > 0.02 * s["pixels"] and s["distinct_colours"] > 50 and curve > 150,
              f"{figure_id} ({kind}) rendered enlarged: {s['non_white']} non-white px, "
              f"{s['distinct_colours']} colours, {curve} px of a curve colour")

    # 5. The headline in the first screen: the page in a 1280x800 frame of a measuring page
    # (the report itself runs no script), which writes each headline card's text and where
    # it lies into its own DOM.
    check_headline(args.chromium, os.path.abspath(args.html), report, args.out)

    # 4. The console.
    messages = [line for line in open(log, encoding="utf-8", errors="replace") if CONSOLE.search(line)]
    for line in messages[:10]:
        print("      " + line.rstrip())
    check(not messages, f"no console messages or failed loads in {log} ({len(messages)} found)")

    print(f"browser test: {'PASSED' if not failures else 'FAILED'} "
          f"({len(failures)} failed check(s)); artefacts in {args.out}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
