// gonioctl backup FILE: a consistent copy of goniod's store, made while scans run
// (backup.create), read back piece by piece (backup.read) over whatever connection gonioctl
// has, checked against its SHA-256 and only then put in place as FILE.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"
#include "gonio/daemon/rpc/transfer.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

constexpr std::size_t kPiece = 1 << 20;

// Reads copy `made` (backup.create's answer) into `part`; returns its SHA-256.
std::string fetch(Session& s, const json& made, const fs::path& part) {
  std::ofstream out(part, std::ios::binary | std::ios::trunc);
  if (!out) throw Error(Errc::io_error, fmt::format("cannot write {}", part.string()), "file");
  const auto id = made["backup"].get<std::string>();
  const auto size = made["bytes"].get<std::uint64_t>();
  Sha256 sha;
  std::uint64_t offset = 0;
  for (bool eof = false; !eof;) {
    const auto piece = s.call("backup.read", json{{"backup", id}, {"offset", offset}, {"length", kPiece}});
    const auto bytes = base64_decode(piece["data"].get<std::string>(), "backup.read data");
    if (piece["offset"].get<std::uint64_t>() != offset || bytes.size() != piece["bytes"].get<std::uint64_t>())
      throw Error(Errc::io_error, fmt::format("backup.read answered for the wrong piece at offset {}", offset));
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    sha.update(bytes);
    offset += bytes.size();
    eof = piece["eof"].get<bool>();
    if (!eof && bytes.empty()) throw Error(Errc::io_error, fmt::format("backup.read returned nothing at offset {}", offset));
  }
  out.flush();
  if (!out) throw Error(Errc::io_error, fmt::format("cannot write {}", part.string()), "file");
  if (offset != size)
    throw Error(Errc::io_error, fmt::format("the copy ended after {} of its {} bytes", offset, size));
  return sha.hex();
}

}  // namespace

void add_backup_commands(CLI::App& app, Context& ctx) {
  auto file = std::make_shared<std::string>();
  auto* cmd = app.add_subcommand(
      "backup", "a consistent copy of goniod's store, made while scans run, written to FILE (role admin)");
  cmd->add_option("file", *file, "the copy: an SQLite file that goniod --restore takes")->required();
  cmd->callback([&ctx, file] {
    ctx.action = [file](Session& s) {
      const fs::path target = *file;
      // Beside the target, so that the rename that puts it in place cannot cross file systems.
      const fs::path part = target.string() + ".part";
      const auto made = s.call("backup.create");
      std::string sha;
      try {
        sha = fetch(s, made, part);
        if (sha != made["sha256"].get<std::string>())
          throw Error(Errc::io_error, fmt::format("the copy's SHA-256 is {}, goniod announced {}", sha,
                                                  made["sha256"].get<std::string>()));
        fs::rename(part, target);
      } catch (...) {
        std::error_code ec;
        fs::remove(part, ec);
        throw;
      }
      json result = made;
      result["file"] = target.string();
      print(s.options(), result, [&] {
        std::cout << fmt::format("{}: {:.1f} MiB, schema version {}, {} scans, {} points, sha256 {} "
                                 "(copied in {:.2f} s)\n",
                                 target.string(), made["bytes"].get<double>() / (1 << 20),
                                 made["schema_version"].get<int>(), made["scans"].get<std::int64_t>(),
                                 made["points"].get<std::int64_t>(), sha, made["seconds"].get<double>());
      });
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
