// MQTT telemetry and the central archive against the real servers: a Mosquitto broker and a
// PostgreSQL cluster started by the test, three mock goniods publishing and archiving at
// once, the broker killed and restarted, PostgreSQL stopped and restarted and one goniod
// SIGKILLed, all mid-scan. Afterwards the archive holds every point exactly once and the
// retained topics are current. Skipped where the servers are not installed.
#include <gtest/gtest.h>

#include "gonio/test/archive_servers.hpp"

namespace gonio::test {
namespace {

std::string node_config(const std::string& instrument, int broker_port, const std::string& conninfo) {
  MockOptions o;
  o.time_scale = 0.3;  // about 120 ms of motion and integration per point
  o.tcp = o.http = false;
  o.extra = "[mqtt]\nurl = \"mqtt://127.0.0.1:" + std::to_string(broker_port) + "\"\ninstrument = \"" +
            instrument + "\"\nkeepalive_s = 5\n\n[archive]\npostgres = \"" + conninfo +
            "\"\ninstrument = \"" + instrument + "\"\nretry_max_s = 0.5\nbatch = 50\n";
  return mock_config(o);
}

std::int64_t points_done(Goniod& g, std::int64_t scan) {
  auto c = g.unix_conn();
  return c.call("scan.get", json{{"scan", scan}})["points_done"].get<std::int64_t>();
}

json info(Goniod& g) { return g.unix_conn().call("system.info"); }

TEST(Archive, ThreeInstrumentsThroughBrokerAndDatabaseOutagesAndAKill) {
  if (!servers_installed()) GTEST_SKIP() << "mosquitto, mosquitto_sub, psql or PostgreSQL 15 not installed";
  TempDir dir;
  Postgres pg(dir.path / "pg");
  Broker broker(dir.path / "mqtt");

  const std::vector<std::string> names{"gcms-a", "gcms-b", "gcms-c"};
  std::vector<std::unique_ptr<Goniod>> nodes;
  std::vector<std::int64_t> scans;
  for (const auto& n : names) {
    nodes.push_back(std::make_unique<Goniod>(dir.path / n, node_config(n, broker.port(), pg.conninfo())));
    auto c = nodes.back()->unix_conn();
    // 61 points each: long enough for every outage below to fall inside the scan.
    scans.push_back(submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:60:1.5"}}}));
  }
  const auto progress = [&](std::size_t i) { return points_done(*nodes[i], scans[i]); };
  for (std::size_t i = 0; i < nodes.size(); ++i)
    ASSERT_TRUE(eventually([&] { return progress(i) >= 3; }, 30s)) << nodes[i]->log_text();

  // The broker dies mid-scan: the scans go on while it is away.
  broker.kill();
  {
    const auto before = progress(0);
    ASSERT_TRUE(eventually([&] { return progress(0) >= before + 3; }, 30s)) << nodes[0]->log_text();
    EXPECT_FALSE(info(*nodes[0])["mqtt"]["connected"].get<bool>());
  }
  broker.start();

  // PostgreSQL stops mid-scan: points are committed locally and wait in the outbox.
  pg.stop();
  {
    const auto before = progress(1);
    ASSERT_TRUE(eventually([&] { return progress(1) >= before + 3; }, 30s)) << nodes[1]->log_text();
    ASSERT_TRUE(eventually([&] { return info(*nodes[1])["archive"]["backlog"].get<int>() > 0; }, 10s));
    EXPECT_FALSE(info(*nodes[1])["archive"]["connected"].get<bool>());
  }
  // … and one goniod is killed while the archive is down, then comes back.
  EXPECT_EQ(nodes[2]->stop(SIGKILL), 128 + SIGKILL);
  nodes[2]->start();
  pg.start();

  for (std::size_t i = 0; i < nodes.size(); ++i) {
    auto c = nodes[i]->unix_conn();
    const auto sc = wait_state(c, scans[i], {"completed"}, 120s);
    ASSERT_EQ(sc["state"], "completed") << nodes[i]->log_text();
  }
  for (std::size_t i = 0; i < nodes.size(); ++i)
    ASSERT_TRUE(eventually([&] {
      const auto a = info(*nodes[i])["archive"];
      return a["backlog"].get<int>() == 0 && a["connected"].get<bool>();
    }, 60s)) << names[i] << ": " << info(*nodes[i])["archive"].dump();

  // Every point exactly once (the key makes twice impossible; count and range show none
  // is missing), each scan's final state and its history.
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const auto id = std::to_string(scans[i]);
    const auto where = " WHERE instrument = '" + names[i] + "' AND scan_id = " + id;
    EXPECT_EQ(pg.query("SELECT count(*), count(DISTINCT idx), min(idx), max(idx) FROM points" + where),
              "61|61|0|60\n") << names[i];
    EXPECT_EQ(pg.query("SELECT state, points_done FROM scans" + where), "completed|61\n") << names[i];
    const auto history = pg.query("SELECT string_agg(state, ',' ORDER BY seq) FROM scan_states" + where);
    EXPECT_TRUE(history.starts_with("queued,running")) << history;
    EXPECT_TRUE(history.ends_with("completed\n")) << history;
    // The view a lab queries: the sample's points across instruments.
    EXPECT_EQ(pg.query("SELECT count(*) FROM sample_points WHERE sample = 'tile' AND instrument = '" +
                       names[i] + "'"),
              "61\n");
  }
  const auto killed = pg.query("SELECT string_agg(state, ',' ORDER BY seq) FROM scan_states WHERE instrument = "
                               "'gcms-c' AND scan_id = " + std::to_string(scans[2]));
  EXPECT_NE(killed.find("interrupted"), std::string::npos) << killed;
  EXPECT_EQ(pg.query("SELECT count(*) FROM instruments"), "3\n");

  // The retained topics are current although the broker forgot them when it restarted.
  ASSERT_TRUE(eventually([&] {
    const auto r = broker.retained("gonio/#");
    for (std::size_t i = 0; i < names.size(); ++i) {
      const auto st = r.find("gonio/" + names[i] + "/state");
      const auto sc = r.find("gonio/" + names[i] + "/scan/" + std::to_string(scans[i]));
      if (st == r.end() || sc == r.end()) return false;
      if (json::parse(st->second)["state"] == "offline") return false;
      if (json::parse(sc->second)["state"] != "completed") return false;
    }
    return true;
  }, 20s));
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const auto m = info(*nodes[i])["mqtt"];
    EXPECT_TRUE(m["connected"].get<bool>());
    EXPECT_TRUE(m.contains("dropped"));
  }

