// gonioctl: the main, its global options and error handling, and what the command groups
// (ctl/cmd_*.cpp) share: the session that connects on first use and the printing helpers.
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "ctl/ctl_internal.hpp"
#include "gonio/daemon/ctl/ctl.hpp"
#include "gonio/daemon/rpc/rpc.hpp"
#include "gonio/proto/error.hpp"
#include "gonio/proto/text.hpp"
#include "gonio/proto/version.hpp"


namespace gonio::daemon {
namespace ctl {

using nlohmann::json;

std::string default_state_dir() {
  if (const char* e = std::getenv("GONIO_STATE_DIR"); e && *e) return e;
  return "/var/lib/gonio";
}

Client& Session::client() {
  if (client_) return *client_;
  const auto timeout = std::chrono::milliseconds(static_cast<long long>(o_.timeout_s * 1000));
  const auto uri = o_.connect.empty() ? "unix:" + o_.state_dir + "/goniod.sock" : o_.connect;
  const bool tcp = !uri.starts_with("unix:");
  // A token file named on the command line must be there: say so before anything else.
  if (tcp && o_.token.empty() && !o_.token_file.empty()) {
    std::error_code ec;
    if (!std::filesystem::exists(o_.token_file, ec))
      throw Error::invalid("--token-file", fmt::format("file not found: {}", o_.token_file));
    if (!std::ifstream(o_.token_file))
      throw Error::invalid("--token-file", fmt::format("cannot read {}: {}", o_.token_file, std::strerror(errno)));
  }
  client_.emplace(uri, timeout, o_.ca);
  if (tcp) {
    std::string token = o_.token;
    if (token.empty()) {
      const auto file = o_.token_file.empty() ? o_.state_dir + "/admin.token" : o_.token_file;
      std::ifstream in(file);
      if (in) std::getline(in, token);
    }
    if (token.empty())
      throw RpcError(rpc::code::unauthorized, "a token is needed over TCP and TLS: --token, --token-file or a "
                                       "readable <state-dir>/admin.token",
                     json::object());
    client_->login(token);
  }
  return *client_;
}

void print_fields(const json& obj, const std::string& prefix) {
  if (!obj.is_object()) {
    std::cout << cell(obj) << "\n";
    return;
  }
  for (const auto& [k, v] : obj.items()) {
    const auto key = prefix.empty() ? k : prefix + "." + k;
    if (v.is_object() && !v.empty()) print_fields(v, key);
    else if (v.is_array() && v.size() > 8) std::cout << key << ": [" << v.size() << " items]\n";
    else std::cout << key << ": " << cell(v) << "\n";
  }
}

void print(const Options& o, const json& result, const std::function<void()>& human) {
  if (o.json) std::cout << result.dump(2) << "\n";
  else human();
}

namespace {

// The name in quotes in a server message ("sample 'pain' does not exist").
std::string quoted(const std::string& message) {
  const auto a = message.find('\''), b = a == std::string::npos ? a : message.find('\'', a + 1);
  return b == std::string::npos ? std::string() : message.substr(a + 1, b - a - 1);
}

// The next step after a server error, when one is cheap to find: the near names of an
// unknown sample or method. Best effort: a second failure leaves the error as it was.
std::string next_step(Session& s, const RpcError& e) {
  const auto field = e.data().value("field", std::string());
  try {
    if (e.code() == rpc::code::not_found && field == "sample") {
      const auto name = quoted(e.what());
      std::vector<std::string> names;
      for (const auto& [id, n] : sample_names(s)) names.push_back(n);
      if (name.empty()) return {};
      const auto near = text::did_you_mean(name, names);
      return near.empty() ? " (gonioctl sample list shows the catalog)" : near;
    }
    if (e.code() == rpc::code::method_not_found) {
      const auto name = quoted(e.what());
      std::vector<std::string> names;
      const auto doc = s.call("rpc.discover");
      for (const auto& m : doc["methods"]) names.push_back(m.value("name", std::string()));
      return name.empty() ? std::string() : text::did_you_mean(name, names);
    }
  } catch (const std::exception&) {
  }
  return {};
}

// The next step when goniod cannot be reached on its socket.
std::string connect_hint(const Options& o) {
  if (!o.connect.empty() && !o.connect.starts_with("unix:")) return {};
  return fmt::format(
      "\n  is goniod running with this state dir? Start it (goniod --state-dir {} --mock, or "
      "systemctl start goniod), or point gonioctl at its state dir with --state-dir DIR or GONIO_STATE_DIR",
      o.state_dir);
}

// An unknown subcommand: CLI11 reports it as an extra argument; the near names of the
// subcommands at that level are the next step.
std::string unknown_command_hint(const CLI::App& app, const std::vector<std::string>& args) {
  const CLI::App* level = &app;
  std::string path = "gonioctl";
  for (std::size_t i = 0; i < args.size(); ++i) {
    const auto& a = args[i];
    if (a.starts_with("-")) {  // an option, and its value when it takes one
      const auto* opt = level->get_option_no_throw(a.substr(0, a.find('=')));
      if (opt && opt->get_type_size() != 0 && a.find('=') == std::string::npos) ++i;
      continue;
    }
    std::vector<std::string> names;
    const CLI::App* next = nullptr;
    for (const auto* sub : level->get_subcommands([](const CLI::App*) { return true; })) {
      names.push_back(sub->get_name());
      if (sub->get_name() == a) next = sub;
    }
    if (next) {
      level = next;
      path += " " + a;
      continue;
    }
    if (names.empty()) return {};
    const auto near = text::did_you_mean(a, names);
    return fmt::format("gonioctl: unknown command '{}'{}; {} --help lists them\n", a, near, path);
  }
  return {};
}

}  // namespace
}  // namespace ctl

int gonioctl_main(int argc, char** argv) {
  CLI::App app{"gonioctl — control goniod over JSON-RPC"};
  app.require_subcommand(1);
  ctl::Options o;
  o.state_dir = ctl::default_state_dir();
  app.add_option("--state-dir", o.state_dir, "goniod's state dir (socket and admin.token); "
                                             "default $GONIO_STATE_DIR or /var/lib/gonio");
  app.add_option("--connect", o.connect, "unix:PATH, tcp://HOST:PORT, tls://HOST:PORT or https://HOST:PORT "
                                         "(default: the state dir's socket)");
  app.add_option("--ca", o.ca, "tls://, https://: the CA certificates (PEM) the server's certificate must chain to "
                               "(default: the system's)")->check(CLI::ExistingFile);
  app.add_option("--token", o.token, "bearer token (TCP)");
  app.add_option("--token-file", o.token_file, "file holding the bearer token (TCP)");
  app.add_flag("--json", o.json, "print JSON results");
  app.add_option("--timeout", o.timeout_s, "seconds to wait for an answer")->check(CLI::Range(0.1, 86400.0));
  app.set_version_flag("--version", "gonioctl " GONIO_VERSION_STRING);

  // The command groups, in the order of the help.
  ctl::Context ctx;
  ctl::add_system_commands(app, ctx);
  ctl::add_instrument_commands(app, ctx);
  ctl::add_sample_commands(app, ctx);
  ctl::add_scan_commands(app, ctx);
  ctl::add_queue_commands(app, ctx);
  ctl::add_alert_commands(app, ctx);
  ctl::add_archive_commands(app, ctx);
  ctl::add_backup_commands(app, ctx);
  ctl::add_twin_commands(app, ctx);
  ctl::add_token_commands(app, ctx);
  ctl::add_demo_commands(app, ctx);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // A mistyped command: the near names instead of CLI11's "a subcommand is required".
    if (e.get_exit_code() != 0) {
      std::vector<std::string> args(argv + 1, argv + argc);
      if (const auto hint = ctl::unknown_command_hint(app, args); !hint.empty()) {
        std::cerr << hint;
        return ctl_exit::usage;
      }
    }
    return app.exit(e) == 0 ? 0 : ctl_exit::usage;
  }
  // Connects on first use, so local commands never do.
  ctl::Session session(o);
  try {
    return ctx.action ? ctx.action(session) : ctl_exit::usage;
  } catch (const RpcError& e) {
    std::cerr << "gonioctl: " << e.what();
    if (e.data().contains("field")) std::cerr << " [field " << e.data()["field"].get<std::string>() << "]";
    std::cerr << " (" << e.code() << ")" << ctl::next_step(session, e) << "\n";
    return exit_code_for_rpc(e.code());
  } catch (const ConnectionError& e) {
    const std::string what = e.what();
    std::cerr << "gonioctl: " << what << (what.starts_with("cannot connect") ? ctl::connect_hint(o) : "") << "\n";
    return ctl_exit::connection;
  } catch (const Error& e) {
    std::cerr << "gonioctl: " << e.what() << "\n";
    return e.code() == Errc::io_error ? ctl_exit::server : ctl_exit::usage;
  } catch (const std::exception& e) {
    std::cerr << "gonioctl: internal error: " << e.what() << "\n";
    return ctl_exit::internal;
  }
}

}  // namespace gonio::daemon
