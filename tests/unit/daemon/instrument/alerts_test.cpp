// Alerts that follow the final verdict: the resolution rule, the store's resolved_at and
// resolution (with the filter, the dedup and the migration of an older file), and the
// service that publishes a resolution to subscribers and the webhook.
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gonio/daemon/instrument/alerts.hpp"
#include "gonio/daemon/instrument/verdict.hpp"
#include "gonio/daemon/store/store.hpp"
#include "gonio/proto/error.hpp"

namespace gonio::daemon {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class AlertResolution : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / fmt::format("gonio-resolution-test-{}-{}", ::getpid(),
                                                    ::testing::UnitTest::GetInstance()->random_seed());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    file_ = dir_ / "goniod.db";
  }
  void TearDown() override { fs::remove_all(dir_); }

  static AlertDraft sustained(std::int64_t scan, const std::string& message) {
    AlertDraft d;
    d.kind = std::string(alert_kind::sustained);
    d.severity = Severity::critical;
    d.dedup_key = fmt::format("sustained:scan:{}", scan);
    d.scan_id = scan;
    d.message = message;
    return d;
  }
  static std::vector<std::int64_t> ids(const std::vector<Alert>& alerts) {
    std::vector<std::int64_t> out;
    for (const auto& a : alerts) out.push_back(a.id);
    return out;
  }

  fs::path dir_, file_;
};

TEST(SustainedResolution, OnlyAVerdictThatNoLongerAlertsResolves) {
  EXPECT_EQ(sustained_resolution("agrees", "within tolerance at 61 of 61 points"),
            "resolved: final verdict agrees: within tolerance at 61 of 61 points");
  EXPECT_EQ(sustained_resolution("undecided", "u straddles the limit"),
            "resolved: final verdict undecided: u straddles the limit");
  EXPECT_FALSE(sustained_resolution("out_of_tolerance", "x").has_value());
  EXPECT_FALSE(sustained_resolution("instrument_out_of_spec", "x").has_value());
  // The same line as the verdict's own: a decision resolves exactly when it does not alert.
  for (const char* d : {"agrees", "undecided", "out_of_tolerance", "instrument_out_of_spec"}) {
    ScanVerdict v;
    v.decision = parse_enum<VerdictDecision>(d, "decision");
    EXPECT_EQ(sustained_resolution(d, "s").has_value(), !v.alerts()) << d;
  }
}

TEST_F(AlertResolution, TheStoreResolvesOnceFiltersAndOpensANewAlertAfterwards) {
  Store s(file_);
  s.set_outbox(true);
  const auto a = s.raise_alert(sustained(3, "scan 3: out_of_tolerance: lambert.albedo = 0.66"));
  const auto other = s.raise_alert(sustained(4, "scan 4: out_of_tolerance"));
  EXPECT_FALSE(a.resolved_at.has_value());
  EXPECT_FALSE(a.resolution.has_value());
  const auto outbox_before = s.outbox_stats().rows;

  bool changed = false;
  const auto r = s.resolve_alert(a.id, "resolved: final verdict agrees: fine", &changed);
  EXPECT_TRUE(changed);
  ASSERT_TRUE(r.resolved_at.has_value());
  EXPECT_EQ(r.resolution, "resolved: final verdict agrees: fine");
  EXPECT_EQ(r.message, a.message);  // what was seen stays as it was
  EXPECT_EQ(s.outbox_stats().rows, outbox_before + 1);  // the archive learns of it
  // Twice: the first resolution stands, nothing more is written.
  const auto again = s.resolve_alert(a.id, "another", &changed);
  EXPECT_FALSE(changed);
  EXPECT_EQ(again.resolution, r.resolution);
  EXPECT_EQ(again.resolved_at, r.resolved_at);
  EXPECT_EQ(s.outbox_stats().rows, outbox_before + 1);

  AlertFilter standing, resolved, all;
  standing.resolved = false;
  resolved.resolved = true;
  EXPECT_EQ(ids(s.alerts(standing)), std::vector<std::int64_t>{other.id});
  EXPECT_EQ(ids(s.alerts(resolved)), std::vector<std::int64_t>{a.id});
  EXPECT_EQ(ids(s.alerts(all)), (std::vector<std::int64_t>{other.id, a.id}));
  // Resolution and acknowledgement are independent.
  AlertFilter unacked_resolved;
  unacked_resolved.acknowledged = false;
  unacked_resolved.resolved = true;
  EXPECT_EQ(s.alerts(unacked_resolved).size(), 1u);
  EXPECT_TRUE(s.ack_alert(a.id, "tech").resolved_at.has_value());

  // A resolved alert absorbs no repeat of its key: a new one opens.
  bool created = false;
  const auto next = s.raise_alert(sustained(3, "scan 3: out_of_tolerance again"), &created);
  EXPECT_TRUE(created);
  EXPECT_NE(next.id, a.id);
  EXPECT_FALSE(next.resolved_at.has_value());

  try {
    s.resolve_alert(999, "x");
    FAIL() << "an unknown alert was resolved";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::not_found);
  }
}

