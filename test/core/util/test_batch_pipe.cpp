#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "die_cushion_ident/core/util/batch_pipe.h"

namespace die_cushion_ident {
namespace {

TEST(BatchPipe, EveryItemArrivesOnceInTheOrderPushed) {
  std::vector<int> received;
  BatchPipe<int> pipe([&](const int& i) { received.push_back(i); }, 64, 2);
  constexpr int kItems = 100003;  // not a whole number of batches: the last one is handed over by finish()
  for (int i = 0; i < kItems; ++i) pipe.push(i);
  pipe.finish();
  ASSERT_EQ(received.size(), static_cast<std::size_t>(kItems));
  for (int i = 0; i < kItems; ++i) ASSERT_EQ(received[i], i);
}

TEST(BatchPipe, TheProducerIsHeldBackByAFullPipe) {
  // A slow consumer: the items pushed but not yet consumed never exceed the batches allowed to wait, the one
  // being filled and the one being consumed.
  std::atomic<int> consumed{0};
  constexpr std::size_t kBatch = 16, kWaiting = 3;
  BatchPipe<int> pipe(
      [&](const int&) {
        std::this_thread::sleep_for(std::chrono::microseconds(20));
        ++consumed;
      },
      kBatch, kWaiting);
  int most_ahead = 0;
  for (int i = 0; i < 2000; ++i) {
    pipe.push(i);
    most_ahead = std::max(most_ahead, i + 1 - consumed.load());
  }
  pipe.finish();
  EXPECT_EQ(consumed.load(), 2000);
  EXPECT_LE(most_ahead, static_cast<int>(kBatch * (kWaiting + 2)));
}

TEST(BatchPipe, TheConsumersExceptionReachesFinishAndTheProducerIsNotBlocked) {
  int seen = 0;
  BatchPipe<int> pipe(
      [&](const int& i) {
        ++seen;
        if (i == 5) throw std::runtime_error("item 5 is bad");
      },
      4, 1);
  for (int i = 0; i < 10000; ++i)
    pipe.push(i);  // would block for good if the consumer stopped taking batches
  EXPECT_THROW(pipe.finish(), std::runtime_error);
  EXPECT_EQ(seen, 6) << "nothing after the failing item is consumed";
  EXPECT_NO_THROW(pipe.finish()) << "reported once";
}

TEST(BatchPipe, DestroyedWithoutFinishItStillConsumesEverything) {
  int received = 0;
  {
    BatchPipe<int> pipe([&](const int&) { ++received; }, 8, 2);
    for (int i = 0; i < 100; ++i) pipe.push(i);
  }
  EXPECT_EQ(received, 100);
}

}  // namespace
}  // namespace die_cushion_ident
