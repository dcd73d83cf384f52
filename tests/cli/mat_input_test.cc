// MATLAB .mat traces (docs/trace-format.md, "MATLAB .mat files"): the files are written here
// with libmatio's own API (v5, v4 and v7.3) and read through ReadTraceCsv, which hands them to
// ReadTraceMat, and through the commands. A .mat twin of a CSV trace gives the same numbers
// bit for bit (the doubles are the same); every variable that cannot be a column is refused
// with the exact message, naming the variable and its class, and exit 2 from the commands.
#include <gtest/gtest.h>
#include <matio.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "blmd/error.h"
#include "blmd/io/csv.h"
#include "blmd/io/mat.h"
#include "support/test_support.h"

namespace blmd::testing {
namespace {

// Writes variables to a new MAT file with libmatio; every write is checked.
class MatWriter {
 public:
  MatWriter(const std::string& path, mat_ft version)
      : mat_(Mat_CreateVer(path.c_str(), nullptr, version)) {}
  ~MatWriter() { Close(); }
  MatWriter(const MatWriter&) = delete;
  MatWriter& operator=(const MatWriter&) = delete;
  bool ok() const { return mat_ != nullptr; }
  void Close() {
    if (mat_) Mat_Close(mat_);
    mat_ = nullptr;
  }

  // A rows x columns double matrix, `values` column by column (MATLAB's order).
  void Doubles(const std::string& name, std::size_t rows, std::size_t columns,
               std::vector<double> values) {
    ASSERT_EQ(values.size(), rows * columns) << name;
    std::size_t dims[2] = {rows, columns};
    Write(Mat_VarCreate(name.c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, values.data(), 0));
  }
  void Column(const std::string& name, const std::vector<double>& values) {
    Doubles(name, values.size(), 1, values);
  }
  template <typename T>
  void Typed(const std::string& name, matio_classes type_class, matio_types type,
             std::vector<T> values, int flags = 0) {
    std::size_t dims[2] = {values.size(), 1};
    Write(Mat_VarCreate(name.c_str(), type_class, type, 2, dims, values.data(), flags));
  }
  void Text(const std::string& name, const std::string& text) {
    std::size_t dims[2] = {1, text.size()};
    Write(Mat_VarCreate(name.c_str(), MAT_C_CHAR, MAT_T_UTF8, 2, dims,
                        const_cast<char*>(text.data()), 0));
  }
  // A 1x2 cell {1, 2}.
  void Cell(const std::string& name) {
    std::size_t dims[2] = {1, 2}, one[2] = {1, 1};
    matvar_t* cell = Mat_VarCreate(name.c_str(), MAT_C_CELL, MAT_T_CELL, 2, dims, nullptr, 0);
    double values[2] = {1.0, 2.0};
    for (int k = 0; k < 2; ++k) {
      Mat_VarSetCell(cell, k,
                     Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, one, &values[k], 0));
    }
    Write(cell);
  }
  // A 1x1 struct with a vector field w and a scalar field k.
  void Struct(const std::string& name, std::vector<double> w, double k) {
    const char* fields[] = {"w", "k", nullptr};
    std::size_t one[2] = {1, 1}, column[2] = {w.size(), 1};
    matvar_t* s = Mat_VarCreateStruct2(name.c_str(), 2, one, fields);
    Mat_VarSetStructFieldByName(
        s, "w", 0, Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, column, w.data(), 0));
    Mat_VarSetStructFieldByName(s, "k", 0,
                                Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, one, &k, 0));
    Write(s);
  }
  void Complex(const std::string& name, std::vector<double> re, std::vector<double> im) {
    std::size_t dims[2] = {re.size(), 1};
    mat_complex_split_t z = {re.data(), im.data()};
    Write(Mat_VarCreate(name.c_str(), MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, &z, MAT_F_COMPLEX));
  }
  // A 4x1 sparse column with 1 and 2 in rows 1 and 3.
  void Sparse(const std::string& name) {
    std::size_t dims[2] = {4, 1};
    mat_uint32_t rows[2] = {0, 2}, starts[2] = {0, 2};
    double values[2] = {1.0, 2.0};
    mat_sparse_t sparse = {2, rows, 2, starts, 2, 2, values};
    Write(Mat_VarCreate(name.c_str(), MAT_C_SPARSE, MAT_T_DOUBLE, 2, dims, &sparse, 0));
  }

 private:
  void Write(matvar_t* var) {
    ASSERT_NE(var, nullptr);
    EXPECT_EQ(Mat_VarWrite(mat_, var, MAT_COMPRESSION_NONE), 0) << var->name;
    Mat_VarFree(var);
  }
  mat_t* mat_;
};

