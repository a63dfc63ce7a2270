// Clients in turn: the order FairQueue hands out tasks.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "gonio/daemon/rpc/fair_queue.hpp"

namespace gonio::daemon::rpc {
namespace {

TEST(FairQueue, TakesClientsInTurnAndEachClientsTasksInOrder) {
  FairQueue q;
  std::string ran;
  const auto task = [&](char c) { return [&ran, c] { ran += c; }; };
  for (char c : std::string("abc")) q.push(1, task(c));
  for (char c : std::string("XY")) q.push(2, task(c));
  q.push(3, task('z'));
  EXPECT_EQ(q.size(), 6u);
  EXPECT_EQ(q.clients(), 3u);
  while (auto t = q.pop()) t();
  EXPECT_EQ(ran, "aXzbYc");
  EXPECT_EQ(q.size(), 0u);
  EXPECT_EQ(q.clients(), 0u);
  EXPECT_FALSE(q.pop());
}

TEST(FairQueue, AClientThatComesBackQueuesBehindThoseWaiting) {
  FairQueue q;
  std::string ran;
  q.push(1, [&] { ran += 'a'; });
  q.push(2, [&] { ran += 'X'; });
  q.pop()();     // client 1's only task: it leaves the rotation
  q.push(1, [&] { ran += 'b'; });  // and rejoins at its end
  q.push(2, [&] { ran += 'Y'; });
  while (auto t = q.pop()) t();
  EXPECT_EQ(ran, "aXbY");
}

}  // namespace
}  // namespace gonio::daemon::rpc
