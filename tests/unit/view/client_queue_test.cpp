// ClientQueue: a new client gets the whole state first; messages in order within the bounds; a client that
// falls behind skips to the whole current state (queue dropped, counted) and never holds more than the bounds.
#include "groundstation/view/client_queue.hpp"

#include <gtest/gtest.h>

namespace teamscan::view {
namespace {

SharedMessage msg(std::size_t bytes, char fill = 'x') {
  auto m = std::make_shared<Message>();
  m->bytes.assign(bytes, fill);
  return m;
}

TEST(ClientQueue, NewClientGetsTheWholeStateFirstThenMessagesInOrder) {
  ClientQueue q({.max_bytes = 1000, .max_messages = 10});
  SharedMessage out;
  q.push(msg(10, 'a'));  // before the whole state was sent: it is in the whole state
  EXPECT_EQ(q.size(), 0u);
  EXPECT_EQ(q.next(out), ClientQueue::Next::kWholeState);
  q.push(msg(10, 'b'));
  q.push(msg(20, 'c'));
  EXPECT_EQ(q.size(), 2u);
  EXPECT_EQ(q.bytes(), 30u);
  ASSERT_EQ(q.next(out), ClientQueue::Next::kMessage);
  EXPECT_EQ(out->bytes[0], 'b');
  ASSERT_EQ(q.next(out), ClientQueue::Next::kMessage);
  EXPECT_EQ(out->bytes[0], 'c');
  EXPECT_EQ(q.next(out), ClientQueue::Next::kNothing);
  EXPECT_EQ(q.bytes(), 0u);
  EXPECT_EQ(q.skips(), 0u);
}

TEST(ClientQueue, ASlowClientSkipsToTheLatestStateWhenBytesRunOver) {
  ClientQueue q({.max_bytes = 100, .max_messages = 1000});
  SharedMessage out;
  ASSERT_EQ(q.next(out), ClientQueue::Next::kWholeState);
  for (int i = 0; i < 1000; ++i) {
    q.push(msg(30));
    EXPECT_LE(q.bytes(), 100u);  // never more than the bound, however far behind
  }
  EXPECT_TRUE(q.whole_pending());
  EXPECT_EQ(q.skips(), 1u);  // dropped once; later pushes wait for the whole state
  EXPECT_EQ(q.size(), 0u);
  EXPECT_EQ(q.next(out), ClientQueue::Next::kWholeState);
  EXPECT_EQ(q.next(out), ClientQueue::Next::kNothing);
  q.push(msg(30, 'n'));  // after the whole state: changes again
  ASSERT_EQ(q.next(out), ClientQueue::Next::kMessage);
  EXPECT_EQ(out->bytes[0], 'n');
}

TEST(ClientQueue, ASlowClientSkipsWhenMessagesRunOver) {
  ClientQueue q({.max_bytes = 1u << 20, .max_messages = 3});
  SharedMessage out;
  ASSERT_EQ(q.next(out), ClientQueue::Next::kWholeState);
  q.push(msg(1));
  q.push(msg(1));
  q.push(msg(1));
  EXPECT_EQ(q.size(), 3u);
  q.push(msg(1));
  EXPECT_EQ(q.size(), 0u);
  EXPECT_EQ(q.skips(), 1u);
  EXPECT_EQ(q.next(out), ClientQueue::Next::kWholeState);
}

TEST(ClientQueue, AMessageLargerThanTheBoundSkipsInsteadOfQueueing) {
  ClientQueue q({.max_bytes = 100, .max_messages = 10});
  SharedMessage out;
  ASSERT_EQ(q.next(out), ClientQueue::Next::kWholeState);
  q.push(msg(101));
  EXPECT_EQ(q.bytes(), 0u);
  EXPECT_EQ(q.skips(), 1u);
  EXPECT_EQ(q.next(out), ClientQueue::Next::kWholeState);
}

}  // namespace
}  // namespace teamscan::view