  // A clean stop leaves `offline` on the state topic; so does a SIGKILL, through the will.
  nodes[0]->stop(SIGTERM);
  nodes[1]->stop(SIGKILL);
  ASSERT_TRUE(eventually([&] {
    const auto r = broker.retained("gonio/+/state");
    return r.count("gonio/gcms-a/state") && r.at("gonio/gcms-a/state") == R"({"state":"offline"})" &&
           r.count("gonio/gcms-b/state") && r.at("gonio/gcms-b/state") == R"({"state":"offline"})";
  }, 30s)) << broker.retained("gonio/+/state").size();
}

// A re-ship resends a scan without a single point twice; without a reachable server the
// backlog ages and raises the warning.
TEST(Archive, ReshipIsIdempotentAndAStaleBacklogRaisesAWarning) {
  if (!servers_installed()) GTEST_SKIP() << "PostgreSQL 15 not installed";
  TempDir dir;
  Postgres pg(dir.path / "pg");
  MockOptions o;
  o.tcp = o.http = false;
  o.extra = "[archive]\npostgres = \"" + pg.conninfo() +
            "\"\ninstrument = \"solo\"\nretry_max_s = 0.2\nmax_backlog_age_s = 1\n";
  Goniod g(dir.path / "solo", mock_config(o));
  auto c = g.unix_conn();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:5"}}});  // 13 points
  ASSERT_EQ(wait_state(c, id, {"completed"})["state"], "completed");
  ASSERT_TRUE(eventually([&] { return c.call("archive.status")["backlog"] == 0; }, 30s))
      << c.call("archive.status").dump() << g.log_text();
  EXPECT_EQ(pg.query("SELECT count(*) FROM points WHERE instrument = 'solo'"), "13\n");
  // The mock's photometer ranges at its own 100 ms; every point says so in the archive too.
  EXPECT_EQ(pg.query("SELECT count(*) FROM sample_points WHERE instrument = 'solo' AND integration_ms = 100"),
            "13\n");

  pg.stop();
  const auto r = c.call("archive.reship", json{{"scan", id}});
  EXPECT_EQ(r["queued"], 15);  // the sample, the scan and 13 points
  ASSERT_TRUE(eventually([&] {
    for (const auto& a : c.call("alert.list", json{{"acknowledged", false}}))
      if (a["kind"] == "archive_backlog") return true;
    return false;
  }, 20s)) << c.call("archive.status").dump();
  pg.start();
  ASSERT_TRUE(eventually([&] { return c.call("archive.status")["backlog"] == 0; }, 30s))
      << c.call("archive.status").dump();
  EXPECT_EQ(pg.query("SELECT count(*), count(DISTINCT idx) FROM points WHERE instrument = 'solo'"), "13|13\n");
  EXPECT_EQ(pg.query("SELECT count(*) FROM alerts WHERE instrument = 'solo' AND kind = 'archive_backlog'"), "1\n");
}

// mqtts:// against a broker that requires TLS and a client certificate: goniod with the
// lab's CA and its certificate publishes its retained state; one that trusts only the
// system's CAs never connects.
TEST(Archive, PublishesOverTlsWithTheLabsCaAndAClientCertificate) {
  if (!servers_installed()) GTEST_SKIP() << "mosquitto or openssl not installed";
  TempDir dir;
  Broker broker(dir.path / "mqtt", true);
  const auto f = broker.tls_files();
  const auto url = "mqtts://127.0.0.1:" + std::to_string(broker.port());
  MockOptions o;
  o.tcp = o.http = false;
  o.extra = "[mqtt]\nurl = \"" + url + "\"\ninstrument = \"tls\"\nca_file = \"" + f.ca.string() +
            "\"\ncert_file = \"" + f.cert.string() + "\"\nkey_file = \"" + f.key.string() + "\"\n";
  Goniod good(dir.path / "good", mock_config(o));
  o.extra = "[mqtt]\nurl = \"" + url + "\"\ninstrument = \"untrusting\"\ncert_file = \"" +
            f.cert.string() + "\"\nkey_file = \"" + f.key.string() + "\"\n";
  Goniod untrusting(dir.path / "untrusting", mock_config(o));

  auto c = good.unix_conn();
  ASSERT_TRUE(eventually([&] { return c.call("system.info")["mqtt"]["connected"] == true; }, 20s))
      << c.call("system.info")["mqtt"].dump() << broker.log();
  const auto id = submit(c, "tile", kTrueSample, json{{"grids", {"in=45;out=-30:30:10"}}});
  ASSERT_EQ(wait_state(c, id, {"completed"})["state"], "completed");
  std::map<std::string, std::string> topics;
  ASSERT_TRUE(eventually([&] {
    topics = broker.retained("gonio/tls/#");
    return topics.contains("gonio/tls/scan/" + std::to_string(id)) &&
           topics["gonio/tls/scan/" + std::to_string(id)].find("completed") != std::string::npos;
  }, 20s)) << broker.log();
  EXPECT_TRUE(topics.contains("gonio/tls/state"));

  // The broker's certificate is not signed by any CA the system trusts.
  const auto info = untrusting.unix_conn().call("system.info")["mqtt"];
  EXPECT_EQ(info["connected"], false) << info.dump();
  EXPECT_EQ(info["connects"], 0) << info.dump();
  EXPECT_TRUE(broker.retained("gonio/untrusting/#").empty());
}

}  // namespace
}  // namespace gonio::test
