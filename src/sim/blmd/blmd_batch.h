// Private to the blmd model's batched path (src/sim/blmd/blmd_drive_batch.cc,
// docs/performance.md §5): the lane count and the choice of instruction set.
#pragma once

namespace blmd::internal {

// Parameter points simulated together at most: the lanes of a 512-bit vector of doubles.
constexpr int kMaxBatchLanes = 8;

// kScalar: no lanes, every point through Simulate() (for comparisons).
enum class BatchIsa { kScalar, kBaseline, kAvx2, kAvx512 };

// The instruction set the batched kernel runs with: BLMD_BATCH_ISA (scalar, baseline, avx2,
// avx512) if set and supported by this CPU, else the widest this CPU supports. Decided once.
BatchIsa ChosenBatchIsa();
const char* BatchIsaName(BatchIsa isa);
// Points per kernel run: 8 (AVX-512), 4 (AVX2), 2 (SSE2, the x86-64 baseline), 1 (scalar).
int BatchWidth(BatchIsa isa);
bool CpuSupports(BatchIsa isa);
// Tests and benchmarks: run the kernel with `isa` from now on. False (and no change) when
// this CPU lacks it.
bool ForceBatchIsa(BatchIsa isa);

}  // namespace blmd::internal
