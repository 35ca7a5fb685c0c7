#include "flatscan/util/statistics.h"

#include <gtest/gtest.h>

namespace flatscan {
namespace {

TEST(Statistics, MedianTakesTheMeanOfTheMiddleTwoForAnEvenCount) {
  EXPECT_EQ(Median({}), 0.0);
  EXPECT_EQ(Median({3, 1, 2}), 2.0);
  EXPECT_EQ(Median({4, 1, 3, 2}), 2.5);
}

// Replicates +e, -e, +e, -e: mean 0, sum of squares 4 e^2, so (3 / 4) 4 e^2 = 3 e^2.
TEST(Statistics, JackknifeVarianceOfAlternatingReplicates) {
  EXPECT_EQ(JackknifeVariance({}), 0.0);
  EXPECT_EQ(JackknifeVariance({5.0}), 0.0);
  EXPECT_DOUBLE_EQ(JackknifeVariance({0.5, -0.5, 0.5, -0.5}), 0.75);
}

}  // namespace
}  // namespace flatscan
