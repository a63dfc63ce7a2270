// Clients in turn (fair_queue.hpp).
#include "gonio/daemon/rpc/fair_queue.hpp"

namespace gonio::daemon::rpc {

void FairQueue::push(std::uint64_t client, Task task) {
  std::lock_guard lock(mu_);
  auto& lane = lanes_[client];
  if (lane.empty()) turn_.push_back(client);
  lane.push_back(std::move(task));
  ++size_;
}

FairQueue::Task FairQueue::pop() {
  std::lock_guard lock(mu_);
  if (turn_.empty()) return {};
  const auto client = turn_.front();
  turn_.pop_front();
  const auto it = lanes_.find(client);
  Task task = std::move(it->second.front());
  it->second.pop_front();
  if (it->second.empty()) lanes_.erase(it);
  else turn_.push_back(client);
  --size_;
  return task;
}

std::size_t FairQueue::size() const {
  std::lock_guard lock(mu_);
  return size_;
}

std::size_t FairQueue::clients() const {
  std::lock_guard lock(mu_);
  return turn_.size();
}

}  // namespace gonio::daemon::rpc
