#include "blmd/error.h"

namespace blmd {

std::string InputError::Format(const std::string& file, long line, long column,
                               const std::string& message) {
  std::string out;
  out.reserve(file.size() + message.size() + 32);
  out.append(file);
  if (line > 0) out.append(":").append(std::to_string(line));
  if (line > 0 && column > 0) out.append(":").append(std::to_string(column));
  if (out.empty()) return message;
  out.append(": ").append(message);
  return out;
}

std::string InputError::OneLine(const std::string& text) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c < 0x20 || c == 0x7f) {
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    } else {
      out += ch;
    }
  }
  return out;
}

}  // namespace blmd
