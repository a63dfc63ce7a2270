// The archive's schema (daemon/src/fleet/archive_schema.cpp): versioned migrations that create
// the documented tables and views.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gonio/daemon/fleet/archive.hpp"

namespace gonio::daemon {
namespace {

TEST(ArchiveSchema, VersionedMigrationsCreateTheDocumentedTablesAndViews) {
  ASSERT_EQ(archive_migrations().size(), static_cast<std::size_t>(kArchiveSchemaVersion));
  const auto& first = archive_migrations().front();
  for (const char* t : {"instruments", "samples", "scans", "scan_states", "points", "alerts"})
    EXPECT_NE(first.find(fmt::format("CREATE TABLE {} (", t)), std::string::npos) << t;
  for (const char* v : {"sample_points", "point_spectra", "scan_summary", "open_alerts"})
    EXPECT_NE(first.find(fmt::format("CREATE VIEW {} AS", v)), std::string::npos) << v;
  EXPECT_NE(first.find("PRIMARY KEY (instrument, scan_id, idx)"), std::string::npos);
  const auto& third = archive_migrations().at(2);
  EXPECT_NE(third.find("ADD COLUMN resolved_at"), std::string::npos);
  EXPECT_NE(third.find("ADD COLUMN resolution"), std::string::npos);
}

}  // namespace
}  // namespace gonio::daemon
