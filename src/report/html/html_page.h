// Private to the report layer: the pieces of the HTML page (html_report.cc) that its sections
// share, and the sections of the linear views (html_views.cc: correlation, frequency response,
// step response).
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "blmd/format.h"
#include "blmd/report/html/html_report.h"
#include "blmd/report/report.h"
#include "report/markup.h"

namespace blmd::internal {

// Colours (Okabe-Ito, see docs/report.md): the measurement is a light grey under the
// simulations; the fit is blue and solid, the model after discovery vermilion and dashed,
// so the two differ in greyscale too.
inline constexpr const char* kMeasuredColour = "#9a9a9a";
inline constexpr const char* kFitColour = "#0072b2";
inline constexpr const char* kAfterColour = "#d55e00";
inline constexpr const char* kAfterDash = "7 4";
inline constexpr const char* kBandColour = "#7f7f7f";

// `digits` significant digits: plain from 1e-3 to 1e6, else with a compact exponent
// ("2.2613e-5"); "n/a" when not finite.
inline std::string G(double v, int digits = 5) { return FormatReadable(v, digits); }

struct ColumnInfo {
  std::string quantity, unit;
};

// The model's input is a torque (N·m) rather than a voltage (ModelTraits).
inline bool InputIsTorque(const std::string& model) {
  for (const Model* m : ModelRegistry())
    if (m->name() == model) return m->traits().input_is_torque;
  return false;
}

inline ColumnInfo DescribeColumn(const std::string& column, const std::string& model) {
  if (column == "i" || column == "ib" || column == "ic") return {"current " + column, "A"};
  if (column == "w") return {"speed w", "rad/s"};
  if (column == "theta") return {"angle theta", "rad"};
  if (column == "u") return {"input u", InputIsTorque(model) ? "N·m" : "V"};
  return {column, ""};
}

class Page {
 public:
  explicit Page(const HtmlReportOptions& options) : options_(options) {}
  std::string& html() { return html_; }
  const HtmlReportOptions& options() const { return options_; }

  void Section(const std::string& id, const std::string& title) {
    section_ = id;
    html_ += "<section id=\"" + id + "\">\n<h2>" + Escape(title) + "</h2>\n";
  }
  void EndSection() { html_ += "</section>\n"; }

  // A figure: the plot, a caption, an "enlarge" link to itself and a "close" link back.
  void Figure(const std::string& kind, const std::string& attributes, const std::string& svg,
              const std::string& caption_html) {
    const std::string id = "fig-" + std::to_string(++figures_);
    html_ += "<figure class=\"plot\" id=\"" + id + "\" data-kind=\"" + kind + "\"" + attributes +
             ">\n<a class=\"zoom\" href=\"#" + id + "\">enlarge</a><a class=\"close\" href=\"#" +
             section_ + "\">close</a>\n" + svg + "<figcaption><b>Figure " +
             std::to_string(figures_) + ".</b> " + caption_html + "</figcaption>\n</figure>\n";
  }
  // id_prefix of the next figure's SVG (unique on the page).
  std::string NextPrefix() const { return "f" + std::to_string(figures_ + 1); }

 private:
  const HtmlReportOptions& options_;
  std::string html_;
  std::string section_;
  int figures_ = 0;
};

inline std::string Row(const std::vector<std::string>& cells_html,
                       const std::string& row_attributes = "",
                       const std::vector<bool>& numeric = {}) {
  std::string out = "<tr" + row_attributes + ">";
  for (std::size_t k = 0; k < cells_html.size(); ++k) {
    const bool num = k < numeric.size() && numeric[k];
    out += num ? "<td class=\"num\">" : "<td>";
    out += cells_html[k] + "</td>";
  }
  return out + "</tr>\n";
}

inline std::string HeaderRow(const std::vector<std::string>& names) {
  std::string out = "<tr>";
  for (const auto& name : names) out += "<th>" + Escape(name) + "</th>";
  return out + "</tr>\n";
}

// The linear views (html_views.cc). Inside the parameters section: the correlation matrix of
// the estimates as a table coloured by rho (a heat map that stays readable as numbers).
void WriteCorrelation(Page& page, const ParameterCorrelation& correlation);
// Sections of their own: the empirical frequency response against the model's Bode plot
// (magnitude, phase, coherence per output), and the model's step response with its figures.
void WriteFrequencyResponse(Page& page, const IdentReport& report);
void WriteStepResponse(Page& page, const IdentReport& report);

}  // namespace blmd::internal
