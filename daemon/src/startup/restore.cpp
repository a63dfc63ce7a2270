// goniod --restore (restore.hpp).
#include "gonio/daemon/startup/restore.hpp"

#include <sys/stat.h>

#include <ostream>

#include <fmt/format.h>

#include "gonio/daemon/startup/daemon.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {

int restore_state(const std::filesystem::path& file, const std::filesystem::path& state_dir, std::ostream& out,
                  std::ostream& err) {
  ::umask(027);  // as goniod's own files
  try {
    const auto info = Store::restore(file, state_dir);
    out << fmt::format("restored {} into {}: schema version {}{}, {} scans, {} points, {:.1f} MiB\n",
                       file.string(), (state_dir / "goniod.db").string(), info.schema_version,
                       info.schema_version < Store::kSchemaVersion
                           ? fmt::format(" (goniod migrates it to {} when it starts)", Store::kSchemaVersion)
                           : std::string(),
                       info.scans, info.points, static_cast<double>(info.bytes) / (1 << 20));
    return exit_code::ok;
  } catch (const Error& e) {
    err << fmt::format("goniod: --restore: {}\n", e.what());
    return e.field() == "file" ? exit_code::usage : exit_code::state;
  }
}

}  // namespace gonio::daemon
