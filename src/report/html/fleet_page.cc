// The fleet's page (fleet_page.h): one row per drive, its parameters over its records.
#include "blmd/report/html/fleet_page.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "blmd/format.h"
#include "report/markup.h"

namespace blmd {
namespace {

using nlohmann::json;

double Value(const json& line, const std::string& key) {
  const auto it = line.find(key);
  return it != line.end() && it->is_number() ? it->get<double>() : NAN;
}
std::string Text(const json& line, const std::string& key) {
  const auto it = line.find(key);
  return it != line.end() && it->is_string() ? it->get<std::string>() : std::string();
}

// A small SVG of one parameter over a drive's records: the baseline's 95 % band (grey), the
// baseline (dashed), each record's value with its interval, drifted records in red.
std::string ParameterChart(const std::vector<const json*>& records, const std::string& name) {
  constexpr double kWidth = 220, kHeight = 60, kPad = 6;
  double low = INFINITY, high = -INFINITY;
  auto widen = [&](double v) {
    if (std::isfinite(v)) low = std::min(low, v), high = std::max(high, v);
  };
  for (const json* r : records) {
    for (const char* suffix : {"", "_ci95_low", "_ci95_high", "_baseline", "_baseline_ci95_low",
                               "_baseline_ci95_high"}) {
      widen(Value(*r, name + suffix));
    }
  }
  if (!std::isfinite(low)) return "<span class=\"none\">n/a</span>";
  if (high <= low) high = low + (low != 0.0 ? std::abs(low) * 1e-3 : 1.0);
  const double span = high - low;
  low -= 0.08 * span, high += 0.08 * span;
  auto y = [&](double v) { return kPad + (kHeight - 2 * kPad) * (high - v) / (high - low); };
  const std::size_t n = records.size();
  auto x = [&](std::size_t k) {
    return n == 1 ? kWidth / 2 : kPad + (kWidth - 2 * kPad) * static_cast<double>(k) / (n - 1);
  };
  std::ostringstream svg;
  svg << "<svg width=\"" << kWidth << "\" height=\"" << kHeight << "\" role=\"img\" aria-label=\""
      << name << " over the records\">";
  const json& last = *records.back();
  const double b = Value(last, name + "_baseline");
  const double bl = Value(last, name + "_baseline_ci95_low");
  const double bh = Value(last, name + "_baseline_ci95_high");
  if (std::isfinite(bl) && std::isfinite(bh)) {
    svg << "<rect x=\"0\" width=\"" << kWidth << "\" y=\"" << y(bh) << "\" height=\""
        << std::max(0.5, y(bl) - y(bh)) << "\" fill=\"#ddd\"/>";
  }
  if (std::isfinite(b)) {
    svg << "<line x1=\"0\" x2=\"" << kWidth << "\" y1=\"" << y(b) << "\" y2=\"" << y(b)
        << "\" stroke=\"#888\" stroke-dasharray=\"3 2\"/>";
  }
  for (std::size_t k = 0; k < n; ++k) {
    const json& r = *records[k];
    const double v = Value(r, name), lo = Value(r, name + "_ci95_low"),
                 hi = Value(r, name + "_ci95_high");
    if (!std::isfinite(v)) continue;
    const char* colour = Text(r, "status") == "drift" ? "#c00" : "#036";
    if (std::isfinite(lo) && std::isfinite(hi)) {
      svg << "<line x1=\"" << x(k) << "\" x2=\"" << x(k) << "\" y1=\"" << y(lo) << "\" y2=\""
          << y(hi) << "\" stroke=\"" << colour << "\"/>";
    }
    svg << "<circle cx=\"" << x(k) << "\" cy=\"" << y(v) << "\" r=\"2.5\" fill=\"" << colour
        << "\"><title>" << internal::Escape(Text(r, "date") + " " + Text(r, "id")) << ": " << name
        << " = " << DisplayNumber(v) << "</title></circle>";
  }
  svg << "</svg>";
  return svg.str();
}

}  // namespace

std::string FleetHtml(const std::vector<json>& lines, const FleetPageCounts& summary) {
  // The drives in the order of their first row; each drive's records by date (then order).
  std::vector<std::string> drives;
  std::map<std::string, std::vector<const json*>> records;
  for (const json& line : lines) {
    const std::string drive = Text(line, "drive");
    if (!records.count(drive)) drives.push_back(drive);
    records[drive].push_back(&line);
  }
  for (auto& [drive, list] : records) {
    std::stable_sort(list.begin(), list.end(), [](const json* a, const json* b) {
      return Text(*a, "date") < Text(*b, "date");
    });
  }
  // Flagged first: a drive whose latest record failed, then drifted, then the others.
  auto rank = [&](const std::string& drive) {
    const std::string status = Text(*records[drive].back(), "status");
    return status == "error" ? 0 : status == "drift" ? 1 : 2;
  };
  std::stable_sort(drives.begin(), drives.end(),
                   [&](const std::string& a, const std::string& b) { return rank(a) < rank(b); });
  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
       << "<title>blmd-ident fleet</title><style>"
       << "body{font:14px sans-serif;margin:1.5em}table{border-collapse:collapse}"
       << "td,th{border-bottom:1px solid #ccc;padding:4px 8px;text-align:left;"
       << "vertical-align:middle}th{background:#f4f4f4}.error{color:#a00;font-weight:bold}"
       << ".drift{color:#c00;font-weight:bold}.ok{color:#060}.none{color:#999}"
       << ".msg{max-width:28em;font-size:12px}</style></head><body>\n"
       << "<h1>Fleet: " << drives.size() << " drives, " << summary.rows << " records</h1>\n"
       << "<p id=\"counts\">" << summary.ok << " ok, " << summary.drift << " drifted, "
       << summary.error << " failed. Drives whose latest record failed or drifted come first. "
       << "Grey band: the baseline's 95 % interval; dashed: the baseline; red: a drifted "
       << "record.</p>\n<table id=\"drives\"><thead><tr><th>drive</th><th>latest</th>"
       << "<th>J</th><th>B</th><th>drift z</th><th>message</th><th>records</th></tr></thead>"
       << "<tbody>\n";
  for (const std::string& drive : drives) {
    const std::vector<const json*>& list = records[drive];
    const json& last = *list.back();
    const std::string status = Text(last, "status");
    const double z = Value(last, "drift_z");
    html << "<tr class=\"drive\" data-status=\"" << status << "\"><td>" << internal::Escape(drive)
         << "</td><td class=\"" << status << "\">" << status << "<br>"
         << internal::Escape(Text(last, "date")) << "</td><td>" << ParameterChart(list, "J")
         << "</td><td>" << ParameterChart(list, "B") << "</td><td>"
         << (std::isfinite(z) ? DisplayNumber(z) : std::string("&ndash;"))
         << "</td><td class=\"msg\">" << internal::Escape(Text(last, "message")) << "</td><td>";
    for (const json* r : list) {
      const std::string report = Text(*r, "report");
      const std::string label =
          internal::Escape(Text(*r, "date").empty() ? Text(*r, "id") : Text(*r, "date"));
      if (report.empty()) {
        html << "<span class=\"" << Text(*r, "status") << "\">" << label << "</span> ";
      } else {
        html << "<a href=\"" << internal::Escape(report) << "\">" << label << "</a> ";
      }
    }
    html << "</td></tr>\n";
  }
  html << "</tbody></table>\n<p>The table: <a href=\"results.csv\">results.csv</a>, "
       << "<a href=\"results.jsonl\">results.jsonl</a>.</p></body></html>\n";
  return html.str();
}

}  // namespace blmd
