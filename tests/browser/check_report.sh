#!/usr/bin/env bash
# ctest's browser test of the HTML report (docs/report.md): runs the demo's identification
# (as scripts/demo does) with --html, then checks the page in headless Chromium
# (check_report.py). Skipped, with exit code 77 and a message, when Chromium is missing.
# Usage: check_report.sh BIN_DIR SOURCE_DIR OUT_DIR
set -euo pipefail
bin_dir=$1
source_dir=$2
out_dir=$3
chromium=${CHROMIUM:-/usr/bin/chromium}
if [[ ! -x "$chromium" ]]; then
  echo "SKIPPED: browser test of the HTML report: $chromium not found" \
       "(scripts/test installs Debian's chromium; or apt-get install chromium)"
  exit 77
fi
if ! command -v python3 >/dev/null; then
  echo "SKIPPED: browser test of the HTML report: python3 not found (it decodes the screenshots)"
  exit 77
fi
mkdir -p "$out_dir"
cd "$source_dir"
# The demo's run (scripts/demo); exit 1 (not converged) would still write both reports.
set +e
"$bin_dir/blmd-ident" --config configs/ganesh-square.json --trace testdata/dc-hidden-coulomb.csv --discover \
  --quiet --report "$out_dir/report.json" --html "$out_dir/report.html"
status=$?
set -e
if [[ $status -ne 0 || ! -f "$out_dir/report.html" ]]; then
  echo "FAIL: blmd-ident exited with $status and wrote no HTML report" >&2
  exit 1
fi
echo "report: $out_dir/report.html ($(stat -c %s "$out_dir/report.html") bytes)"
exec python3 "$source_dir/tests/browser/check_report.py" --chromium "$chromium" \
  --html "$out_dir/report.html" --json "$out_dir/report.json" --out "$out_dir"