std::string ErrorOf(const std::string& path, const CsvReadOptions& options) {
  try {
    ReadTraceCsv(path, options);
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

CsvReadOptions Using(std::vector<std::string> columns, std::string time = "t") {
  CsvReadOptions options;
  options.strict_columns = std::move(columns);
  options.time_column = std::move(time);
  return options;
}

// Every kind of variable in one v5 file (written in this order).
void WriteEveryKind(const std::string& path, mat_ft version = MAT_FT_MAT5) {
  MatWriter mat(path, version);
  ASSERT_TRUE(mat.ok()) << path;
  mat.Column("t", {0.0, 0.1, 0.2, 0.3});
  mat.Doubles("u", 1, 4, {1.0, 2.0, 3.0, 4.0});  // a row vector is a column too
  mat.Doubles("M", 4, 2, {1.0, 2.0, 3.0, 4.0, 10.0, 20.0, 30.0, 40.0});
  mat.Doubles("gain", 1, 1, {35.15});
  mat.Text("label", "rig 3");
  mat.Cell("notes");
  mat.Struct("s", {5.0, 6.0, 7.0, 8.0}, 3.0);
  mat.Typed<std::uint8_t>("open", MAT_C_UINT8, MAT_T_UINT8, {0, 1, 1, 0}, MAT_F_LOGICAL);
  mat.Typed<std::int16_t>("counts", MAT_C_INT16, MAT_T_INT16, {-3, 0, 5, 7});
  mat.Typed<float>("f", MAT_C_SINGLE, MAT_T_SINGLE, {0.5f, 0.25f, -1.5f, 2.0f});
  mat.Column("short", {1.0, 2.0, 3.0});
  mat.Column("bad", {1.0, std::nan(""), 3.0, 4.0});
  mat.Column("far", {1.0, 2.0, 3.0, -std::numeric_limits<double>::infinity()});
  mat.Column("back", {0.0, 0.2, 0.1, 0.3});
  mat.Column("repeat", {0.0, 0.1, 0.1, 0.3});
  mat.Complex("z", {1.0, 2.0, 3.0, 4.0}, {0.0, 1.0, 0.0, 1.0});
  if (version == MAT_FT_MAT5) mat.Sparse("S");
}

TEST(MatInput, ColumnsAreVectorsMatrixColumnsAndStructFields) {
  TempDir dir;
  const std::string path = dir.File("every.mat");
  WriteEveryKind(path);
  EXPECT_TRUE(IsMatFile(path));
  std::string sha256;
  CsvReadOptions options = Using({"t", "u"});
  const Trace trace = ReadTraceCsv(path, options, &sha256);
  // In file order; scalars, text, cells, complex and sparse variables, the column of
  // another length and those with a non-finite value (not used) are left out.
  EXPECT_EQ(trace.names(), (std::vector<std::string>{"t", "u", "M:1", "M:2", "s.w", "open",
                                                     "counts", "f", "back", "repeat"}));
  EXPECT_EQ(trace.Column("t"), (std::vector<double>{0.0, 0.1, 0.2, 0.3}));
  EXPECT_EQ(trace.Column("u"), (std::vector<double>{1.0, 2.0, 3.0, 4.0}));
  EXPECT_EQ(trace.Column("M:2"), (std::vector<double>{10.0, 20.0, 30.0, 40.0}));
  EXPECT_EQ(trace.Column("s.w"), (std::vector<double>{5.0, 6.0, 7.0, 8.0}));
  EXPECT_EQ(trace.Column("open"), (std::vector<double>{0.0, 1.0, 1.0, 0.0}));
  EXPECT_EQ(trace.Column("counts"), (std::vector<double>{-3.0, 0.0, 5.0, 7.0}));
  EXPECT_EQ(trace.Column("f"), (std::vector<double>{0.5, 0.25, -1.5, 2.0}));
  EXPECT_TRUE(trace.comments.empty());
  EXPECT_EQ(sha256, blmd::testing::Run("sha256sum " + path).out.substr(0, 64));
  // The .mat extension is not needed: the header says what the file is.
  const std::string renamed = dir.File("every.bin");
  ASSERT_EQ(std::rename(path.c_str(), renamed.c_str()), 0);
  EXPECT_TRUE(IsMatFile(renamed));
  EXPECT_EQ(ReadTraceCsv(renamed, options).names(), trace.names());
  EXPECT_FALSE(IsMatFile(SourcePath("testdata/ganesh-noload-step.csv")));
}

TEST(MatInput, Version4FilesAreReadToo) {
  TempDir dir;
  const std::string path = dir.File("v4.mat");
  {
    MatWriter mat(path, MAT_FT_MAT4);
    ASSERT_TRUE(mat.ok());
    mat.Column("t", {0.0, 0.5, 1.0});
    mat.Doubles("u", 3, 2, {1.0, 2.0, 3.0, -1.0, -2.0, -3.0});
  }
  const Trace trace = ReadTraceCsv(path, Using({"t", "u:2"}));
  EXPECT_EQ(trace.names(), (std::vector<std::string>{"t", "u:1", "u:2"}));
  EXPECT_EQ(trace.Column("u:2"), (std::vector<double>{-1.0, -2.0, -3.0}));
}

// libmatio is built with HDF5 on Debian: a v7.3 file reads as its v5 twin. A libmatio without
// HDF5 cannot write one either; the reader is then given a v7.3 header and must refuse it
// with the message that says so.
TEST(MatInput, Version73ReadsAsVersion5OrIsRefusedClearly) {
  TempDir dir;
  const std::string v5 = dir.File("v5.mat"), v73 = dir.File("v73.mat");
  WriteEveryKind(v5);
  bool written = false;
  {
    MatWriter probe(v73, MAT_FT_MAT73);
    written = probe.ok();
  }
  const CsvReadOptions options = Using({"t", "u"});
  if (written) {
    WriteEveryKind(v73, MAT_FT_MAT73);
    const Trace five = ReadTraceCsv(v5, options), seven = ReadTraceCsv(v73, options);
    // HDF5 lists the variables by name, so the columns come in another order.
    ASSERT_EQ(seven.names(), (std::vector<std::string>{"M:1", "M:2", "back", "counts", "f", "open",
                                                       "repeat", "s.w", "t", "u"}));
    for (const std::string& name : seven.names()) {
      EXPECT_EQ(seven.Column(name), five.Column(name)) << name;
    }
    EXPECT_EQ(ErrorOf(v73, Using({"t", "label"})),
              v73 + ": variable 'label' is a char array (1x5 char), not numbers");
    // A damaged v7.3 file (its first 1000 bytes): HDF5 cannot open it.
    const std::string cut = dir.Write("cut.mat", Slurp(v73).substr(0, 1000));
    EXPECT_EQ(ErrorOf(cut, options),
              cut +
                  ": MATLAB v7.3 (HDF5) file: unreadable MAT file (libmatio: HDF5 error #000 "
                  "in H5Fopen())");
  } else {
    std::string header = Slurp(v5).substr(0, 128);
    header.replace(0, 19, "MATLAB 7.3 MAT-file");
    header[124] = 0;  // version 0x0200, little-endian ("IM")
    header[125] = 2;
    const std::string fake = dir.Write("fake73.mat", header + std::string(512, '\0'));
    EXPECT_EQ(ErrorOf(fake, options),
              fake +
                  ": MATLAB v7.3 (HDF5) file: this libmatio is built without HDF5 and cannot "
                  "read it; save it with -v7 or export CSV");
  }
}

TEST(MatInput, VariablesThatAreNoColumnAreNamedWithTheirClass) {
  TempDir dir;
  const std::string path = dir.File("every.mat");
  WriteEveryKind(path);
  auto error = [&](const std::string& name) { return ErrorOf(path, Using({"t", name})); };
  EXPECT_EQ(error("label"), path + ": variable 'label' is a char array (1x5 char), not numbers");
  EXPECT_EQ(error("notes"), path + ": variable 'notes' is a cell array (1x2 cell), not numbers");
  EXPECT_EQ(error("s"), path + ": variable 's' is a struct: its fields are read as s.w, s.k");
  EXPECT_EQ(error("s.k"), path +
                              ": variable 's.k' is a scalar (1x1 double), not a column: a "
                              "column is a vector, or a column of a matrix");
  EXPECT_EQ(error("gain"), path +
                               ": variable 'gain' is a scalar (1x1 double), not a column: a "
                               "column is a vector, or a column of a matrix");
  EXPECT_EQ(error("M"), path +
                            ": variable 'M' is a 4x2 double matrix: name one of its columns, "
                            "M:1 ... M:2");
  EXPECT_EQ(error("z"), path + ": variable 'z' is complex (4x1 double): a column must be real");
  EXPECT_EQ(error("S"), path +
                            ": variable 'S' is sparse (4x1 sparse): store it as a full "
                            "matrix, full(S)");
  EXPECT_EQ(error("short"), path +
                                ": variables 't' (4 values) and 'short' (3 values) differ in "
                                "length; the columns of a trace must have the same length");
  EXPECT_EQ(error("bad"), path +
                              ": variable 'bad' element 2 is NaN; a column a command uses "
                              "must hold finite numbers");
  EXPECT_EQ(error("far"), path +
                              ": variable 'far' element 4 is -Inf; a column a command uses "
                              "must hold finite numbers");
  const std::string matrix = dir.File("matrix.mat");
  {
    MatWriter mat(matrix, MAT_FT_MAT5);
    mat.Column("t", {0.0, 1.0, 2.0});
    mat.Doubles("M", 3, 2, {1.0, 2.0, 3.0, 4.0, std::nan(""), 6.0});
  }
  const std::string rows = dir.File("rows.mat");
  {
    MatWriter mat(rows, MAT_FT_MAT5);
    mat.Column("t", {0.0, 1.0, 2.0});
    mat.Doubles("X", 2, 3, {1.0, 10.0, 2.0, 20.0, 3.0, 30.0});  // one signal per row
  }
  EXPECT_EQ(ErrorOf(rows, Using({"t", "X:1"})),
            rows +
                ": variables 't' (3 values) and 'X:1' (2 values) differ in length; the "
                "columns of a trace must have the same length ('X' holds a signal in each "
                "row: store it transposed, X')");
  EXPECT_EQ(ErrorOf(matrix, Using({"t", "M:2"})),
            matrix +
                ": variable 'M' element (2,2), column 'M:2', is NaN; a column a command uses "
                "must hold finite numbers");
  // A missing variable: the CSV reader's message, listing the columns.
  CsvReadOptions required = Using({"t"});
  required.required = {"t", "w"};
  EXPECT_EQ(ErrorOf(path, required),
            path +
                ": missing required column 'w' (header has: t,u,M:1,M:2,s.w,open,counts,f,back,"
                "repeat)");
  // Without a list of used columns every column is read strictly, as in a CSV file.
  EXPECT_EQ(ErrorOf(path, CsvReadOptions{}),
            path +
                ": variables 't' (4 values) and 'short' (3 values) differ in length; the "
                "columns of a trace must have the same length");
}

// The time checks are the CSV reader's own: the place is given as in the file's CSV
// equivalent (line L is element L-1, the column the position in the trace).
TEST(MatInput, TimeChecksAreTheCsvReadersOwn) {
  TempDir dir;
  const std::string path = dir.File("every.mat");
  WriteEveryKind(path);
  EXPECT_EQ(ErrorOf(path, Using({"u"}, "back")),
            path + ":4:9: time 'back' must strictly increase (0.1 follows 0.2)");
  EXPECT_EQ(ErrorOf(path, Using({"u"}, "repeat")),
            path +
                ":4:10: time 'repeat' must strictly increase (0.1 repeats 0.1 of line 3); for "
                "several rows logged at one instant use --duplicate-time first|mean");
  CsvReadOptions mean = Using({"u"}, "repeat");
  mean.duplicate_time = DuplicateTime::kMean;
  const Trace merged = ReadTraceCsv(path, mean);
  EXPECT_EQ(merged.Column("repeat"), (std::vector<double>{0.0, 0.1, 0.3}));
  EXPECT_EQ(merged.Column("u"), (std::vector<double>{1.0, 2.5, 4.0}));
  EXPECT_EQ(merged.comments, std::vector<std::string>{
                                 "read with --duplicate-time mean: 1 repeated-time rows merged"});
}

TEST(MatInput, FilesThatAreNoMatFileAreRefused) {
  TempDir dir;
  const std::string text = dir.Write("text.mat", "t,u\n0,1\n");
  EXPECT_EQ(ErrorOf(text, {}),
            text + ": not a MATLAB .mat file (no MAT v5/v7/v7.3 header, and not a v4 file)");
  const std::string empty = dir.Write("empty.mat", "");
  EXPECT_EQ(ErrorOf(empty, {}), empty + ": empty file: not a MAT file");
  EXPECT_EQ(ErrorOf(dir.File("absent.mat"), {}),
            dir.File("absent.mat") + ": cannot read: No such file or directory");
  // A copy cut short: libmatio alone would read the variables before the cut.
  const std::string whole = dir.File("whole.mat");
  {
    MatWriter mat(whole, MAT_FT_MAT5);
    mat.Column("t", {0.0, 0.1, 0.2, 0.3});
  }
  const std::string bytes = Slurp(whole);
  const std::string cut = dir.Write("cut.mat", bytes.substr(0, bytes.size() - 8));
  EXPECT_EQ(ErrorOf(cut, {}), cut + ": MAT file cut short: the variable at byte 128 needs " +
                                  std::to_string(bytes.size() - 128) + " bytes, the file ends " +
                                  std::to_string(bytes.size() - 136) +
                                  " bytes after it (an interrupted copy?)");
  {
    MatWriter mat(dir.File("words.mat"), MAT_FT_MAT5);
    mat.Text("label", "no numbers here");
    mat.Doubles("gain", 1, 1, {2.0});
  }
  EXPECT_EQ(ErrorOf(dir.File("words.mat"), {}),
            dir.File("words.mat") +
                ": no variable is a numeric vector or matrix (variables: label,gain)");
}

// The reader ReadTraceMat feeds: CSV text cut anywhere reads as the whole text, errors too.
TEST(MatInput, CsvTextInPiecesReadsAsTheWholeText) {
  const std::string text = "# note\nt,u,\"w, rad/s\"\n0,1,2\n0.5,-0,3e-4\n1,2.5,4";
  for (const std::size_t size : {std::size_t{1}, std::size_t{3}, std::size_t{100}}) {
    std::size_t at = 0;
    auto pieces = [&] {
      const std::string piece = text.substr(std::min(at, text.size()), size);
      at += size;
      return piece;
    };
    const Trace whole = ParseTraceCsv(text, "log.csv"),
                cut = ParseTraceCsvPieces(pieces, "log.csv");
    EXPECT_EQ(cut.names(), whole.names()) << size;
    EXPECT_EQ(cut.comments, whole.comments) << size;
    for (std::size_t c = 0; c < whole.num_columns(); ++c) {
      EXPECT_EQ(cut.Column(c), whole.Column(c)) << size;
    }
  }
  std::size_t calls = 0;
  const std::string back = "t,u\n0,1\n0.2,1\n0.1,1\n";
  auto two = [&] { return ++calls == 1 ? back.substr(0, 9) : calls == 2 ? back.substr(9) : ""; };
  try {
    ParseTraceCsvPieces(two, "log.csv");
    ADD_FAILURE() << "time going back was read";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(), "log.csv:4:1: time 't' must strictly increase (0.1 follows 0.2)");
  }
}

// ---------------------------------------------------------------------------------------
// Through the commands: the bundled Ganesh trace (t,u,i,w,theta; 10 001 rows) as a .mat.

struct Twin {
  TempDir dir;
  std::string csv = SourcePath("testdata/ganesh-noload-step.csv");
  std::string mat = dir.File("ganesh.mat");
  std::string matrix = dir.File("ganesh-matrix.mat");
  Twin() {
    const Trace trace = ReadTraceCsv(csv);
    MatWriter vectors(mat, MAT_FT_MAT5);
    std::vector<double> all;
    for (const std::string& name : trace.names()) {
      vectors.Column(name, trace.Column(name));
      all.insert(all.end(), trace.Column(name).begin(), trace.Column(name).end());
    }
    vectors.Text("label", "Ganesh no-load step");
    vectors.Cell("notes");
    vectors.Column("short", {1.0, 2.0, 3.0});
    // The same columns as one matrix: data:1 ... data:5 = t, u, i, w, theta.
    MatWriter one(matrix, MAT_FT_MAT5);
    one.Doubles("data", trace.rows(), trace.num_columns(), all);
  }
};

std::string Ident(const std::string& trace, const std::string& rest) {
  return BinPath("blmd-ident") + " --config " + SourcePath("configs/ganesh-noload.json") +
         " --trace " + trace + " --quiet " + rest;
}

nlohmann::json Report(const std::string& command, const std::string& report) {
  const CommandResult run = blmd::testing::Run(command + " --report " + report);
  EXPECT_EQ(run.exit_code, 0) << command << "\n" << run.err;
  return run.exit_code == 0 ? nlohmann::json::parse(Slurp(report)) : nlohmann::json::object();
}

TEST(MatInput, IdentAndValidateOnAMatTwinGiveTheCsvNumbers) {
  Twin twin;
  const std::string validate = " --validate ";
  const nlohmann::json csv = Report(Ident(twin.csv, validate + twin.csv), twin.dir.File("c.json"));
  const nlohmann::json mat = Report(Ident(twin.mat, validate + twin.mat), twin.dir.File("m.json"));
  const nlohmann::json matrix =
      Report(Ident(twin.matrix, validate + twin.matrix +
                                    " --column t=data:1 --column u=data:2 --column i=data:3 "
                                    "--column w=data:4 --column theta=data:5"),
             twin.dir.File("x.json"));
  ASSERT_TRUE(csv.contains("parameters"));
  for (const nlohmann::json* report : {&mat, &matrix}) {
    ASSERT_TRUE(report->contains("parameters"));
    for (const char* name : {"J", "B"}) {
      EXPECT_EQ((*report)["parameters"][name]["value"].get<double>(),
                csv["parameters"][name]["value"].get<double>())
          << name;
    }
    EXPECT_EQ((*report)["fit"]["nrmse"].get<double>(), csv["fit"]["nrmse"].get<double>());
    EXPECT_EQ((*report)["validation"]["nrmse"].get<double>(),
              csv["validation"]["nrmse"].get<double>());
    EXPECT_EQ((*report)["trace"]["samples"], 10001);
  }
  EXPECT_EQ(mat["trace"]["sha256"].get<std::string>(),
            blmd::testing::Run("sha256sum " + twin.mat).out.substr(0, 64));
}

TEST(MatInput, SurfaceAndSimReadAMatTrace) {
  Twin twin;
  const std::string surface =
      BinPath("blmd-surface") + " --config " + SourcePath("configs/ganesh-noload.json") +
      " --grid J=1.5e-5:3e-5:4 --grid B=1.5e-5:3e-5:3 --json --quiet --trace ";
  const CommandResult csv =
      blmd::testing::Run(surface + twin.csv + " --out " + twin.dir.File("c.csv"));
  const CommandResult mat =
      blmd::testing::Run(surface + twin.mat + " --out " + twin.dir.File("m.csv"));
  ASSERT_EQ(csv.exit_code, 0) << csv.err;
  ASSERT_EQ(mat.exit_code, 0) << mat.err;
  const auto a = nlohmann::json::parse(csv.out), b = nlohmann::json::parse(mat.out);
  EXPECT_EQ(b["minimum"], a["minimum"]);
  EXPECT_EQ(b["minimum"]["cost"].get<double>(), a["minimum"]["cost"].get<double>());
  // blmd-sim driven by the u column of the .mat: the same simulated trace as from the CSV.
  const std::string sim = BinPath("blmd-sim") + " --config " +
                          SourcePath("configs/ganesh-noload.json") + " --quiet --input ";
  ASSERT_EQ(blmd::testing::Run(sim + twin.csv + " --out " + twin.dir.File("sc.csv")).exit_code, 0);
  ASSERT_EQ(blmd::testing::Run(sim + twin.mat + " --out " + twin.dir.File("sm.csv")).exit_code, 0);
  const Trace from_csv = ReadTraceCsv(twin.dir.File("sc.csv"));
  const Trace from_mat = ReadTraceCsv(twin.dir.File("sm.csv"));
  ASSERT_EQ(from_mat.names(), from_csv.names());
  EXPECT_EQ(from_mat.rows(), 10001u);
  for (const std::string& name : from_csv.names()) {
    EXPECT_EQ(from_mat.Column(name), from_csv.Column(name)) << name;
  }
}

// Refused by the command: exit 2, one line on stderr, no report written.
TEST(MatInput, CommandsRefuseUnusableVariablesWithExitTwo) {
  Twin twin;
  const std::string report = twin.dir.File("report.json");
  auto refused = [&](const std::string& flags) {
    const CommandResult run = blmd::testing::Run(Ident(twin.mat, flags + " --report " + report));
    EXPECT_EQ(run.exit_code, 2) << flags;
    EXPECT_FALSE(FileExists(report)) << flags;
    return run.err;
  };
  EXPECT_EQ(refused("--column u=label"),
            "error: " + twin.mat + ": variable 'label' is a char array (1x19 char), not numbers\n");
  EXPECT_EQ(refused("--column u=notes"),
            "error: " + twin.mat + ": variable 'notes' is a cell array (1x2 cell), not numbers\n");
  EXPECT_EQ(refused("--column u=short"),
            "error: " + twin.mat +
                ": variables 't' (10001 values) and 'short' (3 values) differ in length; the "
                "columns of a trace must have the same length\n");
  EXPECT_EQ(
      refused("--column u=volts"),
      "error: " + twin.mat + ": --column u=volts: no column 'volts' (header has: t,u,i,w,theta)\n");
  const CommandResult matrix = blmd::testing::Run(Ident(twin.matrix, "--column t=data"));
  EXPECT_EQ(matrix.exit_code, 2);
  EXPECT_EQ(matrix.err, "error: " + twin.matrix +
                            ": variable 'data' is a 10001x5 double matrix: name one of its "
                            "columns, data:1 ... data:5\n");
}

}  // namespace
}  // namespace blmd::testing
