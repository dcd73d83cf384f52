// Text into SVG and HTML (private to the report layer): the five characters that markup
// gives a meaning escaped as entities, so a name or a message never breaks the page.
#pragma once

#include <string>

namespace blmd::internal {

inline std::string Escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace blmd::internal
