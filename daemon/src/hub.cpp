// Subscriptions and notification fan-out (see hub.hpp).
#include "gonio/daemon/hub.hpp"

#include <fmt/format.h>

namespace gonio::daemon {

std::string_view topic_name(Topic t) noexcept {
  switch (t) {
    case Topic::progress: return "progress";
    case Topic::points: return "points";
    case Topic::alerts: return "alerts";
    case Topic::state: return "state";
  }
  return "state";
}

Topic parse_topic(std::string_view text, std::string_view field) {
  for (Topic t : {Topic::progress, Topic::points, Topic::alerts, Topic::state})
    if (topic_name(t) == text) return t;
  throw Error::invalid(std::string(field),
                       fmt::format("'{}' is not a topic (allowed: progress, points, alerts, state)",
                                   text));
}

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

void Hub::publish(Topic topic, std::string_view method, const nlohmann::json& params,
                  std::optional<std::int64_t> scan) {
  std::vector<std::shared_ptr<rpc::Session>> targets;
  {
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
      if (e.topics.contains(topic) && scan_ok) targets.push_back(std::move(s));
      ++it;
    }
  }
  if (targets.empty()) return;
  const auto text = std::make_shared<const std::string>(rpc::notification(method, params));
  std::uint64_t refused = 0;
  for (const auto& s : targets)
    if (!s->push(text)) ++refused;
  if (refused) {
    std::lock_guard lock(mu_);
    dropped_ += refused;
  }
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
