// The blmd model's batched path (BlmdDriveModel::SimulateBatch, docs/performance.md §4a):
// up to kMaxBatchLanes parameter points of one experiment simulated together, one point per
// SIMD lane. The step is the fast path's (blmd_drive_fast.cc) written without branches per
// lane: every leg's edge and blanking arithmetic is computed in every lane and selected by
// masks, so the lanes, whose PWM edges fall at different steps, stay in lock-step. What is
// rare stays scalar, lane by lane: the leg solver when a blanked phase is near zero current,
// the std::cos/std::sin resynchronisation of the electrical angle, a divergence, and the
// output samples. Each lane does the fast path's arithmetic, operation for operation and in
// the same order (no fused multiply-adds: this file is built with -ffp-contract=off), so a
// lane's outputs equal Simulate()'s bit for bit (tests/unit/batch_test.cc).
//
// The lanes are GCC/Clang vector extensions. The kernel (blmd_batch_kernel.inc) is compiled
// three times under function target attributes, for AVX-512 (8 lanes), AVX2 (4) and the
// x86-64 baseline, SSE2 (2), and the widest the CPU supports runs (src/sim/blmd/blmd_batch.h).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string_view>

#include "blmd/sim/blmd/blmd_drive.h"
#include "blmd/sim/effects.h"
#include "sim/blmd/blmd_batch.h"
#include "sim/blmd/blmd_legs.h"
#include "sim/input_read.h"
#include "sim/plain_shaft.h"
#include "sim/sampler.h"

// The lane helpers take and return 64-byte vectors but are always inlined, so GCC's note
// that their calling convention depends on AVX-512 is moot.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace blmd {
namespace {

constexpr int kMaxLanes = internal::kMaxBatchLanes;
constexpr int kResyncSteps = 256;  // as the fast path

// One batch: what the lanes share, and each lane's constants (computed as the fast path
// computes them). Lanes past `active` repeat the last active lane's parameters and record
// nothing.
struct LaneJob {
  const Experiment* experiment = nullptr;
  const std::vector<double>* times = nullptr;
  double dt = 0.0;  // s
  bool regula_falsi = true, diagnostics = false;
  bool lead_lag = false;           // some lane has Tz or Tp != 0
  double limit = 1e9;              // divergence limit
  long steps_per_half_period = 0;  // Tpwm / (2 dt), the same for every lane
  int active = 0;
  double Ud[kMaxLanes], Ke[kMaxLanes], p[kMaxLanes], Kc[kMaxLanes], Kf[kMaxLanes], Kp[kMaxLanes],
      Ki_dt[kMaxLanes], Vtri[kMaxLanes], carrier_slope[kMaxLanes], delta[kMaxLanes], TL[kMaxLanes],
      i0[kMaxLanes];
  double current_gain[kMaxLanes], speed_gain[kMaxLanes], lag_norm[kMaxLanes], Tp_dt[kMaxLanes],
      lead_gain[kMaxLanes], Tz_dt[kMaxLanes], dt_Ls[kMaxLanes], Ls_dt[kMaxLanes], dt_J[kMaxLanes];
  double lane_lead_lag[kMaxLanes];  // 1.0: this lane's compensator has a lead-lag part
  internal::OutputSampler* samplers[kMaxLanes] = {};
  SimStatus* statuses[kMaxLanes] = {};
};

// The lane that paces the sampling (the lanes record at the same steps): the first one
// still running, or -1.
int LeadLane(const bool* alive, int width) {
  for (int l = 0; l < width; ++l) {
    if (alive[l]) return l;
  }
  return -1;
}

#if defined(__x86_64__)
namespace avx512 {
#define BLMD_BATCH_WIDTH 8
#define BLMD_BATCH_ATTRIBUTES [[gnu::target("avx512f,avx512dq,avx512vl,avx2,avx")]]
#include "sim/blmd/blmd_batch_kernel.inc"
#undef BLMD_BATCH_WIDTH
#undef BLMD_BATCH_ATTRIBUTES
}  // namespace avx512
namespace avx2 {
#define BLMD_BATCH_WIDTH 4
#define BLMD_BATCH_ATTRIBUTES [[gnu::target("avx2,avx")]]
#include "sim/blmd/blmd_batch_kernel.inc"
#undef BLMD_BATCH_WIDTH
#undef BLMD_BATCH_ATTRIBUTES
}  // namespace avx2
#endif
namespace baseline {
#define BLMD_BATCH_WIDTH 2
#define BLMD_BATCH_ATTRIBUTES
#include "sim/blmd/blmd_batch_kernel.inc"
#undef BLMD_BATCH_WIDTH
#undef BLMD_BATCH_ATTRIBUTES
}  // namespace baseline

// The instruction set in use: BLMD_BATCH_ISA if set and supported, else the widest; tests
// and benchmarks change it through ForceBatchIsa.
internal::BatchIsa& IsaInUse() {
  static internal::BatchIsa isa = [] {
    const char* name = std::getenv("BLMD_BATCH_ISA");
    const std::string_view wanted = name ? name : "";
    for (auto candidate : {internal::BatchIsa::kAvx512, internal::BatchIsa::kAvx2,
                           internal::BatchIsa::kBaseline, internal::BatchIsa::kScalar}) {
      if (wanted == internal::BatchIsaName(candidate) && internal::CpuSupports(candidate)) {
        return candidate;
      }
    }
    for (auto candidate : {internal::BatchIsa::kAvx512, internal::BatchIsa::kAvx2}) {
      if (internal::CpuSupports(candidate)) return candidate;
    }
    return internal::BatchIsa::kBaseline;
  }();
  return isa;
}

void Dispatch(internal::BatchIsa isa, LaneJob& job) {
  switch (isa) {
#if defined(__x86_64__)
    case internal::BatchIsa::kAvx512:
      return avx512::RunLanes(job);
    case internal::BatchIsa::kAvx2:
      return avx2::RunLanes(job);
#endif
    default:
      return baseline::RunLanes(job);
  }
}

// Requests the lanes can share: one experiment, sample times, effects and numerics.
bool SameRun(const SimulationRequest& a, const SimulationRequest& b) {
  return a.experiment == b.experiment && a.sample_times == b.sample_times && a.effects &&
         b.effects && *a.effects == *b.effects && a.settings.dt == b.settings.dt &&
         a.settings.regula_falsi == b.settings.regula_falsi &&
         a.settings.friction_smoothing_w == b.settings.friction_smoothing_w &&
         a.settings.diagnostics == b.settings.diagnostics &&
         a.settings.method == b.settings.method && a.settings.max_step == b.settings.max_step &&
         a.settings.divergence_limit == b.settings.divergence_limit &&
         a.settings.effect_angle == nullptr && b.settings.effect_angle == nullptr;
}

}  // namespace

