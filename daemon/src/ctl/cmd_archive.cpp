// gonioctl archive: the central archive's backlog, and shipping a scan again.
#include <cstdint>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"

namespace gonio::daemon::ctl {

using nlohmann::json;

namespace {

void status_human(const json& r) {
  if (!r.value("configured", false)) {
    std::cout << "archive: not configured (no [archive] in goniod's configuration)\n";
    return;
  }
  const auto text = [](const json& v) { return v.is_null() ? std::string("-") : v.get<std::string>(); };
  std::cout << fmt::format("instrument:       {}\n", r["instrument"].get<std::string>())
            << fmt::format("connected:        {}\n", r["connected"].get<bool>() ? "yes" : "no")
            << fmt::format("backlog:          {} rows{}\n", r["backlog"].get<std::int64_t>(),
                           r["oldest_at"].is_null() ? std::string()
                                                    : fmt::format(" (oldest {})", text(r["oldest_at"])))
            << fmt::format("last shipped:     {}\n", text(r["last_shipped_at"]))
            << fmt::format("shipped:          {} rows in {} batches\n", r["shipped"].get<std::uint64_t>(),
                           r["batches"].get<std::uint64_t>())
            << fmt::format("schema version:   {}\n", r["schema_version"].get<int>());
  if (const auto e = r.value("last_error", std::string()); !e.empty())
    std::cout << fmt::format("last error:       {} ({} failures)\n", e, r["failures"].get<std::uint64_t>());
}

}  // namespace

void add_archive_commands(CLI::App& app, Context& ctx) {
  auto scan = std::make_shared<std::int64_t>(0);
  auto* archive = app.add_subcommand("archive", "the central PostgreSQL archive");
  archive->require_subcommand(1);
  archive->add_subcommand("status", "backlog, connection and last shipped time")->callback([&ctx] {
    ctx.action = [](Session& s) {
      const auto r = s.call("archive.status");
      print(s.options(), r, [&] { status_human(r); });
      return 0;
    };
  });
  auto* reship = archive->add_subcommand("reship", "send a scan (sample, scan, every point) again");
  reship->add_option("scan", *scan)->required();
  reship->callback([&ctx, scan] {
    ctx.action = [scan](Session& s) {
      const auto r = s.call("archive.reship", json{{"scan", *scan}});
      print(s.options(), r, [&] {
        std::cout << fmt::format("scan {}: {} rows queued for the archive\n", *scan,
                                 r["queued"].get<std::int64_t>());
      });
      return 0;
    };
  });
}

}  // namespace gonio::daemon::ctl
