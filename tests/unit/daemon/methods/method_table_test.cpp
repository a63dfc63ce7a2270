// The method table (gonio/daemon/methods/method_table.hpp) against the three other places a method
// and its role appear: the handlers goniod registers, proto/openrpc.json (x-role and the
// "Role: ..." of each description) and the method table of daemon/README.md. Any
// disagreement fails.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gonio/daemon/methods/method_table.hpp"
#include "gonio/daemon/methods/methods.hpp"
#include "gonio/daemon/rpc/rpc.hpp"

namespace gonio::daemon {
namespace {

using nlohmann::json;

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t");
  return std::string(s.substr(b, e - b + 1));
}

std::vector<std::string> split(std::string_view s, char sep) {
  std::vector<std::string> out;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= s.size(); ++i)
    if (i == s.size() || s[i] == sep) {
      out.push_back(trim(s.substr(start, i - start)));
      start = i + 1;
    }
  return out;
}

// The methods and roles of the "| method | role | what |" table in a README. A row names
// methods in back-quotes (`.move` after `instrument.home` is `instrument.move`) and gives
// one role for all of them or one per method; "—" is no role (none).
std::map<std::string, std::string> readme_roles(const std::string& text) {
  std::map<std::string, std::string> out;
  std::istringstream in(text);
  std::string line;
  bool in_table = false;
  while (std::getline(in, line)) {
    if (!in_table) {
      in_table = line.rfind("| method | role |", 0) == 0;
      continue;
    }
    if (line.rfind("|---", 0) == 0) continue;
    if (line.empty() || line.front() != '|') break;
    const auto cells = split(line, '|');  // "", methods, roles, what, ""
    if (cells.size() < 4) {
      ADD_FAILURE() << "README method row without a role column: " << line;
      continue;
    }
    std::vector<std::string> names;
    std::string family;
    for (const auto& item : split(cells[1], ',')) {
      if (item.size() < 3 || item.front() != '`' || item.back() != '`') {
        ADD_FAILURE() << "README method cell item is not `name`: '" << item << "' in " << line;
        continue;
      }
      auto name = item.substr(1, item.size() - 2);
      if (name.front() == '.') name = family + name;
      const auto dot = name.rfind('.');
      family = dot == std::string::npos ? name : name.substr(0, dot);
      names.push_back(name);
    }
    auto roles = split(cells[2], ',');
    for (auto& r : roles)
      if (r == "—" || r == "-") r = "none";
    if (roles.size() == 1) roles.resize(names.size(), roles.front());
    if (roles.size() != names.size()) {
      ADD_FAILURE() << "README row gives " << roles.size() << " roles for " << names.size()
                    << " methods: " << line;
      continue;
    }
    for (std::size_t i = 0; i < names.size(); ++i)
      if (!out.emplace(names[i], roles[i]).second) ADD_FAILURE() << names[i] << " is twice in the README";
  }
  EXPECT_TRUE(in_table) << "no '| method | role | what |' table found";
  return out;
}

std::map<std::string, std::string> table_roles() {
  std::map<std::string, std::string> out;
  for (const auto& m : kMethodTable) out.emplace(std::string(m.name), std::string(to_text(m.role)));
  return out;
}

TEST(MethodTable, FindsEveryEntryAndNothingElse) {
  for (const auto& m : kMethodTable) {
    const auto* found = find_method_spec(m.name);
    ASSERT_NE(found, nullptr) << m.name;
    EXPECT_EQ(found->name, m.name);
  }
  EXPECT_EQ(find_method_spec("scan.nope"), nullptr);
  EXPECT_EQ(find_method_spec(""), nullptr);
}

TEST(MethodTable, AgreesWithOpenRpc) {
  std::map<std::string, std::string> documented;
  for (const auto& m : openrpc_document()["methods"]) {
    const auto name = m["name"].get<std::string>();
    ASSERT_TRUE(m.contains("x-role")) << name;
    const auto role = m["x-role"].get<std::string>();
    documented.emplace(name, role);
    // The description repeats the role for readers of the document.
    const auto description = m.value("description", std::string());
    const auto at = description.find("Role: ");
    if (at != std::string::npos) {
      EXPECT_EQ(description.substr(at + 6, role.size() + 1), role + ".") << name << ": " << description;
    }
  }
  EXPECT_EQ(table_roles(), documented);
}

TEST(MethodTable, AgreesWithTheReadme) {
  std::ifstream in(GONIO_SOURCE_DIR "/daemon/README.md");
  ASSERT_TRUE(in) << "daemon/README.md";
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(table_roles(), readme_roles(text.str()));
}

TEST(MethodTable, ReadmeParserReadsSharedRolesPairsAndFamilies) {
  const auto roles = readme_roles(
      "intro\n"
      "| method | role | what |\n"
      "|---|---|---|\n"
      "| `rpc.discover` | — | doc |\n"
      "| `auth.login`, `auth.whoami` | —, viewer | who |\n"
      "| `scan.submit`, `.cancel` | technician | |\n"
      "\n"
      "| command | method |\n"
      "| `scan get` | scan.get |\n");
  const std::map<std::string, std::string> want{{"rpc.discover", "none"},
                                                {"auth.login", "none"},
                                                {"auth.whoami", "viewer"},
                                                {"scan.submit", "technician"},
                                                {"scan.cancel", "technician"}};
  EXPECT_EQ(roles, want);
}

