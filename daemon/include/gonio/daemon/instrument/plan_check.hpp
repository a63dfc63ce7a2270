// Plan check — whether this instrument can measure a scan plan, before it is queued.
//
// ScanPlan::validate() checks the limits that hold for any instrument (angles, counts,
// grids). check_plan() adds what depends on the instrument at hand:
//   - every geometry is in the plane of measurement (no tilt axis), and an azimuth needs the
//     sample rotation axis when the motion controller's axes are known;
//   - both arm angles lie within the soft limits of the MotionGuard;
//   - the arms keep the minimum separation at every geometry;
//   - the first geometry is on the arms' side of the collision zone (ArmClearance::side),
//     which they can never leave; an adaptive plan's every candidate is, since any may
//     come first or next;
//   - the arms can travel from each geometry to the next, one arm after the other in either
//     order, without sweeping through the collision zone (the runner moves them that way);
//     an adaptive plan's order is chosen as it runs, so its loop only chooses moves that
//     pass the same test (arms_can_move) and this check leaves the order out;
// The geometry is ArmClearance's (proto/arms.hpp), the guard's and the planners' rule.
//   - the plan's wavelengths lie within the photometer's, when its grid is known.
// A violation throws Error(plan_rejected) whose field names the geometry ("geometries[12]")
// or "wavelengths", and whose message says which limit and by how much.
//
// A pure function of the plan, the guard and what is known of the devices, so that the
// rules are testable without an instrument.
#pragma once

#include <optional>
#include <vector>

#include "gonio/drivers/motion/collision.hpp"
#include "gonio/drivers/motion/motion_controller.hpp"
#include "gonio/proto/scan.hpp"
#include "gonio/proto/spectrum.hpp"

namespace gonio::daemon {

// What is known of the devices when the plan is checked; empty until they have been opened
// (the checks that need them are then skipped).
struct DeviceFacts {
  std::vector<drivers::Axis> axes;
  std::optional<WavelengthGrid> photometer_grid;
  std::optional<Geometry> arms;  // where the arms stand (incidence, receive), once known
};

void check_plan(const ScanPlan& plan, const drivers::MotionGuard& guard,
                const DeviceFacts& devices);

// Whether the arms can go from `a` to `b`, one arm after the other in either order.
bool arms_can_move(const drivers::MotionGuard& guard, const Geometry& a, const Geometry& b);

}  // namespace gonio::daemon
