// Private entry of the blmd model's event-driven integrator (src/sim/blmd/blmd_drive_events.cc,
// docs/model-blmd.md §9): simulation.method = "events".
#pragma once

#include <string>

#include "blmd/sim/blmd/blmd_drive.h"

namespace blmd::internal {

// Simulates the request with the events method: the PWM comparator crossings, the ends of
// the blanking times, the diode turn-offs (a blanked phase's current reaching zero), the
// carrier's vertices, the compensators' saturation limits and the input's edges located to
// rounding, and between them a Taylor series of the smooth drive (second order for the
// windings and compensators, third for the shaft); samples are read from the series at
// their exact instants.
SimStatus SimulateBlmdEvents(const BlmdDriveModel& model, const SimulationRequest& request,
                             Trace* out);

// Why the events method cannot run these values (empty: it can): the lead-lag's pure
// derivative (Tz > 0 with Tp = 0) has no continuous-time state, so only fixed_euler runs it.
std::string EventsUnsupported(double Tz, double Tp);

}  // namespace blmd::internal
