// Blocking work taken from clients in turn (docs/architecture.md §5).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <unordered_map>

namespace gonio::daemon::rpc {

// Tasks queued per client (a session's id), taken one client at a time in rotation, each
// client's own tasks in the order they came. A plain FIFO lets one client that queues a
// thousand reads (a batch, a pipeline) stand between every other client and its answer;
// here a technician's call waits for at most one task of each other client with work.
class FairQueue {
 public:
  using Task = std::function<void()>;

  void push(std::uint64_t client, Task task);
  // The next task in rotation; empty when nothing is queued.
  Task pop();
  std::size_t size() const;
  // Clients with at least one task queued.
  std::size_t clients() const;

 private:
  mutable std::mutex mu_;
  std::unordered_map<std::uint64_t, std::deque<Task>> lanes_;
  std::deque<std::uint64_t> turn_;  // the clients with work, in the order of their next turn
  std::size_t size_ = 0;
};

}  // namespace gonio::daemon::rpc
