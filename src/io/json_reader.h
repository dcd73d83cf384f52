// Private to the io layer: reading a JSON document with every error placed at its line and
// column (nlohmann::json keeps no positions, so the text is scanned once for them): the
// position index, the messages' helpers and the Reader that checks types, keys and ranges.
// The config loader (config.cc) reads through it.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <unordered_map>
#include <vector>

#include "blmd/error.h"
#include "blmd/format.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"

namespace blmd::json_reader {

using nlohmann::json;

struct Position {
  long line = 0;
  long column = 0;
};

// Maps a JSON pointer ("/parameters/R") to where its key (object member) or value (array
// element, root) starts in the text. nlohmann::json keeps no positions, so we scan once.
class PositionIndex {
 public:
  explicit PositionIndex(const std::string& text) { Scan(text); }
  Position Find(const std::string& pointer) const {
    const auto it = positions_.find(pointer);
    return it == positions_.end() ? Position{} : it->second;
  }
  // The pointer of the first object key that occurs twice in its object ("" when none),
  // and where its second occurrence is.
  const std::string& duplicate() const { return duplicate_; }
  Position duplicate_at() const { return duplicate_at_; }

 private:
  // Decodes the escape at text[k] ('\\') into *out (UTF-8); returns the bytes it took.
  static std::size_t Unescape(const std::string& text, std::size_t k, std::string* out) {
    const char e = text[k + 1];
    switch (e) {
      case 'b':
        *out += '\b';
        return 2;
      case 'f':
        *out += '\f';
        return 2;
      case 'n':
        *out += '\n';
        return 2;
      case 'r':
        *out += '\r';
        return 2;
      case 't':
        *out += '\t';
        return 2;
      case 'u':
        break;
      default:
        *out += e;
        return 2;  // \" \\ \/
    }
    auto hex4 = [&](std::size_t at, unsigned* value) {
      if (at + 4 > text.size()) return false;
      *value = 0;
      for (std::size_t d = at; d < at + 4; ++d) {
        const char h = text[d];
        const int digit = h >= '0' && h <= '9'   ? h - '0'
                          : h >= 'a' && h <= 'f' ? h - 'a' + 10
                          : h >= 'A' && h <= 'F' ? h - 'A' + 10
                                                 : -1;
        if (digit < 0) return false;
        *value = *value * 16 + static_cast<unsigned>(digit);
      }
      return true;
    };
    unsigned code = 0;
    if (!hex4(k + 2, &code)) return 2;
    std::size_t used = 6;
    unsigned low = 0;
    if (code >= 0xD800 && code <= 0xDBFF && k + 7 < text.size() && text[k + 6] == '\\' &&
        text[k + 7] == 'u' && hex4(k + 8, &low) && low >= 0xDC00 && low <= 0xDFFF) {
      code = 0x10000 + ((code - 0xD800) << 10) + (low - 0xDC00);
      used = 12;
    }
    if (code < 0x80) {
      *out += static_cast<char>(code);
    } else if (code < 0x800) {
      *out += static_cast<char>(0xC0 | (code >> 6));
      *out += static_cast<char>(0x80 | (code & 0x3F));
    } else if (code < 0x10000) {
      *out += static_cast<char>(0xE0 | (code >> 12));
      *out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
      *out += static_cast<char>(0x80 | (code & 0x3F));
    } else {
      *out += static_cast<char>(0xF0 | (code >> 18));
      *out += static_cast<char>(0x80 | ((code >> 12) & 0x3F));
      *out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
      *out += static_cast<char>(0x80 | (code & 0x3F));
    }
    return used;
  }

  struct Frame {
    bool is_object;
    std::string pointer;
    std::string key;  // object: last key read
    long index = 0;   // array: next element index
    bool expecting_key = true;
  };

