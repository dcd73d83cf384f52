#include "blmd/io/mat.h"

#include <fcntl.h>
#include <matio.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string_view>
#include <vector>

#include "blmd/error.h"
#include "blmd/io/files.h"
#include "io/matio_library.h"
#include "io/readable_file.h"

namespace blmd {
namespace {

using internal::Matio;
using internal::MatioLibrary;

// What the first 128 bytes of a file say: a MAT v5/v7 or v7.3 header, or neither.
enum class MatHeader { kNone, kV5, kV73 };

MatHeader ReadHeader(const std::string& path) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return MatHeader::kNone;
  struct Closer {
    int fd;
    ~Closer() { close(fd); }
  } closer{fd};
  struct stat info {};
  // Only a regular file is looked into: reading a pipe's first bytes would take them from
  // the CSV reader.
  if (fstat(fd, &info) != 0 || !S_ISREG(info.st_mode)) return MatHeader::kNone;
  unsigned char header[128];
  std::size_t held = 0;
  while (held < sizeof header) {
    const ssize_t n = read(fd, header + held, sizeof header - held);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return MatHeader::kNone;
    held += static_cast<std::size_t>(n);
  }
  // 116 bytes of text starting "MATLAB", 8 of subsystem offset, the version (int16) and the
  // endian mark "MI" as an int16 in the writer's byte order ("IM" little-endian).
  if (std::memcmp(header, "MATLAB", 6) != 0) return MatHeader::kNone;
  const bool little = header[126] == 'I' && header[127] == 'M';
  const bool big = header[126] == 'M' && header[127] == 'I';
  if (!little && !big) return MatHeader::kNone;
  const unsigned version = little ? header[124] | header[125] << 8 : header[124] << 8 | header[125];
  if (version == 0x0100) return MatHeader::kV5;
  if (version == 0x0200) return MatHeader::kV73;
  return MatHeader::kNone;
}

// libmatio stops quietly at a v5 variable cut short (an interrupted copy) and reads the
// variables before it: the top-level elements (an 8-byte tag each: type, size) must end where
// the file ends.
void CheckComplete(const std::string& path) {
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;
  struct Closer {
    int fd;
    ~Closer() { close(fd); }
  } closer{fd};
  struct stat info {};
  if (fstat(fd, &info) != 0 || !S_ISREG(info.st_mode)) return;
  const std::uint64_t size = static_cast<std::uint64_t>(info.st_size);
  unsigned char mark[2];
  if (pread(fd, mark, 2, 126) != 2) return;
  const bool swap = mark[0] == 'M';  // "MI": written big-endian
  std::uint64_t offset = 128;
  while (offset + 8 <= size) {
    unsigned char tag[8];
    if (pread(fd, tag, 8, static_cast<off_t>(offset)) != 8) return;
    auto word = [&](int at) {
      return swap ? std::uint32_t{tag[at]} << 24 | std::uint32_t{tag[at + 1]} << 16 |
                        std::uint32_t{tag[at + 2]} << 8 | tag[at + 3]
                  : std::uint32_t{tag[at + 3]} << 24 | std::uint32_t{tag[at + 2]} << 16 |
                        std::uint32_t{tag[at + 1]} << 8 | tag[at];
    };
    const std::uint32_t type = word(0), bytes = word(4);
    if (type == 0 && bytes == 0) return;  // zero padding after the last variable
    if (bytes > size - offset - 8) {
      throw InputError(path + ": MAT file cut short: the variable at byte " +
                       std::to_string(offset) + " needs " + std::to_string(bytes + 8) +
                       " bytes, the file ends " + std::to_string(size - offset) +
                       " bytes after it (an interrupted copy?)");
    }
    offset += 8 + bytes;
  }
}

// libmatio (and HDF5 under it) keeps global state and is not thread-safe: one file at a
// time. Its messages go to MatioLog instead of stderr; the first error is kept for ours.
std::mutex& MatioMutex() {
  static std::mutex mutex;
  return mutex;
}
std::string& MatioMessage() {
  static std::string message;
  return message;
}
void MatioLog(int level, char* message) {
  if ((level & (MATIO_LOG_LEVEL_ERROR | MATIO_LOG_LEVEL_CRITICAL)) && message &&
      MatioMessage().empty()) {
    const std::string_view text(message);
    MatioMessage() = std::string(text.substr(0, text.find('\n')));
  }
}

struct MatCloser {
  decltype(&Mat_Close) close;
  void operator()(mat_t* mat) const { close(mat); }
};
struct VarFreer {
  decltype(&Mat_VarFree) free;
  void operator()(matvar_t* var) const { free(var); }
};
using MatFile = std::unique_ptr<mat_t, MatCloser>;
using MatVar = std::unique_ptr<matvar_t, VarFreer>;

// One column of the trace, in file order.
struct MatColumn {
  std::string name;        // "t", "data:2", "s.f"
  std::string variable;    // the variable holding it: "t", "data", "s.f"
  std::size_t column = 0;  // 1-based column of a matrix, 0 for a vector
  std::vector<double> values;
  std::size_t matrix_columns = 0;  // the matrix's number of columns (0 for a vector)
};

// What the file holds: the columns, and by name every variable (or field) that is none,
// with what it is ("a char array (class char), not numbers").
struct MatContents {
  std::vector<MatColumn> columns;
  std::map<std::string, std::string> other;
  std::vector<std::string> variables;  // the top-level names, in file order
};

const char* ClassName(const matvar_t& var) {
  if (var.isLogical) return "logical";
  switch (var.class_type) {
    case MAT_C_CELL:
      return "cell";
    case MAT_C_STRUCT:
      return "struct";
    case MAT_C_OBJECT:
      return "object";
    case MAT_C_CHAR:
      return "char";
    case MAT_C_SPARSE:
      return "sparse";
    case MAT_C_DOUBLE:
      return "double";
    case MAT_C_SINGLE:
      return "single";
    case MAT_C_INT8:
      return "int8";
    case MAT_C_UINT8:
      return "uint8";
    case MAT_C_INT16:
      return "int16";
    case MAT_C_UINT16:
      return "uint16";
    case MAT_C_INT32:
      return "int32";
    case MAT_C_UINT32:
      return "uint32";
    case MAT_C_INT64:
      return "int64";
    case MAT_C_UINT64:
      return "uint64";
    case MAT_C_FUNCTION:
      return "function_handle";
    case MAT_C_OPAQUE:
      return "opaque";
    case MAT_C_EMPTY:
      break;
  }
  return "empty";
}

// "24841x1 double"
std::string SizeAndClass(const matvar_t& var) {
  std::string size;
  for (int k = 0; k < var.rank; ++k) size += (k ? "x" : "") + std::to_string(var.dims[k]);
  return (size.empty() ? "0x0" : size) + " " + ClassName(var);
}

std::size_t Elements(const matvar_t& var) {
  std::size_t n = var.rank > 0 ? 1 : 0;
  for (int k = 0; k < var.rank; ++k) n *= var.dims[k];
  return n;
}

bool IsNumericClass(matio_classes c) {
  return c == MAT_C_DOUBLE || c == MAT_C_SINGLE || (c >= MAT_C_INT8 && c <= MAT_C_UINT64);
}

template <typename T>
void AppendAs(const void* data, std::size_t first, std::size_t count, std::vector<double>* out) {
  const T* values = static_cast<const T*>(data) + first;
  out->reserve(count);
  for (std::size_t k = 0; k < count; ++k) out->push_back(static_cast<double>(values[k]));
}

// Elements [first, first + count) of a real numeric variable, as doubles.
std::vector<double> Values(const matvar_t& var, std::size_t first, std::size_t count) {
  std::vector<double> out;
  switch (var.class_type) {
    case MAT_C_DOUBLE:
      AppendAs<double>(var.data, first, count, &out);
      break;
    case MAT_C_SINGLE:
      AppendAs<float>(var.data, first, count, &out);
      break;
    case MAT_C_INT8:
      AppendAs<std::int8_t>(var.data, first, count, &out);
      break;
    case MAT_C_UINT8:
      AppendAs<std::uint8_t>(var.data, first, count, &out);
      break;
    case MAT_C_INT16:
      AppendAs<std::int16_t>(var.data, first, count, &out);
      break;
    case MAT_C_UINT16:
      AppendAs<std::uint16_t>(var.data, first, count, &out);
      break;
    case MAT_C_INT32:
      AppendAs<std::int32_t>(var.data, first, count, &out);
      break;
    case MAT_C_UINT32:
      AppendAs<std::uint32_t>(var.data, first, count, &out);
      break;
    case MAT_C_INT64:
      AppendAs<std::int64_t>(var.data, first, count, &out);
      break;
    case MAT_C_UINT64:
      AppendAs<std::uint64_t>(var.data, first, count, &out);
      break;
    default:
      break;
  }
  return out;
}

// Adds `var` (named `name`: a variable, or a struct's field "s.f") to `contents`: its
// columns, or what it is when it is none. A 1x1 struct's fields are added in turn.
void Collect(const matvar_t& var, const std::string& name, const std::string& path,
             MatContents* contents) {
  const MatioLibrary& matio = Matio(path);
  auto other = [&](const std::string& what) { contents->other[name] = what; };
  // (MATLAB names are identifiers; another writer's name with a line break in it could not
  // be a column name.)
  if (std::any_of(name.begin(), name.end(), [](char c) { return c >= 0 && c < 0x20; })) return;
  const std::size_t n = Elements(var);
  if (var.class_type == MAT_C_STRUCT) {
    if (n != 1) {
      return other("a " + SizeAndClass(var) +
                   " array: the fields of a 1x1 struct are columns, not those of a struct array");
    }
    std::string fields;
    const unsigned count = matio.VarGetNumberOfFields(const_cast<matvar_t*>(&var));
    char* const* names = matio.VarGetStructFieldnames(&var);
    for (unsigned k = 0; k < count && names; ++k) {
      matvar_t* field = matio.VarGetStructFieldByIndex(const_cast<matvar_t*>(&var),
                                                       static_cast<std::size_t>(k), 0);
      const std::string field_name = name + "." + names[k];
      if (field) Collect(*field, field_name, path, contents);
      if (fields.size() < 60) fields += (fields.empty() ? "" : ", ") + field_name;
    }
    return other("a struct: its fields are read as " + (fields.empty() ? "NAME.FIELD" : fields));
  }
  if (var.class_type == MAT_C_SPARSE) {
    return other("sparse (" + SizeAndClass(var) + "): store it as a full matrix, full(" + name +
                 ")");
  }
  if (!IsNumericClass(var.class_type)) {
    const std::string class_name = ClassName(var);
    const bool vowel = std::string_view("aeiou").find(class_name.front()) != std::string::npos;
    return other((vowel ? "an " : "a ") + class_name + " array (" + SizeAndClass(var) +
                 "), not numbers");
  }
  if (var.isComplex) {
    return other("complex (" + SizeAndClass(var) + "): a column must be real");
  }
  if (var.rank != 2) {
    return other("a " + SizeAndClass(var) + " array: only vectors and 2-D matrices are read");
  }
  if (n == 0) return other("empty (" + SizeAndClass(var) + ")");
  if (n == 1) {
    return other("a scalar (" + SizeAndClass(var) +
                 "), not a column: a column is a vector, or a column of a matrix");
  }
  if (!var.data || var.data_size != static_cast<int>(matio.SizeOfClass(var.class_type)) ||
      var.nbytes < n * static_cast<std::size_t>(var.data_size)) {
    throw InputError(path + ": variable '" + name + "' (" + SizeAndClass(var) +
                     ") could not be read: the file is damaged or of a layout libmatio "
                     "does not read");
  }
  const std::size_t rows = var.dims[0], columns = var.dims[1];
  if (rows == 1 || columns == 1) {
    contents->columns.push_back({name, name, 0, Values(var, 0, n), 0});
    return;
  }
  for (std::size_t c = 0; c < columns; ++c) {
    contents->columns.push_back(
        {name + ":" + std::to_string(c + 1), name, c + 1, Values(var, c * rows, rows), columns});
  }
  other("a " + SizeAndClass(var) + " matrix: name one of its columns, " + name + ":1 ... " + name +
        ":" + std::to_string(columns));
}

// The variables of the file, read with libmatio (under its lock).
MatContents ReadContents(const std::string& path, MatHeader header) {
  const MatioLibrary& matio = Matio(path);
  std::lock_guard<std::mutex> lock(MatioMutex());
  static const bool logging = [&matio] { return matio.LogInitFunc("blmd-ident", MatioLog) == 0; }();
  (void)logging;
  MatioMessage().clear();
  auto matio_says = [] {
    return MatioMessage().empty() ? std::string() : " (libmatio: " + MatioMessage() + ")";
  };
  const MatFile mat(matio.Open(path.c_str(), MAT_ACC_RDONLY), MatCloser{matio.Close});
  if (!mat) {
    if (header == MatHeader::kV73) {
      // ("No HDF5 support which is required to read the v7.3 MAT file": libmatio's words.)
      const bool no_hdf5 = MatioMessage().find("No HDF5") != std::string::npos;
      throw InputError(path + ": MATLAB v7.3 (HDF5) file: " +
                       (no_hdf5 ? std::string("this libmatio is built without HDF5 and cannot "
                                              "read it")
                                : "cannot be read" + matio_says()) +
                       "; save it with -v7 or export CSV");
    }
    throw InputError(path +
                     ": not a MATLAB .mat file (no MAT v5/v7/v7.3 header, and not a v4 file)");
  }
  std::size_t count = 0;
  char* const* names = matio.GetDir(mat.get(), &count);
  if (!MatioMessage().empty()) {
    throw InputError(path + (header == MatHeader::kV73 ? ": MATLAB v7.3 (HDF5) file" : "") +
                     ": unreadable MAT file" + matio_says());
  }
  MatContents contents;
  for (std::size_t k = 0; k < count && names; ++k) {
    if (names[k]) contents.variables.emplace_back(names[k]);
  }
  if (contents.variables.empty()) {
    throw InputError(path + ": the MAT file holds no variables");
  }
  for (const std::string& name : contents.variables) {
    const MatVar info(matio.VarReadInfo(mat.get(), name.c_str()), VarFreer{matio.VarFree});
    const bool wanted =
        info && (info->class_type == MAT_C_STRUCT ||
                 (IsNumericClass(info->class_type) && !info->isComplex && Elements(*info) > 1));
    const MatVar var(wanted ? matio.VarRead(mat.get(), name.c_str()) : nullptr,
                     VarFreer{matio.VarFree});
    if (!info || (wanted && !var)) {
      throw InputError(path + ": variable '" + name + "' could not be read" + matio_says());
    }
    Collect(var ? *var : *info, name, path, &contents);
  }
  return contents;
}

std::string NonFinite(double v) { return std::isnan(v) ? "NaN" : v > 0 ? "Inf" : "-Inf"; }

}  // namespace

