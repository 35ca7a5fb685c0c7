#include "flatscan/util/ordered_parallel.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace flatscan {
namespace {

TEST(ParallelInOrder, DeliversEveryResultInOrderWithBoundedItemsInFlight) {
  constexpr size_t kCount = 400, kInFlight = 4;
  std::atomic<int> in_flight{0}, most_in_flight{0};
  std::vector<size_t> delivered;
  ParallelInOrder<size_t>(
      kCount, kInFlight,
      [&](size_t i) {
        const int now = ++in_flight;
        int most = most_in_flight.load();
        while (now > most && !most_in_flight.compare_exchange_weak(most, now)) {
        }
        // Later items finish first now and then: delivery must still keep the order.
        std::this_thread::sleep_for(std::chrono::microseconds(i % 7 == 0 ? 300 : 10));
        return i * i;
      },
      [&](size_t i, size_t& square) {
        EXPECT_EQ(square, i * i);
        delivered.push_back(i);
        --in_flight;
      });
  ASSERT_EQ(delivered.size(), kCount);
  for (size_t i = 0; i < kCount; ++i) EXPECT_EQ(delivered[i], i);
  EXPECT_LE(most_in_flight.load(), static_cast<int>(kInFlight));
  EXPECT_GE(most_in_flight.load(), 1);
}

}  // namespace
}  // namespace flatscan
