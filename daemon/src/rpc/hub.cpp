// Subscriptions and notification fan-out (see hub.hpp).
#include "gonio/daemon/rpc/hub.hpp"

#include "gonio/daemon/rpc/rpc.hpp"

#include <fmt/format.h>

namespace gonio::daemon {

void Hub::subscribe(const std::shared_ptr<rpc::Session>& s, const std::set<Topic>& topics,
                    std::optional<std::int64_t> scan) {
  std::lock_guard lock(mu_);
  auto& e = entries_[s->id()];
  e.session = s;
  e.topics.insert(topics.begin(), topics.end());
  e.scan = scan;
}

std::set<Topic> Hub::unsubscribe(std::uint64_t session, const std::set<Topic>& topics) {
  std::lock_guard lock(mu_);
  const auto it = entries_.find(session);
  if (it == entries_.end()) return {};
  if (topics.empty()) it->second.topics.clear();
  for (auto t : topics) it->second.topics.erase(t);
  auto left = it->second.topics;
  if (left.empty()) entries_.erase(it);
  return left;
}

std::set<Topic> Hub::topics(std::uint64_t session) const {
  std::lock_guard lock(mu_);
  const auto it = entries_.find(session);
  return it == entries_.end() ? std::set<Topic>{} : it->second.topics;
}

void Hub::remove(std::uint64_t session) {
  std::lock_guard lock(mu_);
  entries_.erase(session);
}

std::vector<std::shared_ptr<rpc::Session>> Hub::targets(Topic topic, std::optional<std::int64_t> scan) {
  std::vector<std::shared_ptr<rpc::Session>> out;
  std::lock_guard lock(mu_);
  for (auto it = entries_.begin(); it != entries_.end();) {
    auto s = it->second.session.lock();
    if (!s) {
      it = entries_.erase(it);
      continue;
    }
    const auto& e = it->second;
    const bool scan_ok = !scan || !e.scan || *e.scan == *scan ||
                         (topic != Topic::progress && topic != Topic::points);
    if (e.topics.contains(topic) && scan_ok) out.push_back(std::move(s));
    ++it;
  }
  return out;
}

void Hub::deliver(const std::vector<std::shared_ptr<rpc::Session>>& to,
                  const std::shared_ptr<const std::string>& text) {
  std::uint64_t refused = 0;
  for (const auto& s : to)
    if (!s->push(text)) ++refused;
  if (refused) {
    std::lock_guard lock(mu_);
    dropped_ += refused;
  }
}

void Hub::set_tap(Tap tap) {
  std::lock_guard lock(mu_);
  tap_ = tap ? std::make_shared<const Tap>(std::move(tap)) : nullptr;
}

void Hub::publish(Topic topic, std::string_view method, const nlohmann::json& params,
                  std::optional<std::int64_t> scan) {
  std::shared_ptr<const Tap> tap;
  {
    std::lock_guard lock(mu_);
    tap = tap_;
  }
  if (tap) (*tap)(method, rpc::json_text(params), scan);
  const auto to = targets(topic, scan);
  if (to.empty()) return;
  deliver(to, std::make_shared<const std::string>(rpc::notification(method, params)));
}

void Hub::publish_raw(Topic topic, std::string_view method, const std::string& params_json,
                      std::optional<std::int64_t> scan) {
  std::shared_ptr<const Tap> tap;
  {
    std::lock_guard lock(mu_);
    tap = tap_;
  }
  if (tap) (*tap)(method, params_json, scan);
  const auto to = targets(topic, scan);
  if (to.empty()) return;
  std::string text = R"({"jsonrpc":"2.0","method":)";
  text += nlohmann::json(method).dump();
  text += R"(,"params":)";
  text += params_json;
  text += '}';
  deliver(to, std::make_shared<const std::string>(std::move(text)));
}

std::size_t Hub::sessions() const {
  std::lock_guard lock(mu_);
  return entries_.size();
}

std::uint64_t Hub::dropped() const {
  std::lock_guard lock(mu_);
  return dropped_;
}

}  // namespace gonio::daemon