TEST_F(AlertResolution, AVersion4StoreKeepsItsAlertsStanding) {
  // A store as the schema before resolutions left it, with one alert written by hand.
  Store::create_at_version(file_, 4);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db,
                         "INSERT INTO alerts(kind, severity, dedup_key, scan_id, message, first_at, "
                         "last_at) VALUES ('sustained_divergence', 2, 'sustained:scan:1', 1, 'old', "
                         "'2026-01-01T00:00:00Z', '2026-01-01T00:00:00Z');",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);

  Store s(file_);
  EXPECT_EQ(s.schema_version(), Store::kSchemaVersion);
  const auto old = s.alert(1);
  ASSERT_TRUE(old.has_value());
  EXPECT_EQ(old->message, "old");
  EXPECT_FALSE(old->resolved_at.has_value());
  AlertFilter standing;
  standing.resolved = false;
  EXPECT_EQ(s.alerts(standing).size(), 1u);
  EXPECT_TRUE(s.resolve_alert(1, "resolved: final verdict agrees: fine").resolved_at.has_value());
}

// What the webhook sender would POST.
class Captured final : public AlertSink {
 public:
  void deliver(const json& payload) override { got.push_back(payload); }
  json stats() const override { return json::object(); }
  std::vector<json> got;
};

TEST_F(AlertResolution, TheServicePublishesAResolutionOnceToSubscribersAndTheWebhook) {
  Store s(file_);
  Hub hub;
  std::vector<std::pair<std::string, json>> published;
  hub.set_tap([&](std::string_view method, const std::string& params, std::optional<std::int64_t>) {
    published.emplace_back(std::string(method), json::parse(params));
  });
  AlertService alerts(s, hub, Severity::warning);
  auto sink = std::make_shared<Captured>();
  alerts.set_sink(sink);

  const auto a = alerts.raise(sustained(7, "scan 7: out_of_tolerance"));
  ASSERT_EQ(sink->got.size(), 1u);
  EXPECT_EQ(sink->got[0]["event"], "alert.raised");
  published.clear();

  const auto r = alerts.resolve(a.id, "resolved: final verdict undecided: too close to call");
  EXPECT_TRUE(r.resolved_at.has_value());
  ASSERT_EQ(published.size(), 1u);
  EXPECT_EQ(published[0].first, "alert");
  EXPECT_EQ(published[0].second["id"], a.id);
  EXPECT_EQ(published[0].second["resolution"], "resolved: final verdict undecided: too close to call");
  EXPECT_FALSE(published[0].second["resolved_at"].is_null());
  ASSERT_EQ(sink->got.size(), 2u);
  EXPECT_EQ(sink->got[1]["event"], "alert.resolved");
  EXPECT_EQ(sink->got[1]["alert"]["id"], a.id);
  EXPECT_EQ(sink->got[1]["alert"]["resolved_at"], published[0].second["resolved_at"]);

  // Resolving again changes nothing and tells nobody.
  alerts.resolve(a.id, "again");
  EXPECT_EQ(published.size(), 1u);
  EXPECT_EQ(sink->got.size(), 2u);
}

}  // namespace
}  // namespace gonio::daemon
