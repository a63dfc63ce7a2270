// Hub — subscriptions and the notifications pushed to them.
//
// A persistent session (NDJSON socket, WebSocket) subscribes to topics; publish() encodes a
// JSON-RPC notification once and queues it on every subscribed session. A session whose
// queue is full is dropped by its transport (a slow reader must not hold memory without
// bound), and the hub forgets sessions that are gone.
//
//   topic      notification method    params
//   progress   scan.progress          {scan, state, reason, points_done, points_total,
//                                      points_diverged, eta_s, adaptive (running scans:
//                                      the adaptive loop's state, null for a plain scan)}
//   points     scan.point             a PointRecord
//   alerts     alert                  an Alert (new, bumped, acknowledged or resolved)
//   state      instrument.state       instrument.status result
//              scan.state             {scan, state, reason}
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "gonio/daemon/rpc/rpc.hpp"
#include "gonio/proto/enum_text.hpp"

namespace gonio::daemon {

enum class Topic { progress, points, alerts, state };
inline constexpr EnumNames<Topic, 4> kTopicNames{{
    {Topic::progress, "progress"},
    {Topic::points, "points"},
    {Topic::alerts, "alerts"},
    {Topic::state, "state"},
}};
constexpr const auto& enum_names(Topic) { return kTopicNames; }  // proto/enum_text.hpp

class Hub {
 public:
  // Adds topics (optionally only for one scan: progress and points) to the session.
  void subscribe(const std::shared_ptr<rpc::Session>& s, const std::set<Topic>& topics,
                 std::optional<std::int64_t> scan);
  // Removes topics (all when empty). Returns the topics left.
  std::set<Topic> unsubscribe(std::uint64_t session, const std::set<Topic>& topics);
  std::set<Topic> topics(std::uint64_t session) const;
  void remove(std::uint64_t session);

  // `scan` restricts delivery to sessions that subscribed without a scan filter or to it.
  void publish(Topic topic, std::string_view method, const nlohmann::json& params,
               std::optional<std::int64_t> scan = std::nullopt);
  // The same with params already serialised (spliced in unchanged).
  void publish_raw(Topic topic, std::string_view method, const std::string& params_json,
                   std::optional<std::int64_t> scan = std::nullopt);

  // Receives every notification published, subscribers or not, with its params as JSON
  // text (MQTT mirrors the hub through this). Called on the publishing thread: it must not
  // block.
  using Tap = std::function<void(std::string_view method, const std::string& params_json,
                                 std::optional<std::int64_t> scan)>;
  void set_tap(Tap tap);

  std::size_t sessions() const;
  std::uint64_t dropped() const;  // notifications refused by full or closed sessions

 private:
  struct Entry {
    std::weak_ptr<rpc::Session> session;
    std::set<Topic> topics;
    std::optional<std::int64_t> scan;
  };
  std::vector<std::shared_ptr<rpc::Session>> targets(Topic topic, std::optional<std::int64_t> scan);
  void deliver(const std::vector<std::shared_ptr<rpc::Session>>& to,
               const std::shared_ptr<const std::string>& text);

  mutable std::mutex mu_;
  std::map<std::uint64_t, Entry> entries_;
  std::uint64_t dropped_ = 0;
  std::shared_ptr<const Tap> tap_;
};

}  // namespace gonio::daemon
