// The one table of configuration keys (config_keys()) against what is made from it and
// what is written by hand beside it: the printed configuration (goniod --check-config),
// the file it reads back, and the key table in daemon/README.md.
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gonio/daemon/config/config.hpp"
#include "gonio/daemon/startup/daemon.hpp"

namespace gonio::daemon {
namespace {

// Every key set, the ones that are unset by default included.
Config everything_set() {
  return Config::parse(R"(
[server]
listen = ["tcp://127.0.0.1:7700"]
allowed_origins = ["http://lab.example:8080"]
[auth.unix]
admin_uids = [0]
admin_gids = [10]
technician_uids = [1000]
technician_gids = [100]
viewer_uids = [1001]
viewer_gids = [101]
[[auth.token]]
name = "lab-viewer"
role = "viewer"
sha256 = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
[instrument]
integration_ms = 50
[instrument.motion]
driver = "mock"
[instrument.photometer]
driver = "mock"
[instrument.limits]
min_separation = 12
[webhook]
url = "http://127.0.0.1:9000/alerts"
[mqtt]
url = "mqtts://broker.lab:8883"
username = "gonio"
password = "secret"
ca_file = "/etc/ssl/ca.pem"
cert_file = "/etc/ssl/gonio.pem"
key_file = "/etc/ssl/gonio.key"
[archive]
postgres = "host=db.lab dbname=gonio"
)",
                       "everything.toml");
}

const nlohmann::json* find(const nlohmann::json& doc, const ConfigKey& key) {
  const nlohmann::json* at = &doc;
  std::string path(key.section);
  for (std::size_t from = 0; from <= path.size();) {
    const auto dot = std::min(path.find('.', from), path.size());
    const auto it = at->find(path.substr(from, dot - from));
    if (it == at->end()) return nullptr;
    at = &*it;
    from = dot + 1;
  }
  const auto it = at->find(std::string(key.name));
  return it == at->end() ? nullptr : &*it;
}

TEST(ConfigKeys, TheCheckedConfigurationPrintsEveryKey) {
  const auto doc = everything_set().to_json();
  for (const auto& key : config_keys())
    EXPECT_NE(find(doc, key), nullptr) << key.section << "." << key.name;
  // With nothing set, only the keys whose defaults are decided at start are left out.
  const auto defaults = Config{}.to_json();
  for (const auto& key : config_keys())
    if (!find(defaults, key)) {
      EXPECT_FALSE(key.default_text.empty()) << key.section << "." << key.name;
    }
}

// What goniod --check-config prints: each key in its table, or named as not set.
TEST(ConfigKeys, CheckConfigShowsEveryKey) {
  DaemonOptions o;
  o.state_dir = "/nonexistent";
  o.mock = true;
  std::ostringstream out, err;
  ASSERT_EQ(check_config(o, out, err), exit_code::ok) << err.str();
  const auto text = out.str();
  const auto printed = toml_to_json(text, "printed");
  for (const auto& key : config_keys()) {
    const auto unset = fmt::format("\n# {}.{} is not set: ", key.section, key.name);
    EXPECT_TRUE(find(printed, key) || text.find(unset) != std::string::npos)
        << key.section << "." << key.name << " is missing from:\n" << text;
  }
}

TEST(ConfigKeys, EveryPrintedKeyReadsBack) {
  const auto c = everything_set();
  const auto text = json_to_toml(c.to_json());
  SCOPED_TRACE(text);
  // The password is printed as ***; the rest is the configuration itself.
  EXPECT_EQ(Config::parse(text, "printed.toml").to_json(), c.to_json());
}

TEST(ConfigKeys, EveryKeyHasItsDocumentation) {
  for (const auto& key : config_keys()) {
    EXPECT_FALSE(key.type.empty()) << key.section << "." << key.name;
    EXPECT_FALSE(key.doc.empty()) << key.section << "." << key.name;
  }
}

// daemon/README.md's table from its header row to the first line after it that is no row.
std::string readme_table() {
  std::ifstream in(GONIO_SOURCE_DIR "/daemon/README.md");
  std::stringstream all;
  all << in.rdbuf();
  const auto text = all.str();
  const auto a = text.find("| key | type | default | allowed | meaning |\n");
  if (a == std::string::npos) return {};
  auto b = a;
  while (b < text.size() && text[b] == '|') b = text.find('\n', b) + 1;
  return text.substr(a, b - a);
}

TEST(ConfigKeys, TheReadmeTableIsTheKeyTable) {
  EXPECT_EQ(readme_table(), config_key_table())
      << "daemon/README.md's configuration table should read:\n"
      << config_key_table();
}

}  // namespace
}  // namespace gonio::daemon