bool IsMatFile(const std::string& path) {
  if (path.size() >= 4) {
    std::string extension = path.substr(path.size() - 4);
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (extension == ".mat") return true;
  }
  return ReadHeader(path) != MatHeader::kNone;
}

Trace ReadTraceMat(const std::string& path, const CsvReadOptions& options, std::string* sha256) {
  // The same errors as a CSV file for a file that cannot be opened; the bytes hashed.
  {
    const internal::ReadableFile file(path);
    if (file.regular() && file.size() == 0) throw InputError(path + ": empty file: not a MAT file");
    if (sha256) *sha256 = Sha256OfFile(path);
  }
  const MatHeader header = ReadHeader(path);
  if (header == MatHeader::kV5) CheckComplete(path);
  MatContents contents = ReadContents(path, header);

  // The names a command uses: a variable that is no column is an error naming it.
  std::set<std::string> used(options.required.begin(), options.required.end());
  used.insert(options.strict_columns.begin(), options.strict_columns.end());
  if (!options.time_column.empty()) used.insert(options.time_column);
  for (const std::string& name : used) {
    const auto found = contents.other.find(name);
    if (found != contents.other.end()) {
      throw InputError(path + ": variable '" + name + "' is " + found->second);
    }
  }
  if (contents.columns.empty()) {
    throw InputError(path + ": no variable is a numeric vector or matrix (variables: " +
                     HeaderSummary(contents.variables) + ")");
  }
  // As for a CSV file, every column is read strictly unless a list is given.
  const bool every_column = options.strict_columns.empty();
  auto is_used = [&](const MatColumn& column) {
    return every_column || used.count(column.name) > 0;
  };

  // One length: the time column's, else the first used column's; a column of another
  // length is an error when used, else left out (as a CSV column holding text).
  const MatColumn* reference = nullptr;
  for (const MatColumn& column : contents.columns) {
    if (column.name == options.time_column) reference = &column;
  }
  for (const MatColumn& column : contents.columns) {
    if (!reference && is_used(column)) reference = &column;
  }
  if (!reference) reference = &contents.columns.front();
  auto finite = [](const MatColumn& column) {
    return std::all_of(column.values.begin(), column.values.end(),
                       [](double v) { return std::isfinite(v); });
  };
  std::vector<const MatColumn*> kept;
  for (const MatColumn& column : contents.columns) {
    if (column.values.size() == reference->values.size()) {
      // A column not used that holds NaN or Inf is left out (as a CSV column holding text).
      if (is_used(column) || finite(column)) kept.push_back(&column);
    } else if (is_used(column)) {
      // A matrix as wide as the trace is long holds its signals in rows.
      const bool by_rows = column.matrix_columns == reference->values.size();
      throw InputError(path + ": variables '" + reference->name + "' (" +
                       std::to_string(reference->values.size()) + " values) and '" + column.name +
                       "' (" + std::to_string(column.values.size()) +
                       " values) differ in length; the columns of a trace must have the same "
                       "length" +
                       (by_rows ? " ('" + column.variable + "' holds a signal in each row: " +
                                      "store it transposed, " + column.variable + "')"
                                : std::string()));
    }
  }
  // A used column must be finite: the message names the variable and the element (1-based).
  for (const MatColumn* column : kept) {
    if (!is_used(*column)) continue;
    const auto& values = column->values;
    const auto bad =
        std::find_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); });
    if (bad == values.end()) continue;
    const std::size_t element = static_cast<std::size_t>(bad - values.begin()) + 1;
    const std::string where = column->column == 0 ? "element " + std::to_string(element)
                                                  : "element (" + std::to_string(element) + "," +
                                                        std::to_string(column->column) +
                                                        "), column '" + column->name + "',";
    throw InputError(path + ": variable '" + column->variable + "' " + where + " is " +
                     NonFinite(*bad) + "; a column a command uses must hold finite numbers");
  }

  // The rows, as CSV text in pieces of about 1 MiB, through the CSV reader's checks.
  std::size_t row = 0;
  const std::size_t rows = reference->values.size();
  bool header_done = false;
  auto next_piece = [&]() -> std::string {
    std::string piece;
    if (!header_done) {
      header_done = true;
      for (std::size_t c = 0; c < kept.size(); ++c) {
        piece += c ? ",\"" : "\"";
        for (const char ch : kept[c]->name)
          piece += ch == '"' ? std::string("\"\"") : std::string(1, ch);
        piece += '"';
      }
      piece += '\n';
    }
    char number[64];
    while (row < rows && piece.size() < (std::size_t{1} << 20)) {
      for (std::size_t c = 0; c < kept.size(); ++c) {
        if (c) piece += ',';
        const auto result = std::to_chars(number, number + sizeof number, kept[c]->values[row]);
        piece.append(number, result.ptr);
      }
      piece += '\n';
      ++row;
    }
    return piece;
  };
  CsvReadOptions csv = options;
  csv.delimiter = ',';
  return ParseTraceCsvPieces(next_piece, path, csv);
}

}  // namespace blmd