  void Scan(const std::string& text) {
    long line = 1, column = 1;
    std::vector<Frame> stack;
    auto value_started = [&](long l, long c) {
      if (stack.empty()) {
        positions_.emplace("", Position{l, c});
        return std::string();
      }
      Frame& top = stack.back();
      if (top.is_object) return top.pointer + "/" + top.key;
      std::string pointer = top.pointer + "/" + std::to_string(top.index++);
      positions_.emplace(pointer, Position{l, c});
      return pointer;
    };
    for (std::size_t k = 0; k < text.size(); ++k) {
      const char c = text[k];
      if (c == '\n') {
        ++line;
        column = 1;
        continue;
      }
      const long here_line = line, here_column = column;
      ++column;
      if (c == '"') {
        std::string value;
        ++k;
        while (k < text.size() && text[k] != '"') {
          if (text[k] == '\\' && k + 1 < text.size()) {
            const std::size_t used = Unescape(text, k, &value);
            k += used;
            column += static_cast<long>(used);
            continue;
          }
          if (text[k] == '\n') return;  // malformed: the parser will report it
          value += text[k++];
          ++column;
        }
        ++column;
        if (!stack.empty() && stack.back().is_object && stack.back().expecting_key) {
          stack.back().key = value;
          stack.back().expecting_key = false;
          const std::string pointer = stack.back().pointer + "/" + value;
          if (!positions_.emplace(pointer, Position{here_line, here_column}).second &&
              duplicate_.empty()) {
            duplicate_ = pointer;  // the first key written twice (the JSON keeps one)
            duplicate_at_ = Position{here_line, here_column};
          }
        } else {
          value_started(here_line, here_column);
        }
      } else if (c == '{' || c == '[') {
        // Positions are for error messages; a config is a few levels deep. Past 64 levels
        // (garbage, or an attack: every pointer would copy the whole path, quadratic in the
        // depth) nothing more is indexed, and the parser reports the problem.
        if (stack.size() >= 64) return;
        std::string pointer = value_started(here_line, here_column);
        stack.push_back({c == '{', pointer, "", 0, true});
      } else if (c == '}' || c == ']') {
        if (!stack.empty()) stack.pop_back();
      } else if (c == ',') {
        if (!stack.empty() && stack.back().is_object) stack.back().expecting_key = true;
      } else if (c == '-' || (c >= '0' && c <= '9') || c == 't' || c == 'f' || c == 'n') {
        value_started(here_line, here_column);
        while (k + 1 < text.size() &&
               std::string_view(",}] \t\r\n").find(text[k + 1]) == std::string_view::npos) {
          ++k;
          ++column;
        }
      }
    }
  }

  std::unordered_map<std::string, Position> positions_;
  std::string duplicate_;
  Position duplicate_at_;
};

// Line and column (1-based, in bytes) of byte `offset` of `text`.
inline Position PositionOf(const std::string& text, std::size_t offset) {
  Position p{1, 1};
  const std::size_t end = std::min(offset, text.size());
  for (std::size_t k = 0; k < end; ++k) {
    if (text[k] == '\n') {
      ++p.line;
      p.column = 1;
    } else {
      ++p.column;
    }
  }
  return p;
}

// Control and non-ASCII bytes of a parser message as \xNN: one clean line whatever the file.
inline std::string Printable(const std::string& text) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  for (const char ch : text) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if (c < 0x20 || c >= 0x7f) {
      out += "\\x";
      out += hex[c >> 4];
      out += hex[c & 15];
    } else {
      out += ch;
    }
  }
  return out;
}

// A number for a message, %g with `digits` significant digits (1/dt prints as 100000).
inline std::string Short(double value, int digits = 6) { return FormatSignificant(value, digits); }

// The usual reason behind a JSON syntax error, from the text the parser read last
// ("last read: '...'"): a comment, single quotes, NaN or Infinity.
inline std::string SyntaxHint(const std::string& what) {
  const auto from = what.find("last read: '");
  if (from == std::string::npos) return {};
  const auto to = what.find("'; ", from + 12);
  std::string token =
      what.substr(from + 12, to == std::string::npos ? std::string::npos : to - from - 12);
  if (to == std::string::npos && !token.empty() && token.back() == '\'') token.pop_back();
  if (token.empty()) return {};
  if (token.back() == '/') return " (JSON has no comments)";
  if (token.back() == '\'') return " (JSON strings and keys take double quotes)";
  std::size_t word = token.size();
  while (word > 0 && std::isalpha(static_cast<unsigned char>(token[word - 1]))) --word;
  std::string tail = token.substr(word);
  for (auto& c : tail) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (!tail.empty() &&
      (std::string("nan").rfind(tail, 0) == 0 || std::string("infinity").rfind(tail, 0) == 0)) {
    return " (NaN and Infinity are not JSON numbers)";
  }
  return {};
}

// Nesting depth at which a config is refused (the real ones nest 4 deep): deeper input is
// not a config, and the position index would cost depth² to build.
constexpr int kMaxNesting = 64;

