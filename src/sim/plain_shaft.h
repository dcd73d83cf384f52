// Private helper of the fast paths (dc_servo_fast.cc, blmd_drive_fast.cc).
#pragma once

#include "blmd/sim/effects.h"

namespace blmd::internal {

// True when the shaft feels no effect torque but a constant load: no friction, no
// position-dependent torque (cogging, spring, gravity), no speed-dependent torque besides B w
// (DragTorque is zero both ways, whatever terms it sums), and one body (no two-mass coupling).
// The fast paths then take the mechanical step without the effect calls.
inline bool PlainShaft(const ShaftEffects& shaft) {
  return !shaft.two_mass() && !shaft.has_friction() && !shaft.position_dependent() &&
         shaft.DragTorque(1.0) == 0.0 && shaft.DragTorque(-1.0) == 0.0;
}

}  // namespace blmd::internal
