// Trace CSV and config JSON (docs/trace-format.md, docs/config.md): exact round trips, and
// for every class of bad input the exact one-line message, with file:line:column where the
// reader knows them. The messages are the product's interface: a change here is a change
// users see.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "blmd/error.h"
#include "blmd/io/config.h"
#include "blmd/io/csv.h"
#include "blmd/io/files.h"
#include "blmd/random.h"
#include "support/test_support.h"

namespace blmd {
namespace {

// The message of the InputError that `body` throws ("" if it throws none).
template <typename F>
std::string ErrorOf(F&& body) {
  try {
    body();
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

CsvReadOptions WithRequired(std::vector<std::string> required) {
  CsvReadOptions options;
  options.required = std::move(required);
  return options;
}
CsvReadOptions WithTime(std::string time_column) {
  CsvReadOptions options;
  options.time_column = std::move(time_column);
  return options;
}

std::string CsvError(const std::string& text, const CsvReadOptions& options = {}) {
  return ErrorOf([&] { ParseTraceCsv(text, "trace.csv", options); });
}

// ---------------------------------------------------------------------------------------
// Trace CSV: round trip.

TEST(TraceCsv, RoundTripIsBitExact) {
  Random random(2024);
  Trace trace;
  std::vector<double> t, u, w;
  const std::vector<double> specials = {0.0,
                                        0.1,
                                        -1.5,
                                        1.0 / 3.0,
                                        3.141592653589793,
                                        1e-300,
                                        std::numeric_limits<double>::denorm_min(),
                                        std::numeric_limits<double>::min(),
                                        std::numeric_limits<double>::max(),
                                        -std::numeric_limits<double>::max(),
                                        1e21,
                                        123456789.125,
                                        2.261e-5};
  for (std::size_t k = 0; k < 2000; ++k) {
    t.push_back(static_cast<double>(k) * 1e-4 + 1e-9 * random.Uniform());
    u.push_back(k < specials.size() ? specials[k] : 48.0 * random.Uniform() - 24.0);
    // Arbitrary finite bit patterns, to cover every exponent.
    double x = 0.0;
    do {
      x = std::bit_cast<double>(random.Next());
    } while (!std::isfinite(x));
    w.push_back(x);
  }
  trace.Set("t", t);
  trace.Set("u", u);
  trace.Set("w", w);
  trace.comments = {"blmd-sim 0.1.0 model=dc_servo config=configs/ganesh-noload.json",
                    "effect coulomb_friction", "noise w sigma=0.5 seed=7"};
  const std::string text = FormatTraceCsv(trace);
  EXPECT_EQ(text.substr(0, text.find("t,u,w\n")),
            "# blmd-sim 0.1.0 model=dc_servo config=configs/ganesh-noload.json\n"
            "# effect coulomb_friction\n# noise w sigma=0.5 seed=7\n");
  const Trace back = ParseTraceCsv(text, "round-trip.csv");
  EXPECT_EQ(back.comments, trace.comments);
  ASSERT_EQ(back.names(), trace.names());
  ASSERT_EQ(back.rows(), trace.rows());
  for (const std::string name : {"t", "u", "w"}) {
    for (std::size_t k = 0; k < trace.rows(); ++k) {
      ASSERT_EQ(std::bit_cast<std::uint64_t>(back.Column(name)[k]),
                std::bit_cast<std::uint64_t>(trace.Column(name)[k]))
          << name << "[" << k << "] = " << FormatNumber(trace.Column(name)[k]);
    }
  }
  // The same through a file (written atomically: no temporary left beside it).
  testing::TempDir dir;
  WriteTraceCsv(trace, dir.File("trace.csv"));
  const Trace from_file = ReadTraceCsv(dir.File("trace.csv"));
  EXPECT_EQ(FormatTraceCsv(from_file), text);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()),
                          std::filesystem::directory_iterator()),
            1);
}

TEST(TraceCsv, AcceptedNumberForms) {
  const Trace trace =
      ParseTraceCsv("# comment\nt , u,w\n0, +1.5 ,-0\n.5,5.,1e-310\n1,-2E3,\t7\n", "ok.csv");
  EXPECT_EQ(trace.comments, std::vector<std::string>{"comment"});
  EXPECT_EQ(trace.names(), (std::vector<std::string>{"t", "u", "w"}));
  EXPECT_EQ(trace.Column("u"), (std::vector<double>{1.5, 5.0, -2000.0}));
  EXPECT_EQ(trace.Column("t"), (std::vector<double>{0.0, 0.5, 1.0}));
  // -0 is accepted and read as +0.
  EXPECT_EQ(trace.Column("w")[0], 0.0);
  EXPECT_FALSE(std::signbit(trace.Column("w")[0]));
  EXPECT_EQ(trace.Column("w")[1], 1e-310);  // subnormal, kept
  EXPECT_EQ(trace.Column("w")[2], 7.0);
  // A comment may be indented; then no column name can start with '#' (found by fuzzing:
  // a first name "#w" would be written back as a comment line).
  EXPECT_EQ(ParseTraceCsv("  # indented\n\t#tab\nt,u\n0,1\n", "ok.csv").comments,
            (std::vector<std::string>{"indented", "tab"}));
  // A final line without a newline is fine when it is complete.
  EXPECT_EQ(ParseTraceCsv("t,u\n0,1\n0.1,2", "x.csv").rows(), 2u);
  // Columns besides the standard ones are carried along.
  EXPECT_TRUE(ParseTraceCsv("t,u,temperature\n0,1,20\n", "x.csv").Has("temperature"));
  // Formatting writes -0 as 0.
  Trace negative_zero;
  negative_zero.Set("t", {-0.0});
  EXPECT_EQ(FormatTraceCsv(negative_zero), "t\n0\n");
}

// ReadTraceCsv reads a file in pieces (4 MiB by default); a line cut between two reads, a
// line longer than the buffer and the last line without '\n' read as ParseTraceCsv reads
// the whole text: the same values, or the same message. Every piece size from 1 byte.
TEST(TraceCsv, ReadingInPiecesMatchesTheWholeText) {
  testing::TempDir dir;
  const std::vector<std::string> texts = {
      "# c\nt,u,w\n0,1,2\n0.1,-3.5,1e-300\n0.2,4,5",
      "t,u\n0,1\n0.1,2\n",
      "t,u\n0,1\n0.1,2\n\n",                            // one final blank line is fine
      "t,u\n0,1\n\n0.1,2\n",                            // a blank line inside is not
      "t,u\n0,1\n0.1," + std::string(300, '7') + "\n",  // a line longer than small pieces
      std::string("\xEF\xBB\xBFt,u\n0,1\n"),
      std::string("t,u\n0,1\n0.1,2\n0.2,\0\n", 20),
      "t,u\r\n0,1\r\n",
      "t,u\n0,1\n0.1,1\n0.05,1\n",
      "t,u\n0,1\n0.1,1",
      "t,u\n0,1\n0.1,",
      "",
      "# only\n",
  };
  for (std::size_t k = 0; k < texts.size(); ++k) {
    const std::string& text = texts[k];
    const std::string path = dir.Write("t.csv", text);
    std::string whole_error;
    Trace whole;
    try {
      whole = ParseTraceCsv(text, path);
    } catch (const InputError& error) {
      whole_error = error.what();
    }
    for (std::size_t piece = 1; piece <= 40; ++piece) {
      SCOPED_TRACE("text " + std::to_string(k) + ", pieces of " + std::to_string(piece) + " bytes");
      CsvReadOptions options;
      options.read_chunk_bytes = piece;
      std::string sha;
      try {
        const Trace read = ReadTraceCsv(path, options, &sha);
        EXPECT_EQ(whole_error, "");
        EXPECT_EQ(read.names(), whole.names());
        EXPECT_EQ(read.comments, whole.comments);
        for (std::size_t c = 0; c < read.num_columns(); ++c)
          EXPECT_EQ(read.Column(c), whole.Column(c));
        EXPECT_EQ(sha, Sha256Hex(text));
      } catch (const InputError& error) {
        EXPECT_EQ(error.what(), whole_error);
      }
    }
  }
}

// ---------------------------------------------------------------------------------------
// Trace CSV: every class of bad input and its exact message.

// SHA-256 (OpenSSL): the FIPS 180-2 examples, and a 1 MB text fed whole and in odd pieces
// (every length 0..300 in pieces of 37 against the same bytes fed whole).
TEST(Sha256, KnownDigestsAndPiecesAgree) {
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(Sha256Hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(Sha256Hex(std::string(1000000, 'a')),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  Random random(42);
  std::string text;
  // Bytes 0..255 as unsigned char first: a double above 127 converted to (signed) char is
  // undefined behaviour (clang's float-cast-overflow check found it here).
  for (int k = 0; k < (1 << 20); ++k) {
    text += static_cast<char>(static_cast<unsigned char>(random.Uniform() * 256.0));
  }
  auto digest = [&](std::size_t length, std::size_t piece) {
    Sha256 sha;
    for (std::size_t at = 0; at < length; at += piece) {
      sha.Update(std::string_view(text).substr(at, std::min(piece, length - at)));
    }
    return sha.HexDigest();
  };
  for (std::size_t length = 0; length <= 300; ++length) {
    EXPECT_EQ(digest(length, 37), Sha256Hex(text.substr(0, length))) << length;
  }
  EXPECT_EQ(digest(text.size(), 1000), Sha256Hex(text));
  EXPECT_EQ(digest(text.size(), 4093), Sha256Hex(text));
}

TEST(TraceCsvErrors, EmptyFileAndMissingRows) {
  EXPECT_EQ(CsvError(""), "trace.csv: empty file: expected a header row such as 't,u,i,w'");
  EXPECT_EQ(CsvError("t,u,w\n"), "trace.csv:1: no data rows after the header");
  EXPECT_EQ(CsvError("# logger v2\n# rig 3\nt,u,w"), "trace.csv:3: no data rows after the header");
  EXPECT_EQ(CsvError("# only a comment\n"),
            "trace.csv:1: no header row: expected a row such as 't,u,i,w'");
  EXPECT_EQ(CsvError("\nt,u\n0,1\n"),
            "trace.csv:1:1: empty line where the header row was expected");
}

TEST(TraceCsvErrors, HeaderProblems) {
  EXPECT_EQ(CsvError("0,1,2\n0.1,1,2\n"),
            "trace.csv:1:1: header expected but found the number \"0\": the first row must name "
            "the columns, e.g. t,u,i,w");
  // ';' and tab separators and double-quoted names are read (they were errors):
  // csv_dialect_test.cc checks the values. '|' is not.
  EXPECT_EQ(CsvError("t;u;w\n0;1;2\n"), "");
  EXPECT_EQ(CsvError("t\tu\n0\t1\n"), "");
  EXPECT_EQ(CsvError("\"t\",\"u\"\n0,1\n"), "");
  EXPECT_EQ(CsvError("t|u|w\n0|1|2\n"),
            "trace.csv:1:1: header \"t|u|w\" is not comma separated (found '|'); use ',' between "
            "columns");
  EXPECT_EQ(CsvError("'t','u'\n0,1\n"),
            "trace.csv:1:1: quoted column name \"'t'\": write plain names such as t,u,w, or "
            "double quotes");
  EXPECT_EQ(CsvError("t,u,t\n0,1,2\n"), "trace.csv:1:3: duplicate column name 't'");
  EXPECT_EQ(CsvError("t,,w\n0,1,2\n"), "trace.csv:1:2: empty column name in the header");
  EXPECT_EQ(CsvError("t,u\n0,1\n", WithRequired({"t", "u", "w"})),
            "trace.csv: missing required column 'w' (header has: t,u)");
}

TEST(TraceCsvErrors, EncodingProblems) {
  EXPECT_EQ(
      CsvError("\xEF\xBB\xBFt,u\n0,1\n"),
      "trace.csv:1:1: file starts with a UTF-8 byte-order mark; save it as plain UTF-8/ASCII");
  // CRLF line ends are read (they were an error), also mixed with LF; CR alone is not.
  EXPECT_EQ(CsvError("t,u\r\n0,1\r\n"), "");
  EXPECT_EQ(CsvError("t,u\n0,1\n0.1,2\r\n"), "");
  EXPECT_EQ(CsvError("t,u\n0,1\r0.1,2\n"),
            "trace.csv:2:4: lines end with CR alone (old Mac line endings); convert the file with "
            "mac2unix");
  EXPECT_EQ(CsvError(std::string("t,u\n0,1\n0.1,\0", 13)),
            "trace.csv:3: binary data (NUL byte): not a CSV text file");
}

TEST(TraceCsvErrors, CellProblems) {
  EXPECT_EQ(CsvError("t,u\n0,\"1.5\"\n"), "");  // quoted numbers are read (RFC 4180)
  EXPECT_EQ(CsvError("t,u\n0,\"1.5\n"),
            "trace.csv:2:2: unclosed quote (a '\"' without its closing '\"')");
  EXPECT_EQ(CsvError("t,u,w\n0,1,2\n0.1,abc,2\n"),
            "trace.csv:3:2: column 'u' is not a number (\"abc\")");
  EXPECT_EQ(CsvError("t,u,w\n0,1,2.5V\n"), "trace.csv:2:3: column 'w' is not a number (\"2.5V\")");
  EXPECT_EQ(CsvError("t,u\n0,+-1\n"), "trace.csv:2:2: column 'u' is not a number (\"+-1\")");
  EXPECT_EQ(CsvError("t,u\n0,nan\n"), "trace.csv:2:2: column 'u' is not finite (\"nan\")");
  EXPECT_EQ(CsvError("t,u\n0,NaN\n"), "trace.csv:2:2: column 'u' is not finite (\"NaN\")");
  EXPECT_EQ(CsvError("t,u\n0,nan?\n"), "trace.csv:2:2: column 'u' is not a number (\"nan?\")");
  EXPECT_EQ(CsvError("t,u\n0,inf\n"), "trace.csv:2:2: column 'u' is not finite (\"inf\")");
  EXPECT_EQ(CsvError("t,u\n0,-Infinity\n"),
            "trace.csv:2:2: column 'u' is not finite (\"-Infinity\")");
  EXPECT_EQ(CsvError("t,u\n0,1e400\n"),
            "trace.csv:2:2: column 'u' value \"1e400\" is out of the double range");
  EXPECT_EQ(CsvError("t,u\n0,-1e400\n"),
            "trace.csv:2:2: column 'u' value \"-1e400\" is out of the double range");
  EXPECT_EQ(CsvError("t,u\n0,\n"), "trace.csv:2:2: column 'u' is empty");
  EXPECT_EQ(CsvError("t,u\n0,  \n"), "trace.csv:2:2: column 'u' is empty");
}

TEST(TraceCsvErrors, RowShapeProblems) {
  EXPECT_EQ(CsvError("t,u\n0,1,2\n"), "trace.csv:2:3: too many fields: the header has 2 columns");
  EXPECT_EQ(CsvError("t,u,w\n0,1\n0.1,1,2\n"),
            "trace.csv:2:3: too few fields: expected 3, found 2");
  // A truncated last line (a logger killed mid-write) says so.
  EXPECT_EQ(CsvError("t,u,w\n0,1,2\n0.1,1"),
            "trace.csv:3:3: too few fields: expected 3, found 2 (truncated last line?)");
  EXPECT_EQ(CsvError("t,u,w\n0,1,2\n0.1,1,"),
            "trace.csv:3:3: column 'w' is empty (truncated last line?)");
  EXPECT_EQ(CsvError("t,u\n0,1\n\n0.1,2\n"), "trace.csv:3:1: empty line inside the data");
  EXPECT_EQ(CsvError("t,u\n0,1\n# note\n"),
            "trace.csv:3:1: comment line inside the data (only before the header)");
}

// A column name is echoed as at most 80 bytes: a quoted header name may be a whole line
// (a csv_fuzz campaign found a 1141-byte message from a 1100-byte name).
TEST(TraceCsvErrors, LongColumnNamesAreCutInMessages) {
  const std::string name(2000, 'n');
  const std::string cut = std::string(80, 'n') + "...";
  EXPECT_EQ(CsvError("t,\"" + name + "\"\n0,x\n"),
            "trace.csv:2:2: column '" + cut + "' is not a number (\"x\")");
  EXPECT_EQ(CsvError("t,\"" + name + "\"\n0,1e999\n"),
            "trace.csv:2:2: column '" + cut + "' value \"1e999\" is out of the double range");
  EXPECT_EQ(CsvError("t,\"" + name + "\",\"" + name + "\"\n0,1,2\n"),
            "trace.csv:1:3: duplicate column name '" + cut + "'");
}

TEST(TraceCsvErrors, TimeMustStrictlyIncrease) {
  EXPECT_EQ(CsvError("t,u\n0,1\n0.2,1\n0.1,1\n"),
            "trace.csv:4:1: time 't' must strictly increase (0.1 follows 0.2)");
  EXPECT_EQ(CsvError("# a\n# b\nt,u\n0,1\n0.1,1\n0.1,1\n"),
            "trace.csv:6:1: time 't' must strictly increase (0.1 repeats 0.1 of line 5); for "
            "several rows logged at one instant use --duplicate-time first|mean");
  EXPECT_EQ(CsvError("u,w,t\n1,2,0\n1,2,-0.5\n"),
            "trace.csv:3:3: time 't' must strictly increase (-0.5 follows 0)");
  // Irregular but increasing sampling is fine; another time column can be named, or none.
  EXPECT_EQ(CsvError("t,u\n0,1\n0.1,1\n0.1003,1\n0.25,1\n"), "");
  EXPECT_EQ(CsvError("time,u\n0,1\n0,1\n", WithTime("time")),
            "trace.csv:3:1: time 'time' must strictly increase (0 repeats 0 of line 2); for "
            "several rows logged at one instant use --duplicate-time first|mean");
  EXPECT_EQ(CsvError("t,u\n0,1\n0,1\n", WithTime("")), "");
}

TEST(TraceCsvErrors, UnreadableFile) {
  EXPECT_EQ(ErrorOf([] { ReadTraceCsv("/nonexistent/trace.csv"); }),
            "/nonexistent/trace.csv: cannot read: No such file or directory");
}

// ---------------------------------------------------------------------------------------
// Config JSON: the bundled configs load with the values written in them.

TEST(Config, EveryBundledConfigLoadsWithItsValues) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(testing::SourcePath("configs"))) {
    if (entry.path().extension() != ".json") continue;
    ++count;
    const std::string path = entry.path().string();
    SCOPED_TRACE(path);
    Config config;
    ASSERT_NO_THROW(config = LoadConfig(path));
    std::ifstream in(path);
    const nlohmann::json raw = nlohmann::json::parse(in);
    EXPECT_EQ(config.path, path);
    EXPECT_EQ(config.name, raw.value("name", ""));
    EXPECT_EQ(std::string(config.model->name()), raw["model"].get<std::string>());
    for (const auto& [name, value] : raw["parameters"].items()) {
      EXPECT_EQ(config.parameters.Get(name), value.get<double>()) << name;
    }
    if (raw.contains("experiment") && raw["experiment"].contains("duration")) {
      EXPECT_EQ(config.experiment.duration, raw["experiment"]["duration"].get<double>());
    }
    if (raw.contains("simulation") && raw["simulation"].contains("dt")) {
      EXPECT_EQ(config.simulation.dt, raw["simulation"]["dt"].get<double>());
    }
  }
  EXPECT_GE(count, 3);
}

TEST(Config, GaneshNoLoad) {
  const Config config = LoadConfig(testing::SourcePath("configs/ganesh-noload.json"));
  EXPECT_EQ(config.name, "ganesh-noload");
  EXPECT_EQ(config.model->name(), "dc_servo");
  EXPECT_EQ(config.parameters.Get("R"), 12.6);
  EXPECT_EQ(config.parameters.Get("L"), 0.283);
  EXPECT_EQ(config.parameters.Get("Kt"), 0.04);
  EXPECT_EQ(config.parameters.Get("Kb"), 0.04);
  EXPECT_EQ(config.parameters.Get("J"), 2.26e-5);
  EXPECT_EQ(config.parameters.Get("B"), 2.261e-5);
  EXPECT_TRUE(config.effects.empty());
  EXPECT_EQ(config.simulation.dt, 1e-5);
  EXPECT_EQ(config.experiment.input.kind, InputSignal::Kind::kStep);
  EXPECT_EQ(config.experiment.input.amplitude, 24.0);
  EXPECT_EQ(config.experiment.input.offset, 0.0);
  EXPECT_EQ(config.experiment.input.t0, 0.0);
  EXPECT_EQ(config.experiment.duration, 1.0);
  EXPECT_EQ(config.experiment.sample_rate, 10000.0);
  EXPECT_EQ(config.experiment.coast_off_time, -1.0);
  EXPECT_FALSE(config.experiment.closed_loop);
  EXPECT_EQ(config.identification.free, (std::vector<std::string>{"J", "B"}));
  EXPECT_EQ(config.identification.initial.Get("J"), 1e-5);
  EXPECT_EQ(config.identification.initial.Get("B"), 1e-5);
  EXPECT_EQ(config.Bounds("J"), (std::pair<double, double>{1e-7, 1e-2}));
  EXPECT_EQ(config.Bounds("B"), (std::pair<double, double>{1e-8, 1e-2}));
  // No explicit bounds: three decades either side of the value (12.6 ohm), within the
  // model's default range [1e-3, 1e3] (docs/config.md).
  EXPECT_EQ(config.Bounds("R"), (std::pair<double, double>{12.6 * 1e-3, 1e3}));
  EXPECT_EQ(config.identification.observe, (std::vector<std::string>{"i", "w"}));
  EXPECT_EQ(config.identification.method, "ceres");
  EXPECT_EQ(config.experiment.SampleTimes().size(), 10001u);
}

TEST(Config, GaneshLoad1AndPid) {
  const Config load1 = LoadConfig(testing::SourcePath("configs/ganesh-load1.json"));
  EXPECT_EQ(load1.parameters.Get("J"), 1.94e-5);
  EXPECT_EQ(load1.parameters.Get("B"), 4.52e-5);
  const Config pid = LoadConfig(testing::SourcePath("configs/ganesh-pid.json"));
  EXPECT_TRUE(pid.experiment.closed_loop);
  EXPECT_EQ(pid.experiment.pid.Kp, 15.0);
  EXPECT_EQ(pid.experiment.pid.Ki, 2.0);
  EXPECT_EQ(pid.experiment.pid.Kd, 0.8);
  EXPECT_EQ(pid.experiment.pid.tau_d, 0.002);
  EXPECT_EQ(pid.experiment.pid.u_max, 24.0);
  EXPECT_EQ(pid.experiment.input.amplitude, 1.0);
  EXPECT_EQ(pid.experiment.duration, 1.5);
  EXPECT_EQ(pid.experiment.sample_rate, 2000.0);
  EXPECT_EQ(pid.identification.method, "");  // the tool's default
  // No "initial": the parameter values; no "bounds": three decades either side of them.
  EXPECT_FALSE(pid.identification.initial.Has("J"));
  EXPECT_EQ(pid.Bounds("J"), (std::pair<double, double>{2.26e-5 * 1e-3, 2.26e-5 * 1e3}));
  EXPECT_EQ(pid.Bounds("B"), (std::pair<double, double>{2.261e-5 * 1e-3, 2.261e-5 * 1e3}));
}

TEST(Config, DefaultsEffectsAndInputs) {
  const Config config = ParseConfig(R"({
    "model": "dc_servo",
    "parameters": { "R": 1, "L": 0.01, "Kt": 0.1, "Kb": 0.1, "J": 1e-4, "B": 1e-4 },
    "effects": { "coulomb_friction": { "Tc": 0.01 }, "cogging": { "Tcog": 0.002, "periods": 12, "phase": 0.5 } },
    "experiment": { "input": { "type": "square", "amplitude": 5, "period": 0.2 },
                    "coast_off_time": 0.5, "initial": { "w": 3 } },
    "identification": { "free": "J, B, Tc", "observe": ["w"] }
  })",
                                    "inline.json");
  EXPECT_EQ(config.path, "inline.json");
  EXPECT_EQ(config.name, "");
  // The JSON object's members are read in name order, not in the order written.
  EXPECT_EQ(config.effects, (std::vector<std::string>{"cogging", "coulomb_friction"}));
  EXPECT_EQ(config.parameters.Get("Tc"), 0.01);
  EXPECT_EQ(config.parameters.Get("periods"), 12.0);
  EXPECT_EQ(config.simulation.dt, 1e-5);  // the model's default
  EXPECT_TRUE(config.simulation.regula_falsi);
  EXPECT_EQ(config.simulation.friction_smoothing_w, 0.0);
  EXPECT_EQ(config.simulation.divergence_limit, 1e9);
  EXPECT_EQ(config.experiment.input.kind, InputSignal::Kind::kSquare);
  EXPECT_EQ(config.experiment.input.offset, 0.0);
  EXPECT_EQ(config.experiment.input.t0, 0.0);
  EXPECT_EQ(config.experiment.duration, 1.0);
  EXPECT_EQ(config.experiment.sample_rate, 10000.0);
  EXPECT_EQ(config.experiment.coast_off_time, 0.5);
  EXPECT_EQ(config.experiment.initial.w, 3.0);
  EXPECT_EQ(config.experiment.initial.i, 0.0);
  EXPECT_EQ(config.identification.free, (std::vector<std::string>{"J", "B", "Tc"}));
  EXPECT_EQ(config.Bounds("Tc"), (std::pair<double, double>{0.0, 10.0}));
  EXPECT_EQ(config.identification.observe, (std::vector<std::string>{"w"}));
}

