// The mock instrument — a virtual lab behind a MotionController and a Photometer, whose
// readings come from the twin (docs/architecture.md §4). Like every motion driver it checks no limits:
// the registry wraps it in GuardedMotion (motion/guarded_motion.hpp).
//
// The lab holds a hidden "true" sample (a BSDF spec that may differ from the catalog's),
// an instrument profile (default gcms4) and imperfections: arm offsets (the arms stand
// where the controller says plus an offset: the twin sees the offset geometry), lamp drift
// (relative change per virtual second), detector noise (shot + read noise, seeded), dark
// signal, finite motion time (speed in degrees per second on a virtual clock; optionally
// also slept in real time, scaled). Everything is deterministic for `seed`.
//
// Signals (counts): dark = dark_counts_per_ms·t; reference = dark + gain·t·lamp;
// sample = dark + gain·t·lamp·β where β is the twin's prediction at the true geometry,
// so (S − D)/(R − D) reproduces the twin's radiance factor up to noise and drift.
//
// Scripted faults (counted from 1, "point" = a sample-channel measurement):
//   disconnect_at_point N   the photometer is unplugged at the Nth sample reading: that
//                           call and every later call of that photometer fail with
//                           disconnected. Opening it again (connect_photometer, as the
//                           registry does after a replug) succeeds once reconnect_after_ms
//                           (default 0: at once) have passed since the loss; the arms are
//                           not affected
//   timeout_at_point N      the Nth sample reading never answers: timeout (after the call's
//                           timeout or timeout_wait_ms, whichever is shorter)
//   garbage_at_point N      the Nth sample reading is unreadable: protocol_error
//   saturate_at_point N     the Nth sample reading is saturated: saturated (goniod's
//                           auto-ranging reads the point again, shorter, and goes on)
//   stall_at_move N         the Nth move stalls half way: device_alarm (code 0x10,
//                           excessive position deviation) and the arm stays there
//
// Config (JSON, strict; every key optional):
//   {"profile": "gcms4", "sample": "lambert:albedo=0.5" | {...}, "wavelengths": "400:700:10",
//    "arm_offsets_deg": {"incidence": 0, "receive": 0},
//    "lamp_drift_per_s": 0, "gain_counts_per_ms": 400, "dark_counts_per_ms": 2,
//    "read_noise_counts": 3, "full_scale_counts": 1e6, "integration_ms": 100 (settable:
//    the signal grows with it, the shot noise with its square root),
//    "speed_deg_s": 20, "time_scale": 0, "seed": 1,
//    "estimator": {"rel_se": 0.01, "max_samples": 65536, "replicates": 8},
//    "faults": {"disconnect_at_point": N, "timeout_at_point": N, "garbage_at_point": N,
//               "saturate_at_point": N, "stall_at_move": N, "timeout_wait_ms": 200,
//               "reconnect_after_ms": 0}}
#pragma once

#include <memory>

#include <nlohmann/json_fwd.hpp>

#include "gonio/drivers/motion/motion_controller.hpp"
#include "gonio/drivers/photometer/photometer.hpp"
#include "gonio/sim/devsim/scpi_sim.hpp"

namespace gonio::twin {
class Twin;
struct EstimatorOptions;
}  // namespace gonio::twin

namespace gonio::drivers::mock {

class Lab;  // the shared state

struct MockInstrument {
  std::unique_ptr<MotionController> motion;
  std::unique_ptr<Photometer> photometer;
  std::shared_ptr<Lab> lab;
};

// One lab, both sides. Throws Error naming the field for a bad config.
MockInstrument make_mock(const nlohmann::json& config);
// New handles on an existing lab (a reconnection): the arms at once; the photometer throws
// Error(disconnected) while it is still unplugged.
std::unique_ptr<MotionController> connect_motion(const std::shared_ptr<Lab>& lab);
std::unique_ptr<Photometer> connect_photometer(const std::shared_ptr<Lab>& lab);
// Registry entries: each builds its own lab.
std::unique_ptr<MotionController> make_mock_motion(const nlohmann::json& config);
std::unique_ptr<Photometer> make_mock_photometer(const nlohmann::json& config);
// The arms' clearance of the lab's profile (profile.arms.min_separation_deg): the
// instrument's minimum separation when its limits table leaves it unset. Throws for a bad
// config, as make_mock does.
double default_min_separation(const nlohmann::json& config);

// β of the twin at a geometry, cached per geometry: the physics of the simulators.
devsim::BetaSource twin_beta_source(std::shared_ptr<const twin::Twin> twin,
                                    const twin::EstimatorOptions& options);

}  // namespace gonio::drivers::mock
