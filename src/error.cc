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

}  // namespace blmd