TEST(Config, RecordedInputIsReadRelativeToTheConfig) {
  testing::TempDir dir;
  dir.Write("drive.csv", "# bench log\nt,volts,open\n0,0,0\n0.1,12,0\n0.3,12,1\n");
  dir.Write("config.json", R"({
    "model": "dc_servo",
    "parameters": { "R": 12.6, "L": 0.283, "Kt": 0.04, "Kb": 0.04, "J": 2.26e-5, "B": 2.261e-5 },
    "experiment": { "input": { "type": "recorded", "file": "drive.csv", "column": "volts" } }
  })");
  const Config config = LoadConfig(dir.File("config.json"));
  EXPECT_EQ(config.experiment.input.kind, InputSignal::Kind::kRecorded);
  EXPECT_EQ(config.experiment.input.times, (std::vector<double>{0.0, 0.1, 0.3}));
  EXPECT_EQ(config.experiment.input.values, (std::vector<double>{0.0, 12.0, 12.0}));
  EXPECT_EQ(config.experiment.input.open, (std::vector<double>{0.0, 0.0, 1.0}));
  // A problem in the recorded file is reported against that file.
  dir.Write("drive.csv", "t,volts\n0,0\n0.1,x\n");
  EXPECT_EQ(ErrorOf([&] { LoadConfig(dir.File("config.json")); }),
            dir.File("drive.csv") + ":3:2: column 'volts' is not a number (\"x\")");
}

