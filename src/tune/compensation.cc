#include "tune/compensation.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "blmd/constants.h"
#include "blmd/error.h"
#include "blmd/format.h"
#include "blmd/sim/effects.h"
#include "blmd/version.h"

namespace blmd {
namespace {

// The parameters of T_ff, in the order the files list them.
const std::vector<std::string>& TermNames() {
  static const std::vector<std::string> names = {"J",     "B",  "dB",     "Cd",   "Tc",
                                                 "Ts",    "ws", "TL",     "Tcog", "periods",
                                                 "phase", "K",  "theta0", "Tg",   "gravity_phase"};
  return names;
}

// Units and meanings in ASCII for the C and XML comments ("kg·m²" -> "kg m^2").
std::string Ascii(const std::string& text) {
  std::string out;
  for (std::size_t k = 0; k < text.size(); ++k) {
    if (text.compare(k, 2, "\xC2\xB7") == 0) {  // middle dot
      out += ' ';
      ++k;
    } else if (text.compare(k, 2, "\xC2\xB2") == 0) {  // superscript two
      out += "^2";
      ++k;
    } else if (static_cast<unsigned char>(text[k]) < 0x80) {
      out += text[k];
    }
  }
  return out;
}

std::string Exact(double v) { return FormatExact17(v); }

// "95 %: [lo, hi]" for a fitted value, "fixed (the config's value)" otherwise.
std::string IntervalText(const ExportedValue& v) {
  if (!v.in_model) return "not in the model";
  if (v.has_interval) return "95 %: [" + Exact(v.low) + ", " + Exact(v.high) + "]";
  if (v.fitted) return "fitted, no interval in the report";
  return "fixed (the config's value, not identified)";
}

double Sign(double w) { return w > 0.0 ? 1.0 : (w < 0.0 ? -1.0 : 0.0); }

}  // namespace

double Compensation::Value(const std::string& name) const {
  const auto it = values.find(name);
  return it == values.end() ? 0.0 : it->second.value;
}
void Compensation::Refresh() {
  numbers = {Value("J"),     Value("B"),  Value("dB"),     Value("Cd"),   Value("Tc"),
             Value("Ts"),    Value("ws"), Value("TL"),     Value("Tcog"), Value("periods"),
             Value("phase"), Value("K"),  Value("theta0"), Value("Tg"),   Value("gravity_phase")};
}
double Compensation::Inertia(double a) const { return numbers.J * a; }
double Compensation::Viscous(double w) const {
  return numbers.B * w + numbers.dB * std::abs(w) + numbers.Cd * w * std::abs(w);
}
double Compensation::Friction(double w) const {
  const double ws = numbers.ws;
  const double stribeck = ws > 0.0 ? numbers.Ts * std::exp(-(w / ws) * (w / ws)) : 0.0;
  return (numbers.Tc + stribeck) * Sign(w);
}
double Compensation::Load() const { return numbers.TL; }
double Compensation::Cogging(double theta) const {
  return numbers.Tcog * std::sin(numbers.periods * theta + numbers.phase);
}
double Compensation::Spring(double theta) const { return numbers.K * (theta - numbers.theta0); }
double Compensation::Gravity(double theta) const {
  return numbers.Tg * std::sin(theta + numbers.gravity_phase);
}
double Compensation::Torque(double theta, double w, double a) const {
  return Inertia(a) + Viscous(w) + Friction(w) + Load() + Cogging(theta) + Spring(theta) +
         Gravity(theta);
}

Compensation Compensation::FromReport(Config config, const StoredReport& report) {
  report.RequireModel(std::string(config.model->name()), "the report's model", "the config's");
  ApplyFinalModel(report, &config);
  for (const std::string& effect : config.effects) {
    if (FindEffect(effect).hidden_states) {
      throw InputError(report.path() + ": the final model's " + effect +
                       " has states of its own (a flexible coupling's load side): its "
                       "feed-forward needs the load's own trajectory, which a torque per motor "
                       "state cannot give; export a rigid model's report (identify without " +
                       effect +
                       ") or tune the loop around the resonance with blmd-tune --notch "
                       "auto");
    }
  }
  Compensation out;
  out.model = std::string(config.model->name());
  out.config_name = config.name;
  out.report_path = report.path();
  out.report_sha256 = report.sha256();
  out.linear_axis = config.linear_axis;
  const ModelTraits traits = config.model->traits();
  if (config.parameters.Has("Kt") &&
      (traits.input_is_torque || !traits.torque_current_column.empty())) {
    out.torque_per_input = config.parameters.Get("Kt");
    out.torque_is_command = traits.input_is_torque;
    out.torque_column = traits.input_is_torque ? "u" : traits.torque_current_column;
    out.input_unit = traits.input_is_torque ? "u" : "A";
  }
  for (const std::string& name : TermNames()) {
    ExportedValue v;
    v.in_model = config.parameters.Has(name);
    v.value = config.parameters.GetOr(name, 0.0);
    if (const ParamInfo* info = config.FindParameterInfo(name)) {
      v.unit = info->unit;
      v.meaning = info->meaning;
    }
    if (const StoredParameter* p = report.FindParameter(name)) {
      v.fitted = p->free;
      v.has_interval = p->has_ci95;
      v.low = p->ci95_low;
      v.high = p->ci95_high;
    }
    out.values[name] = v;
  }
  out.Refresh();
  return out;
}

CFiles CompensationC(const Compensation& c, int cogging_points) {
  if (cogging_points < 16 || cogging_points > 65536) {
    throw InputError("--cogging-points: " + std::to_string(cogging_points) +
                     " is out of range: 16 to 65536 points per revolution");
  }
  std::ostringstream h;
  h << "/* blmd_compensation.h: the feed-forward torque of an identified model, generated by "
       "blmd-export "
    << kVersion << ".\n"
    << " * Model " << c.model << " '" << Ascii(c.config_name) << "', report " << c.report_path
    << "\n * (sha256 " << c.report_sha256 << ").\n"
    << " *\n"
    << " * T_ff(theta, w, a) = J a + B w + dB |w| + Cd w |w| + (Tc + Ts exp(-(w/ws)^2)) sgn(w) + "
       "TL\n"
    << " *                   + Tcog sin(periods theta + phase) + K (theta - theta0)\n"
    << " *                   + Tg sin(theta + gravity_phase)\n"
    << " * the torque the drive adds so that the shaft follows the reference motion: evaluate it "
       "at\n"
    << " * the reference's angle (rad), speed (rad/s) and acceleration (rad/s^2); N m"
    << (c.linear_axis ? " (a linear axis: N, m, m/s, m/s^2)" : "") << ".\n"
    << " * Portable C99: no allocation, <math.h> only. Define BLMD_REAL as float before including\n"
    << " * this header for single precision (double by default), and BLMD_W_ZERO as the speed\n"
    << " * below which the friction's sign is taken as 0 (default 0: the sign of w).\n"
    << " * Each constant below carries its 95 % interval from the report (docs/export.md §6). */\n"
    << "#ifndef BLMD_COMPENSATION_H\n#define BLMD_COMPENSATION_H\n\n"
    << "#ifndef BLMD_REAL\n#define BLMD_REAL double\n#endif\n"
    << "#ifndef BLMD_W_ZERO\n#define BLMD_W_ZERO 0\n#endif\n"
    << "typedef BLMD_REAL blmd_real;\n\n";
  for (const std::string& name : TermNames()) {
    const ExportedValue& v = c.values.at(name);
    std::string macro = "BLMD_" + name;
    std::transform(macro.begin(), macro.end(), macro.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::toupper(ch)); });
    h << "#define " << macro << " ((blmd_real)" << Exact(v.value) << ") /* " << Ascii(v.unit)
      << (v.unit.empty() ? "" : ", ") << Ascii(v.meaning) << "; " << IntervalText(v) << " */\n";
  }
  h << "#define BLMD_TORQUE_PER_INPUT ((blmd_real)" << Exact(c.torque_per_input) << ") /* "
    << (c.torque_per_input > 0.0
            ? "N m per unit of the drive's input (" + c.input_unit + "): Kt"
            : "0: the model states no torque constant; blmd_ff_input returns 0")
    << " */\n"
    << "#define BLMD_COGGING_POINTS " << cogging_points << " /* table points per revolution */\n\n"
    << "/* The terms of T_ff (0 where the model lacks them). */\n"
    << "blmd_real blmd_ff_inertia(blmd_real a);\n"
    << "blmd_real blmd_ff_viscous(blmd_real w);   /* B w + dB |w| + Cd w |w| */\n"
    << "blmd_real blmd_ff_friction(blmd_real w);  /* (Tc + Ts exp(-(w/ws)^2)) sgn(w) */\n"
    << "blmd_real blmd_ff_load(void);\n"
    << "blmd_real blmd_ff_cogging(blmd_real theta);           /* the table, interpolated */\n"
    << "blmd_real blmd_ff_cogging_harmonic(blmd_real theta);  /* Tcog sin(periods theta + phase) "
       "*/\n"
    << "blmd_real blmd_ff_spring(blmd_real theta);\n"
    << "blmd_real blmd_ff_gravity(blmd_real theta);\n"
    << "/* Their sum (the cogging from the table), and the drive's input for it (T_ff / Kt). */\n"
    << "blmd_real blmd_ff_torque(blmd_real theta, blmd_real w, blmd_real a);\n"
    << "blmd_real blmd_ff_input(blmd_real theta, blmd_real w, blmd_real a);\n\n"
    << "#endif /* BLMD_COMPENSATION_H */\n";

  std::ostringstream s;
  s << "/* blmd_compensation.c: generated by blmd-export " << kVersion
    << " (see blmd_compensation.h). */\n"
    << "#include \"blmd_compensation.h\"\n\n#include <math.h>\n\n"
    << "#define BLMD_TWO_PI ((blmd_real)6.283185307179586476925286766559)\n\n"
    << "/* T_cog at theta = 2 pi k / BLMD_COGGING_POINTS, k = 0 .. BLMD_COGGING_POINTS - 1. */\n"
    << "static const blmd_real blmd_cogging_table[BLMD_COGGING_POINTS] = {\n";
  for (int k = 0; k < cogging_points; ++k) {
    const double theta = 2.0 * kPi * k / cogging_points;
    s << (k % 4 == 0 ? "    " : " ") << "(blmd_real)" << Exact(c.Cogging(theta))
      << (k + 1 < cogging_points ? "," : "") << (k % 4 == 3 || k + 1 == cogging_points ? "\n" : "");
  }
  s << "};\n\n"
    << "static blmd_real blmd_sign(blmd_real w) {\n"
    << "  return w > (blmd_real)BLMD_W_ZERO ? (blmd_real)1\n"
    << "         : (w < -(blmd_real)BLMD_W_ZERO ? (blmd_real)-1 : (blmd_real)0);\n}\n\n"
    << "blmd_real blmd_ff_inertia(blmd_real a) { return BLMD_J * a; }\n\n"
    << "blmd_real blmd_ff_viscous(blmd_real w) {\n"
    << "  blmd_real aw = w < 0 ? -w : w;\n"
    << "  return BLMD_B * w + BLMD_DB * aw + BLMD_CD * w * aw;\n}\n\n"
    << "blmd_real blmd_ff_friction(blmd_real w) {\n"
    << "  blmd_real stribeck = (blmd_real)0;\n"
    << "  if (BLMD_WS > 0) {\n"
    << "    blmd_real x = w / BLMD_WS;\n"
    << "    stribeck = BLMD_TS * (blmd_real)exp(-(double)(x * x));\n  }\n"
    << "  return (BLMD_TC + stribeck) * blmd_sign(w);\n}\n\n"
    << "blmd_real blmd_ff_load(void) { return BLMD_TL; }\n\n"
    << "blmd_real blmd_ff_cogging(blmd_real theta) {\n"
    << "  double x = (double)theta / (double)BLMD_TWO_PI * BLMD_COGGING_POINTS;\n"
    << "  double base = floor(x);\n"
    << "  blmd_real f = (blmd_real)(x - base);\n"
    << "  long k = (long)fmod(base, (double)BLMD_COGGING_POINTS);\n"
    << "  long next;\n"
    << "  if (k < 0) k += BLMD_COGGING_POINTS;\n"
    << "  next = k + 1 == BLMD_COGGING_POINTS ? 0 : k + 1;\n"
    << "  return blmd_cogging_table[k] + f * (blmd_cogging_table[next] - blmd_cogging_table[k]);\n"
       "}\n\n"
    << "blmd_real blmd_ff_cogging_harmonic(blmd_real theta) {\n"
    << "  return BLMD_TCOG * (blmd_real)sin((double)(BLMD_PERIODS * theta + BLMD_PHASE));\n}\n\n"
    << "blmd_real blmd_ff_spring(blmd_real theta) { return BLMD_K * (theta - BLMD_THETA0); }\n\n"
    << "blmd_real blmd_ff_gravity(blmd_real theta) {\n"
    << "  return BLMD_TG * (blmd_real)sin((double)(theta + BLMD_GRAVITY_PHASE));\n}\n\n"
    << "blmd_real blmd_ff_torque(blmd_real theta, blmd_real w, blmd_real a) {\n"
    << "  return blmd_ff_inertia(a) + blmd_ff_viscous(w) + blmd_ff_friction(w) + blmd_ff_load() +\n"
    << "         blmd_ff_cogging(theta) + blmd_ff_spring(theta) + blmd_ff_gravity(theta);\n}\n\n"
    << "blmd_real blmd_ff_input(blmd_real theta, blmd_real w, blmd_real a) {\n"
    << "  return BLMD_TORQUE_PER_INPUT > 0 ? blmd_ff_torque(theta, w, a) / BLMD_TORQUE_PER_INPUT\n"
    << "                                   : (blmd_real)0;\n}\n";
  return {h.str(), s.str()};
}