class TestSession final : public rpc::Session {
 public:
  explicit TestSession(Role role) : Session("test", "peer", true) {
    Principal p;
    p.name = "tester";
    p.role = role;
    set_principal(p);
  }
  bool push(std::shared_ptr<const std::string>) override { return true; }
};

// goniod's real services, not started (no thread, no device opened), with every method
// registered; blocking calls run inline and are counted.
class RegisteredMethods : public ::testing::Test {
 protected:
  RegisteredMethods()
      : dir_(std::filesystem::temp_directory_path() /
             fmt::format("gonio-method-table-test-{}", ::getpid())),
        d_([this](std::uint64_t, std::function<void()> f) {
          ++blocking_runs_;
          f();
        }) {
    std::filesystem::create_directories(dir_);
    config_.twin_threads = 1;
    store_.emplace(dir_ / "goniod.db");
    auth_.emplace(std::vector<TokenEntry>{}, *store_);
    twin_.emplace(config_, twin::InstrumentProfile::preset("gcms4"));
    alerts_.emplace(*store_, hub_);
    instrument_.emplace(config_, *store_, *twin_, *alerts_, hub_);
    services_.emplace(Services{config_, dir_, *store_, *auth_, hub_, *twin_, *alerts_, *instrument_,
                               &d_, std::chrono::steady_clock::now(), utc::now(), nullptr, nullptr, nullptr, {}, nullptr, nullptr, nullptr});
    register_methods(d_, *services_);
  }
  ~RegisteredMethods() override {
    services_.reset();
    instrument_.reset();
    alerts_.reset();
    twin_.reset();
    auth_.reset();
    store_.reset();
    std::filesystem::remove_all(dir_);
  }

  json call(std::string_view method, const json& params, Role role) {
    const auto text = json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", method}, {"params", params}}.dump();
    std::string out = "<no reply>";
    d_.handle(text, std::make_shared<TestSession>(role), [&](std::string r) { out = std::move(r); });
    EXPECT_NE(out, "<no reply>") << method;
    return out == "<no reply>" ? json() : json::parse(out);
  }

  std::filesystem::path dir_;
  Config config_ = Config::mock_defaults();
  std::optional<Store> store_;
  std::optional<Auth> auth_;
  std::optional<TwinService> twin_;
  Hub hub_;
  std::optional<AlertService> alerts_;
  std::optional<Instrument> instrument_;
  int blocking_runs_ = 0;
  rpc::Dispatcher d_;
  std::optional<Services> services_;
};

TEST_F(RegisteredMethods, AreTheTableAndTheOpenRpcDocument) {
  const auto& doc = openrpc_document();
  EXPECT_EQ(doc["openrpc"], "1.2.6");
  std::set<std::string> documented;
  for (const auto& m : doc["methods"]) {
    documented.insert(m["name"].get<std::string>());
    EXPECT_TRUE(m.contains("result")) << m["name"];
    EXPECT_TRUE(m.contains("params")) << m["name"];
  }
  const auto names = d_.names();
  const std::set<std::string> registered(names.begin(), names.end());
  EXPECT_EQ(documented, registered);
  std::set<std::string> table;
  for (const auto& m : kMethodTable) table.emplace(m.name);
  EXPECT_EQ(table, registered);

  std::set<int> codes;
  for (const auto& e : doc["x-error-codes"]) codes.insert(e["code"].get<int>());
  namespace code = rpc::code;
  for (int c : {-32700, -32600, -32601, -32602, -32603, code::unauthorized, code::forbidden, code::not_found,
                code::invalid_state, code::instrument_busy, code::instrument_fault, code::plan_rejected,
                code::limit_violation, code::unsupported, code::io_error, code::overloaded,
                code::storage_unavailable})
    EXPECT_TRUE(codes.contains(c)) << c;
}

// Each method is refused one role below its table role and reaches its handler at that role
// (which rejects an unknown parameter before doing anything), on the worker executor exactly
// when the table says it blocks.
TEST_F(RegisteredMethods, RunWithTheTablesRoleAndBlocking) {
  const json bad{{"no_such_parameter", true}};
  for (const auto& m : kMethodTable) {
    const std::string name(m.name);
    if (m.role != Role::none) {
      const auto below = static_cast<Role>(static_cast<int>(m.role) - 1);
      const auto r = call(name, bad, below);
      if (below == Role::none) {
        EXPECT_EQ(r["error"]["code"], rpc::code::unauthorized) << name << ": " << r.dump();
      } else {
        EXPECT_EQ(r["error"]["code"], rpc::code::forbidden) << name << ": " << r.dump();
        EXPECT_EQ(r["error"]["message"],
                  fmt::format("{} needs the {} role; 'tester' has {}", name, to_text(m.role),
                              to_text(below)))
            << name;
      }
    }
    blocking_runs_ = 0;
    const auto r = call(name, bad, m.role);
    EXPECT_EQ(r["error"]["code"], rpc::code::invalid_params) << name << ": " << r.dump();
    EXPECT_EQ(blocking_runs_, m.blocking ? 1 : 0) << name;
  }
}

}  // namespace
}  // namespace gonio::daemon
