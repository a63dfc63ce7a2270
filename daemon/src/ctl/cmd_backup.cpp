// gonioctl backup FILE | --dir DIR: a consistent copy of goniod's store, made while scans run
// (backup.create), read back piece by piece (backup.read) over whatever connection gonioctl
// has, checked against its SHA-256 and only then put in place; with --dir, named by its time
// and followed by the rotation rule (what the nightly gonio-backup.timer runs).
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <set>
#include <vector>

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

// Copies in a rotation directory: goniod-YYYY-MM-DDTHHMMSSZ.db (UTC), so that names sort
// in time order and the rule below can read their day from them.
constexpr const char* kRotationName = "goniod-%Y-%m-%dT%H%M%SZ.db";

struct Rotated {
  fs::path file;
  std::chrono::sys_days day;
};

std::optional<Rotated> rotated(const fs::path& file) {
  const auto name = file.filename().string();
  int y = 0, mo = 0, d = 0, hms = 0;
  char tail[8] = {};
  if (name.size() != 28 || std::sscanf(name.c_str(), "goniod-%4d-%2d-%2dT%6dZ%7s", &y, &mo, &d, &hms, tail) != 5 ||
      std::string_view(tail) != ".db")
    return std::nullopt;
  const std::chrono::year_month_day ymd{std::chrono::year(y), std::chrono::month(static_cast<unsigned>(mo)),
                                        std::chrono::day(static_cast<unsigned>(d))};
  if (!ymd.ok()) return std::nullopt;
  return Rotated{file, std::chrono::sys_days(ymd)};
}

// The rotation rule: of the copies in `dir`, keep the newest of each of the `daily` most
// recent days that have one and the newest of each of the `weekly` most recent weeks
// (Monday to Sunday) that have one; remove the other copies (files of any other name are
// left alone). Returns the removed ones.
std::vector<fs::path> rotate(const fs::path& dir, std::size_t daily, std::size_t weekly) {
  std::vector<Rotated> copies;
  for (const auto& e : fs::directory_iterator(dir))
    if (auto r = rotated(e.path()); r && e.is_regular_file()) copies.push_back(*r);
  std::sort(copies.begin(), copies.end(), [](const Rotated& a, const Rotated& b) { return a.file > b.file; });
  std::set<std::int64_t> days, weeks;
  std::vector<fs::path> removed;
  for (const auto& c : copies) {
    const auto day = c.day.time_since_epoch().count();
    // 1970-01-01 was a Thursday: days + 3 counts from a Monday.
    const auto week = (day + 3) / 7;
    bool keep = false;
    if (!days.contains(day) && days.size() < daily) keep = days.insert(day).second;
    if (!weeks.contains(week) && weeks.size() < weekly) keep = weeks.insert(week).second || keep;
    if (!keep) {
      fs::remove(c.file);
      removed.push_back(c.file);
    }
  }
  return removed;
}

}  // namespace

void add_backup_commands(CLI::App& app, Context& ctx) {
  struct Args {
    std::string file, dir;
    std::size_t daily = 7, weekly = 4;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "backup", "a consistent copy of goniod's store, made while scans run, written to FILE or into --dir (role admin)");
  auto* file_opt = cmd->add_option("file", args->file, "the copy: an SQLite file that goniod --restore takes");
  auto* dir_opt = cmd->add_option("--dir", args->dir,
                                  "write the copy into DIR as goniod-<UTC time>.db, then apply the rotation rule to "
                                  "the copies there")
                      ->excludes(file_opt);
  cmd->add_option("--keep-daily", args->daily, "with --dir: keep the newest copy of each of the last N days with one")
      ->needs(dir_opt);
  cmd->add_option("--keep-weekly", args->weekly,
                  "with --dir: … and of each of the last N weeks (Monday to Sunday) with one")
      ->needs(dir_opt);
  cmd->callback([&ctx, args, file_opt, dir_opt] {
    if (!*file_opt && !*dir_opt) throw CLI::RequiredError("FILE or --dir");
    ctx.action = [args](Session& s) {
      fs::path target = args->file;
      if (!args->dir.empty()) {
        const auto now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
        std::tm utc{};
        ::gmtime_r(&now, &utc);
        char name[64];
        std::strftime(name, sizeof name, kRotationName, &utc);
        target = fs::path(args->dir) / name;
      }
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
      json removed = json::array();
      if (!args->dir.empty())
        for (const auto& f : rotate(args->dir, args->daily, args->weekly)) removed.push_back(f.string());
      result["removed"] = removed;
      print(s.options(), result, [&] {
        std::cout << fmt::format("{}: {:.1f} MiB, schema version {}, {} scans, {} points, sha256 {} "
                                 "(copied in {:.2f} s)\n",
                                 target.string(), made["bytes"].get<double>() / (1 << 20),
                                 made["schema_version"].get<int>(), made["scans"].get<std::int64_t>(),
                                 made["points"].get<std::int64_t>(), sha, made["seconds"].get<double>());
        for (const auto& f : removed) std::cout << "removed " << f.get<std::string>() << " (rotation)\n";
      });
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