std::string ODriveSettings(const Compensation& c) {
  nlohmann::json out;
  out["generator"] = std::string("blmd-export ") + kVersion;
  out["report"] = {{"path", c.report_path}, {"sha256", c.report_sha256}};
  out["firmware"] = "ODrive 0.5.x";
  const ExportedValue& J = c.values.at("J");
  nlohmann::json inertia = {
      {"setting", "axis0.controller.config.inertia"},
      {"value", 2.0 * kPi * J.value},
      {"unit", "N·m/(turn/s²)"},
      {"conversion", "2 pi J: ODrive's acceleration is in turn/s², 1 turn/s² = 2 pi rad/s²"},
      {"firmware_use",
       "added to the torque command as inertia × the input's acceleration in the trajectory and "
       "filtered input modes (input_mode TRAP_TRAJ or POS_FILTER)"}};
  if (J.has_interval) inertia["ci95"] = {2.0 * kPi * J.low, 2.0 * kPi * J.high};
  out["inertia"] = inertia;
  nlohmann::json map = nlohmann::json::array();
  for (int k = 0; k < 3600; ++k) map.push_back(c.Cogging(2.0 * kPi * k / 3600.0));
  const ExportedValue& Tcog = c.values.at("Tcog");
  nlohmann::json cogging = {
      {"setting", "axis0.controller.config.anticogging.cogging_map"},
      {"unit", "N·m"},
      {"points", 3600},
      {"index",
       "k = floor(pos_estimate × 3600) mod 3600, pos_estimate in turns from the "
       "encoder's index; the record's theta = 0 must be that index"},
      {"firmware_use",
       "added to the torque command (torque += cogging_map[k]) when anticogging_enabled and "
       "the map is marked valid (pre_calibrated); the firmware fills it by its own "
       "calibration, so loading it needs a write of the 3600 values to the saved "
       "configuration (a firmware build or a script that writes each entry)"},
      {"map", map}};
  if (Tcog.has_interval) cogging["amplitude_ci95"] = {Tcog.low, Tcog.high};
  out["anticogging"] = cogging;
  nlohmann::json host = nlohmann::json::object();
  for (const char* name :
       {"B", "dB", "Cd", "Tc", "Ts", "ws", "TL", "K", "theta0", "Tg", "gravity_phase"}) {
    if (c.Value(name) != 0.0) host[name] = c.Value(name);
  }
  out["host_feed_forward"] = {
      {"setting", "axis0.controller.input_torque"},
      {"unit", "N·m"},
      {"why",
       "ODrive 0.5.x has no setting for damping, friction, load, spring or gravity: send "
       "their sum from the host (or a custom firmware: blmd-export --format c) as "
       "input_torque"},
      {"terms", host}};
  return out.dump(2) + "\n";
}

