// One browser's send queue (view/send_queue.hpp): bounded in bytes, tiles and states coalesce
// (newest wins, in the place of the first), a reset clears it.

#include "send_queue.hpp"

#include <gtest/gtest.h>

namespace esfleet::view {
namespace {

OutMessage msg(std::string key, std::string data) {
  return {std::move(key), std::make_shared<const std::string>(std::move(data)), true};
}

TEST(SendQueue, FifoWithoutKeys) {
  SendQueue q(100);
  EXPECT_TRUE(q.push(msg("", "a")));
  EXPECT_TRUE(q.push(msg("", "bb")));
  EXPECT_EQ(q.size(), 2u);
  EXPECT_EQ(q.bytes(), 3u);
  EXPECT_EQ(*q.pop().data, "a");
  EXPECT_EQ(*q.pop().data, "bb");
  EXPECT_TRUE(q.empty());
  EXPECT_EQ(q.bytes(), 0u);
}

TEST(SendQueue, SameKeyCoalescesNewestWinsInPlace) {
  SendQueue q(100);
  ASSERT_TRUE(q.push(msg(tile_key(1, 2), "v1")));
  ASSERT_TRUE(q.push(msg(tile_key(3, 4), "w1")));
  ASSERT_TRUE(q.push(msg(tile_key(1, 2), "v2--")));
  ASSERT_TRUE(q.push(msg(tile_key(1, 2), "v3")));
  EXPECT_EQ(q.size(), 2u);
  EXPECT_EQ(q.bytes(), 4u);
  EXPECT_EQ(q.coalesced(), 2u);
  const OutMessage first = q.pop();
  EXPECT_EQ(first.key, "t:1,2");
  EXPECT_EQ(*first.data, "v3");
  EXPECT_EQ(*q.pop().data, "w1");
  // Once sent, the key may be queued again.
  ASSERT_TRUE(q.push(msg(tile_key(1, 2), "v4")));
  EXPECT_EQ(q.size(), 1u);
}

TEST(SendQueue, OverflowIsRefusedAndLeavesTheQueueAsItWas) {
  SendQueue q(10);
  ASSERT_TRUE(q.push(msg("a", "12345")));
  ASSERT_TRUE(q.push(msg("b", "1234")));
  EXPECT_FALSE(q.push(msg("c", "12")));
  EXPECT_EQ(q.size(), 2u);
  EXPECT_EQ(q.bytes(), 9u);
  // A replacement that grows past the bound is refused too; one that fits is taken.
  EXPECT_FALSE(q.push(msg("a", "1234567")));
  EXPECT_TRUE(q.push(msg("a", "123456")));
  EXPECT_EQ(q.bytes(), 10u);
}

TEST(SendQueue, ManyUpdatesOfFewTilesStayBounded) {
  // A browser that reads nothing while 1000 publishes of 50 tiles go by holds 50 tiles.
  SendQueue q(50 * 300);
  for (int round = 0; round < 1000; ++round) {
    for (int t = 0; t < 50; ++t) {
      ASSERT_TRUE(q.push(msg(tile_key(t, 0), std::string(200 + round % 100, 'x'))));
    }
  }
  EXPECT_EQ(q.size(), 50u);
  EXPECT_EQ(q.coalesced(), 999u * 50u);
}

TEST(SendQueue, ClearEmptiesEverything) {
  SendQueue q(100);
  ASSERT_TRUE(q.push(msg("t:0,0", "abc")));
  q.clear();
  EXPECT_TRUE(q.empty());
  EXPECT_EQ(q.bytes(), 0u);
  ASSERT_TRUE(q.push(msg("t:0,0", "d")));
  EXPECT_EQ(q.size(), 1u);
}

}  // namespace
}  // namespace esfleet::view