namespace internal {

int BatchWidth(BatchIsa isa) {
  switch (isa) {
    case BatchIsa::kAvx512:
      return 8;
    case BatchIsa::kAvx2:
      return 4;
    case BatchIsa::kBaseline:
      return 2;
    default:
      return 1;
  }
}

const char* BatchIsaName(BatchIsa isa) {
  switch (isa) {
    case BatchIsa::kAvx512:
      return "avx512";
    case BatchIsa::kAvx2:
      return "avx2";
    case BatchIsa::kBaseline:
      return "baseline";
    default:
      return "scalar";
  }
}

bool CpuSupports(BatchIsa isa) {
#if defined(__x86_64__)
  switch (isa) {
    case BatchIsa::kAvx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
             __builtin_cpu_supports("avx512vl");
    case BatchIsa::kAvx2:
      return __builtin_cpu_supports("avx2");
    default:
      return true;
  }
#else
  return isa == BatchIsa::kBaseline || isa == BatchIsa::kScalar;
#endif
}

BatchIsa ChosenBatchIsa() { return IsaInUse(); }

bool ForceBatchIsa(BatchIsa isa) {
  if (!CpuSupports(isa)) return false;
  IsaInUse() = isa;
  return true;
}

}  // namespace internal

void BlmdDriveModel::SimulateBatch(const SimulationRequest* requests, std::size_t count,
                                   Trace* outs, SimStatus* statuses) const {
  bool shared = count > 1;
  for (std::size_t k = 1; shared && k < count; ++k) shared = SameRun(requests[0], requests[k]);
  // The events method (docs/model-blmd.md §9) runs each point on its own: its segments end
  // at each point's own switching instants, so points cannot share a lock-step.
  if (!shared || requests[0].sample_times->empty() ||
      requests[0].settings.method == SimulationMethod::kEvents ||
      requests[0].experiment->closed_loop ||
      internal::ChosenBatchIsa() == internal::BatchIsa::kScalar) {
    Model::SimulateBatch(requests, count, outs, statuses);
    return;
  }
  const SimulationSettings& settings = requests[0].settings;
  const double dt = settings.dt;
  // Points that run in lanes: valid, a plain shaft, the carrier period of the first one.
  std::vector<std::size_t> lanes;
  std::vector<internal::BlmdStepConstants> constants;
  for (std::size_t k = 0; k < count; ++k) {
    const ParameterSet& values = *requests[k].parameters;
    if (Validate(values, settings).empty()) {
      const auto point = internal::BlmdStepConstants::From(values, *requests[k].effects, settings);
      if (internal::PlainShaft(point.shaft) &&
          (constants.empty() ||
           point.steps_per_half_period == constants.front().steps_per_half_period)) {
        lanes.push_back(k);
        constants.push_back(point);
        continue;
      }
    }
    statuses[k] = Simulate(requests[k], &outs[k]);  // its error, or the scalar fast path
  }
  const std::vector<std::string> names = internal::BlmdOutputNames(settings.diagnostics);
  std::vector<double> u_column(requests[0].sample_times->size());  // the same for every lane
  InputCursor u_cursor(requests[0].experiment->input);
  for (std::size_t r = 0; r < u_column.size(); ++r) {
    u_column[r] = u_cursor.At(internal::InputReadTime((*requests[0].sample_times)[r], dt));
  }
  const internal::BatchIsa chosen = internal::ChosenBatchIsa();
  for (std::size_t first = 0, width = 0; first < lanes.size(); first += width) {
    // The widest kernel for full chunks; for a last, partial one the narrowest that holds it
    // (a step of all 2 SSE2 lanes costs about as much as one of 4 AVX2 lanes and less than one
    // of 8 AVX-512 lanes; one point alone runs quickest on the scalar fast path:
    // docs/performance.md §4a). Every kernel gives the same bits.
    const std::size_t remaining = lanes.size() - first;
    if (remaining == 1) {
      statuses[lanes[first]] = Simulate(requests[lanes[first]], &outs[lanes[first]]);
      width = 1;
      continue;
    }
    internal::BatchIsa isa = chosen;
    if (remaining <= 2) {
      isa = internal::BatchIsa::kBaseline;
    } else if (remaining <= 4 && chosen == internal::BatchIsa::kAvx512) {
      isa = internal::BatchIsa::kAvx2;
    }
    width = static_cast<std::size_t>(internal::BatchWidth(isa));
    LaneJob job;
    job.experiment = requests[0].experiment;
    job.times = requests[0].sample_times;
    job.dt = dt;
    job.regula_falsi = settings.regula_falsi;
    job.diagnostics = settings.diagnostics;
    job.limit = settings.divergence_limit;
    job.steps_per_half_period = constants.front().steps_per_half_period;
    job.active = static_cast<int>(std::min(width, remaining));
    std::vector<internal::OutputSampler> samplers;
    samplers.reserve(width);
    for (int l = 0; l < kMaxLanes; ++l) {
      const std::size_t q = first + static_cast<std::size_t>(std::min(l, job.active - 1));
      const internal::BlmdStepConstants& c = constants[q];
      job.Ud[l] = c.Ud;
      job.Ke[l] = c.Ke;
      job.p[l] = c.p;
      job.Kc[l] = c.Kc;
      job.Kf[l] = c.Kf;
      job.Kp[l] = c.Kp;
      job.Ki_dt[l] = c.Ki_dt;
      job.Vtri[l] = c.Vtri;
      job.carrier_slope[l] = c.carrier_slope;
      job.delta[l] = c.delta;
      job.TL[l] = c.shaft.TL;
      job.i0[l] = c.drive.i0;
      job.current_gain[l] = c.current_gain;
      job.speed_gain[l] = c.speed_gain;
      job.lag_norm[l] = c.lag_norm;
      job.Tp_dt[l] = c.Tp_dt;
      job.lead_gain[l] = c.lead_gain;
      job.Tz_dt[l] = c.Tz_dt;
      job.dt_Ls[l] = c.dt_Ls;
      job.Ls_dt[l] = c.Ls_dt;
      job.dt_J[l] = c.dt_J;
      job.lane_lead_lag[l] = c.lead_lag ? 1.0 : 0.0;
      job.lead_lag = job.lead_lag || c.lead_lag;
      if (l < job.active) {
        samplers.emplace_back(*job.times, names);
        job.samplers[l] = &samplers.back();
        job.statuses[l] = &statuses[lanes[q]];
        statuses[lanes[q]] = SimStatus::Ok();
      }
    }
    Dispatch(isa, job);
    for (int l = 0; l < job.active; ++l) {
      const std::size_t k = lanes[first + static_cast<std::size_t>(l)];
      if (!statuses[k].ok()) continue;
      samplers[static_cast<std::size_t>(l)].Finish(&outs[k]);
      outs[k].Column("u") = u_column;
    }
  }
}

}  // namespace blmd