std::string MujocoModel(const Compensation& c) {
  const double frictionloss = c.Value("Tc") + c.Value("Ts");
  std::ostringstream x;
  x << "<!-- generated by blmd-export " << kVersion << " from " << c.report_path << " (sha256 "
    << c.report_sha256 << ").\n"
    << "     The identified shaft as a hinge joint (docs/export.md §6): armature = J, damping = "
       "B,\n"
    << "     frictionloss = Tc + Ts (the breakaway; MuJoCo's dry friction has no Stribeck\n"
    << "     curve), stiffness and springref = the spring's K and theta0. The body's own\n"
    << "     inertia is negligible so that the armature carries the identified J.\n";
  for (const char* name : {"J", "B", "Tc", "Ts", "K", "theta0"}) {
    const ExportedValue& v = c.values.at(name);
    if (name != std::string("J") && name != std::string("B") && v.value == 0.0) continue;
    x << "     " << name << " = " << Exact(v.value) << " " << Ascii(v.unit) << ": "
      << IntervalText(v) << "\n";
  }
  std::vector<std::string> left;
  for (const char* name : {"dB", "Cd", "TL", "Tcog", "Tg"}) {
    if (c.Value(name) != 0.0) left.push_back(name);
  }
  if (!left.empty()) {
    x << "     Not expressible on an MJCF joint, apply them as a generalised force\n"
         "     (qfrc_applied) in a control callback:";
    for (const std::string& name : left) x << " " << name << " = " << Exact(c.Value(name));
    x << ".\n";
  }
  x << "-->\n"
    << "<mujoco model=\"" << Ascii(c.config_name) << "\">\n"
    << "  <option gravity=\"0 0 0\"/>\n"
    << "  <worldbody>\n"
    << "    <body name=\"rotor\">\n"
    << "      <inertial pos=\"0 0 0\" mass=\"1e-9\" diaginertia=\"1e-12 1e-12 1e-12\"/>\n"
    << "      <joint name=\"shaft\" type=\"" << (c.linear_axis ? "slide" : "hinge")
    << "\" axis=\"0 0 1\" armature=\"" << Exact(c.Value("J")) << "\" damping=\""
    << Exact(c.Value("B")) << "\" frictionloss=\"" << Exact(frictionloss) << "\" stiffness=\""
    << Exact(c.Value("K")) << "\" springref=\"" << Exact(c.Value("theta0")) << "\"/>\n"
    << "    </body>\n"
    << "  </worldbody>\n"
    << "  <actuator>\n"
    << "    <motor name=\"drive\" joint=\"shaft\" gear=\"1\"/>\n"
    << "  </actuator>\n"
    << "</mujoco>\n";
  return x.str();
}

}  // namespace blmd
