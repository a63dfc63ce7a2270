// goniod --restore FILE --state-dir DIR: a backup (gonioctl backup) made the store of a new
// state directory (Store::restore). Exit codes as goniod's (daemon.hpp): ok; usage when FILE
// is not a gonio store this goniod can open; state when DIR is not empty or cannot be
// written. Nothing is written on a refusal.
#pragma once

#include <filesystem>
#include <iosfwd>

namespace gonio::daemon {

int restore_state(const std::filesystem::path& file, const std::filesystem::path& state_dir, std::ostream& out,
                  std::ostream& err);

}  // namespace gonio::daemon