// Offset of the bracket that opens level kMaxNesting + 1, or npos.
inline std::size_t TooDeep(const std::string& text) {
  int depth = 0;
  bool in_string = false;
  for (std::size_t k = 0; k < text.size(); ++k) {
    const char c = text[k];
    if (in_string) {
      if (c == '\\') {
        ++k;
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
    } else if (c == '{' || c == '[') {
      if (++depth > kMaxNesting) return k;
    } else if (c == '}' || c == ']') {
      --depth;
    }
  }
  return std::string::npos;
}

// Receives nlohmann's SAX events only to learn where a number overflows (the DOM parser
// reports it without a position).
struct ErrorLocator {
  std::size_t position = 0;
  bool null() { return true; }
  bool boolean(bool) { return true; }
  bool number_integer(nlohmann::json::number_integer_t) { return true; }
  bool number_unsigned(nlohmann::json::number_unsigned_t) { return true; }
  bool number_float(nlohmann::json::number_float_t, const std::string&) { return true; }
  bool string(std::string&) { return true; }
  bool binary(nlohmann::json::binary_t&) { return true; }
  bool start_object(std::size_t) { return true; }
  bool key(std::string&) { return true; }
  bool end_object() { return true; }
  bool start_array(std::size_t) { return true; }
  bool end_array() { return true; }
  bool parse_error(std::size_t at, const std::string&, const nlohmann::detail::exception&) {
    position = at;
    return false;
  }
};

inline std::string TypeName(const json& value) {
  if (value.is_number()) return "a number";
  if (value.is_string()) return "a string";
  if (value.is_boolean()) return "true/false";
  if (value.is_array()) return "an array";
  if (value.is_object()) return "an object";
  return "null";
}

class Reader {
 public:
  Reader(const std::string& path, const PositionIndex& index) : path_(path), index_(index) {}

  [[noreturn]] void Fail(const std::string& pointer, const std::string& message) const {
    throw Error(pointer, message);
  }
  InputError Error(const std::string& pointer, const std::string& message) const {
    const Position p = index_.Find(pointer);
    return InputError(path_, p.line, p.column, message);
  }

  static std::string Label(const std::string& pointer) {
    std::string label = pointer.empty() ? "(top level)" : pointer.substr(1);
    std::replace(label.begin(), label.end(), '/', '.');
    return label;
  }

  void RequireObject(const json& value, const std::string& pointer) const {
    if (!value.is_object()) {
      Fail(pointer, "'" + Label(pointer) + "' must be an object, not " + TypeName(value));
    }
  }

  void CheckKeys(const json& object, const std::string& pointer,
                 const std::vector<std::string>& allowed) const {
    for (const auto& [key, value] : object.items()) {
      if (std::find(allowed.begin(), allowed.end(), key) != allowed.end()) continue;
      const std::string near = NearestName(key, allowed);
      Fail(pointer + "/" + key, "unknown key '" + InputError::Excerpt(key) + "' in '" +
                                    Label(pointer) + "'" +
                                    (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                                    "; valid keys: " + Join(allowed));
    }
  }

  double Number(const json& value, const std::string& pointer) const {
    if (!value.is_number()) {
      Fail(pointer, "'" + Label(pointer) + "' must be a number, not " + TypeName(value));
    }
    const double v = value.get<double>();
    if (!std::isfinite(v)) Fail(pointer, "'" + Label(pointer) + "' must be finite");
    return v;
  }

  double Positive(const json& value, const std::string& pointer) const {
    const double v = Number(value, pointer);
    if (!(v > 0.0))
      Fail(pointer, "'" + Label(pointer) + "' must be > 0 (got " + FormatNumber(v) + ")");
    return v;
  }

  bool Bool(const json& value, const std::string& pointer) const {
    if (!value.is_boolean()) {
      Fail(pointer, "'" + Label(pointer) + "' must be true or false, not " + TypeName(value));
    }
    return value.get<bool>();
  }

  std::string String(const json& value, const std::string& pointer) const {
    if (!value.is_string()) {
      Fail(pointer, "'" + Label(pointer) + "' must be a string, not " + TypeName(value));
    }
    return value.get<std::string>();
  }

  // A string that must be one of `valid`: "NAME 'VALUE' is not one of: a, b" otherwise.
  std::string Choice(const json& value, const std::string& pointer, const std::string& name,
                     const std::vector<std::string>& valid) const {
    std::string text = String(value, pointer);
    if (std::find(valid.begin(), valid.end(), text) == valid.end()) {
      std::string list;
      for (const auto& v : valid) list += (list.empty() ? "" : ", ") + v;
      Fail(pointer, name + " '" + InputError::Excerpt(text) + "' is not one of: " + list);
    }
    return text;
  }

  std::vector<double> Numbers(const json& value, const std::string& pointer) const {
    if (!value.is_array()) {
      Fail(pointer, "'" + Label(pointer) + "' must be an array of numbers, not " + TypeName(value));
    }
    std::vector<double> out;
    for (std::size_t k = 0; k < value.size(); ++k) {
      out.push_back(Number(value[k], pointer + "/" + std::to_string(k)));
    }
    return out;
  }

  std::vector<std::string> Strings(const json& value, const std::string& pointer) const {
    if (value.is_string()) {  // "J,B" is accepted too
      std::vector<std::string> out;
      std::string item;
      for (char c : value.get<std::string>() + ",") {
        if (c == ',') {
          if (!item.empty()) out.push_back(item);
          item.clear();
        } else if (c != ' ') {
          item += c;
        }
      }
      return out;
    }
    if (!value.is_array()) {
      Fail(pointer, "'" + Label(pointer) + "' must be an array of names, not " + TypeName(value));
    }
    std::vector<std::string> out;
    for (std::size_t k = 0; k < value.size(); ++k) {
      out.push_back(String(value[k], pointer + "/" + std::to_string(k)));
    }
    return out;
  }

  const std::string& path() const { return path_; }

 private:
  std::string path_;
  const PositionIndex& index_;
};

}  // namespace blmd::json_reader