// ---------------------------------------------------------------------------------------
// Config JSON: every class of bad input and its exact message. kBase is valid; each case
// changes one thing. Line numbers of kBase: 2 model, 4..9 R L Kt Kb J B (keys at column 5),
// 11 identification, 12 free, 13 initial, 14 bounds.

constexpr const char* kBase = R"({
  "model": "dc_servo",
  "parameters": {
    "R": 12.6,
    "L": 0.283,
    "Kt": 0.04,
    "Kb": 0.04,
    "J": 2.26e-5,
    "B": 2.261e-5
  },
  "identification": {
    "free": ["J", "B"],
    "initial": { "J": 1e-5, "B": 1e-5 },
    "bounds": { "J": [1e-7, 1e-2], "B": [1e-8, 1e-2] }
  }
})";

// kBase with `from` (which must occur exactly once) replaced by `to`.
std::string Base(const std::string& from = "", const std::string& to = "") {
  std::string text = kBase;
  if (from.empty()) return text;
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  EXPECT_EQ(text.find(from, at + 1), std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

std::string ConfigError(const std::string& text) {
  return ErrorOf([&] { ParseConfig(text, "config.json"); });
}

TEST(ConfigErrors, BaseIsValid) { EXPECT_EQ(ConfigError(Base()), ""); }

TEST(ConfigErrors, InvalidJsonWithLineAndColumn) {
  EXPECT_EQ(ConfigError(Base("\"L\": 0.283,", "\"L\": 0.283,,")),
            "config.json:5:16: invalid JSON: syntax error while parsing object key - unexpected "
            "','; expected string literal");
  EXPECT_EQ(ConfigError("{\"model\": \"dc_servo\""),
            "config.json:1:21: invalid JSON: syntax error while parsing object - unexpected end "
            "of input; expected '}'");
  EXPECT_EQ(ConfigError(Base("\"Kb\": 0.04", "\"Kb\": 0.04.1")),
            "config.json:7:15: invalid JSON: syntax error while parsing object - invalid literal; "
            "last read: '0.04.'; expected '}'");
  EXPECT_EQ(ConfigError(""),
            "config.json:1:1: invalid JSON: syntax error while parsing value - unexpected end of "
            "input; expected '[', '{', or a literal");
  EXPECT_EQ(ConfigError("[1, 2]"),
            "config.json:1:1: '(top level)' must be an object, not an array");
}

TEST(ConfigErrors, EffectAngleIsMeasuredOrSimulated) {
  EXPECT_EQ(ParseConfig(Base(), "config.json").identification.effect_angle, "measured");
  EXPECT_EQ(ParseConfig(Base("\"free\": [\"J\", \"B\"],",
                             "\"free\": [\"J\", \"B\"], \"effect_angle\": \"simulated\","),
                        "config.json")
                .identification.effect_angle,
            "simulated");
  EXPECT_EQ(ConfigError(Base("\"free\": [\"J\", \"B\"],",
                             "\"free\": [\"J\", \"B\"], \"effect_angle\": \"free\",")),
            "config.json:12:25: effect_angle 'free' is not one of: measured, simulated");
}

TEST(ConfigErrors, UnknownKeysSuggestTheNearest) {
  EXPECT_EQ(
      ConfigError(Base("\"model\": \"dc_servo\",", "\"model\": \"dc_servo\", \"experimnet\": {},")),
      "config.json:2:24: unknown key 'experimnet' in '(top level)' (did you mean "
      "'experiment'?); valid keys: name, description, notes, model, axis, parameters, effects, "
      "simulation, experiment, identification");
  EXPECT_EQ(ConfigError(Base("\"B\": 2.261e-5", "\"b\": 2.261e-5")),
            "config.json:9:5: unknown key 'b' in 'parameters' (did you mean 'B'?); valid keys: R, "
            "L, Kt, Kb, J, B");
  EXPECT_EQ(
      ConfigError(Base("\"free\"", "\"fre\"")),
      "config.json:12:5: unknown key 'fre' in 'identification' (did you mean 'free'?); "
      "valid keys: free, initial, bounds, observe, method, options, error, filter_hz, decimate, "
      "weighting, noise_std, effect_angle, simulate_from");
  // Nothing close: no suggestion.
  EXPECT_EQ(ConfigError(Base("\"free\"", "\"zzzzzz\"")),
            "config.json:12:5: unknown key 'zzzzzz' in 'identification'; valid keys: free, "
            "initial, bounds, observe, method, options, error, filter_hz, decimate, weighting, "
            "noise_std, effect_angle, simulate_from");
}

TEST(ConfigErrors, MissingOrUnknownModel) {
  EXPECT_EQ(ConfigError(Base("  \"model\": \"dc_servo\",\n", "")),
            "config.json:1:1: missing \"model\" (one of: blmd, dc_servo, rigid_load)");
  EXPECT_EQ(ConfigError(Base("\"dc_servo\"", "\"dc_motor\"")),
            "config.json:2:3: unknown model 'dc_motor' (valid: blmd, dc_servo, rigid_load)");
}

TEST(ConfigErrors, WrongTypes) {
  EXPECT_EQ(ConfigError(Base("\"R\": 12.6", "\"R\": \"12.6\"")),
            "config.json:4:5: 'parameters.R' must be a number, not a string");
  EXPECT_EQ(ConfigError(Base("\"dc_servo\"", "3")),
            "config.json:2:3: 'model' must be a string, not a number");
  EXPECT_EQ(ConfigError(Base("\"free\": [\"J\", \"B\"]", "\"free\": 2")),
            "config.json:12:5: 'identification.free' must be an array of names, not a number");
  EXPECT_EQ(ConfigError(Base("[1e-7, 1e-2]", "[1e-7, true]")),
            "config.json:14:29: 'identification.bounds.J.1' must be a number, not true/false");
  EXPECT_EQ(ConfigError(Base("\"J\": 2.26e-5", "\"J\": null")),
            "config.json:8:5: 'parameters.J' must be a number, not null");
}

TEST(ConfigErrors, ImpossibleParameterValues) {
  EXPECT_EQ(ConfigError(Base("\"L\": 0.283", "\"L\": 0")),
            "config.json:5:5: parameter 'L' must be > 0 (got 0 H)");
  EXPECT_EQ(ConfigError(Base("\"R\": 12.6", "\"R\": -12.6")),
            "config.json:4:5: parameter 'R' must be > 0 (got -12.6 ohm)");
  EXPECT_EQ(ConfigError(Base("\"J\": 2.26e-5", "\"J\": 0")),
            "config.json:8:5: parameter 'J' must be > 0 (got 0 kg·m²)");
  EXPECT_EQ(
      ConfigError(
          Base("    \"B\": 2.261e-5\n", "").replace(Base().find("\"J\": 2.26e-5,") + 12, 1, "")),
      "config.json:3:3: missing parameter 'B' (viscous damping of motor and load, N·m·s/rad) "
      "for model dc_servo");
}

TEST(ConfigErrors, IdentificationSetUp) {
  EXPECT_EQ(ConfigError(Base("\"J\": [1e-7, 1e-2]", "\"J\": [1e-2, 1e-7]")),
            "config.json:14:17: bounds of 'J' are inverted or empty: lower 0.01 >= upper 1e-07");
  EXPECT_EQ(ConfigError(Base("\"J\": [1e-7, 1e-2]", "\"J\": [0, 1e-2]")),
            "config.json:14:17: lower bound of 'J' must be > 0 (it is a positive scale parameter)");
  EXPECT_EQ(ConfigError(Base("\"J\": [1e-7, 1e-2]", "\"J\": [1e-7]")),
            "config.json:14:17: bounds of 'J' must be [lower, upper]");
  EXPECT_EQ(ConfigError(Base("[\"J\", \"B\"]", "[\"J\", \"Bx\"]")),
            "config.json:12:19: unknown parameter 'Bx' (did you mean 'B'?)");
  EXPECT_EQ(ConfigError(Base("[\"J\", \"B\"]", "[\"J\", \"Tc\"]")),
            "config.json:12:19: parameter 'Tc' belongs to effect 'coulomb_friction', which the "
            "config does not declare under \"effects\"");
  EXPECT_EQ(ConfigError(Base("\"initial\": { \"J\": 1e-5", "\"initial\": { \"J\": 1.0")),
            "config.json:13:18: initial value 1 of 'J' is outside its bounds [1e-07, 0.01]");
  // No initial value: the parameter value is the start, and must lie inside the bounds.
  EXPECT_EQ(ConfigError(
                Base("\"initial\": { \"J\": 1e-5, \"B\": 1e-5 },", "\"initial\": { \"B\": 1e-5 },")
                    .replace(Base().find("\"J\": 2.26e-5"), 12, "\"J\": 0.5   ")),
            "config.json:8:5: initial value 0.5 of 'J' is outside its bounds [1e-07, 0.01]");
}

TEST(ConfigErrors, Effects) {
  const std::string effects_line = "  \"identification\": {";
  auto with_effects = [&](const std::string& effects) {
    return Base(effects_line, "  \"effects\": " + effects + ",\n" + effects_line);
  };
  EXPECT_EQ(
      ConfigError(with_effects("{ \"coulomb_fricton\": { \"Tc\": 0.01 } }")),
      "config.json:11:16: unknown effect 'coulomb_fricton' (valid: asymmetric_viscous, cogging, "
      "coulomb_friction, current_offset, dead_time, gravity, load_torque, quadratic_drag, spring, "
      "stribeck, two_mass) (did you mean 'coulomb_friction'?)");
  EXPECT_EQ(ConfigError(with_effects("{ \"friction\": { \"Tc\": 0.01 } }")),
            "config.json:11:16: unknown effect 'friction' (valid: asymmetric_viscous, cogging, "
            "coulomb_friction, current_offset, dead_time, gravity, load_torque, quadratic_drag, "
            "spring, stribeck, two_mass)");
  EXPECT_EQ(ConfigError(with_effects("{ \"coulomb_friction\": { \"tc\": 0.01 } }")),
            "config.json:11:38: unknown key 'tc' in 'effects.coulomb_friction' (did you mean "
            "'Tc'?); valid keys: Tc");
  EXPECT_EQ(ConfigError(with_effects("{ \"stribeck\": { \"Ts\": 0.01 } }")),
            "config.json:11:16: effect 'stribeck' needs parameter 'ws' (Stribeck velocity, rad/s)");
  EXPECT_EQ(ConfigError(with_effects("{ \"coulomb_friction\": { \"Tc\": -0.01 } }")),
            "config.json:11:38: effect parameter 'Tc' must be >= 0");
  EXPECT_EQ(ConfigError(with_effects("{ \"coulomb_friction\": 0.01 }")),
            "config.json:11:16: 'effects.coulomb_friction' must be an object, not a number");
}

TEST(ConfigErrors, ExperimentAndSimulation) {
  const std::string line = "  \"identification\": {";
  auto with = [&](const std::string& section) { return Base(line, "  " + section + ",\n" + line); };
  EXPECT_EQ(ConfigError(with("\"simulation\": { \"dt\": 0 }")),
            "config.json:11:19: 'simulation.dt' must be > 0 (got 0)");
  EXPECT_EQ(ConfigError(with("\"experiment\": { \"input\": { \"type\": \"ramp\" } }")),
            "config.json:11:30: unknown input type 'ramp' (valid: chirp, prbs, recorded, square, "
            "step, steps, sweep)");
  EXPECT_EQ(ConfigError(with("\"experiment\": { \"input\": { \"type\": \"square\" } }")),
            "config.json:11:19: square input needs \"period\" (s)");
  EXPECT_EQ(
      ConfigError(with(
          "\"experiment\": { \"input\": { \"type\": \"step\", \"amplitude\": 1, \"hold\": 2 } }")),
      "config.json:11:62: unknown key 'hold' in 'experiment.input'; valid keys: type, "
      "amplitude, offset, t0");
  EXPECT_EQ(ConfigError(with("\"experiment\": { \"input\": { \"type\": \"steps\", \"times\": [0, "
                             "0], \"values\": [1, 2] } }")),
            "config.json:11:60: step times must increase");
  // Loads (a trace brings its own time base), but cannot be run: the error is kept for
  // those that run the experiment (an identification from a trace never does).
  EXPECT_EQ(ErrorOf([&] {
              ParseConfig(with("\"experiment\": { \"sample_rate\": 1e6 }"), "config.json")
                  .experiment.CheckRunnable();
            }),
            "config.json:11:19: sample_rate 1000000 Hz is faster than the simulation step "
            "allows (1/dt = 100000 Hz); lower it or reduce dt");
  EXPECT_EQ(ConfigError(with("\"experiment\": { \"coast_off_time\": -1 }")),
            "config.json:11:19: coast_off_time must be >= 0 (s)");
  EXPECT_EQ(ConfigError(with("\"experiment\": { \"pid\": { \"Kp\": 1, \"u_max\": 0 } }")),
            "config.json:11:37: u_max must be > 0");
}

TEST(ConfigErrors, UnreadableFile) {
  EXPECT_EQ(ErrorOf([] { LoadConfig("/nonexistent/config.json"); }),
            "/nonexistent/config.json: cannot read: No such file or directory");
}

TEST(NearestName, EditDistanceWithinHalfTheLength) {
  EXPECT_EQ(NearestName("expriment", {"experiment", "effects"}), "experiment");
  EXPECT_EQ(NearestName("b", {"R", "B"}), "B");
  EXPECT_EQ(NearestName("coulomb", {"coulomb_friction"}), "");
  EXPECT_EQ(NearestName("x", {}), "");
}

}  // namespace
}  // namespace blmd
