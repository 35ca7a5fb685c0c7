#include "flatscan/boundary/chain_linking.h"

#include <cmath>

#include <gtest/gtest.h>

namespace flatscan {
namespace {

// Points on a circle of radius 40 px about the origin from angle a0 to a1 (radians,
// 1 px apart), normals pointing out (a dark disc on a bright field).
std::vector<ChainPoint> Arc(double a0, double a1) {
  std::vector<ChainPoint> arc;
  const int n = static_cast<int>(std::lround(std::abs(a1 - a0) * 40.0));
  for (int k = 0; k <= n; ++k) {
    const double a = a0 + k * (a1 - a0) / n;
    ChainPoint p;
    p.normal = Eigen::Vector2d(std::cos(a), std::sin(a));
    p.p = 40.0 * p.normal;
    arc.push_back(p);
  }
  return arc;
}

TEST(ChainLinking, JoinsThePiecesOfOneEdgeIntoOneChainWhateverTheirDirection) {
  // A circle in three pieces with 1.5 px gaps, the middle one walked backwards.
  const double gap = 1.5 / 40.0;
  const std::vector<std::vector<ChainPoint>> pieces = {Arc(0.0, 2.0), Arc(4.0, 2.0 + gap), Arc(4.0 + gap, 2 * M_PI - gap)};
  const auto joined = LinkChainEnds(pieces);
  ASSERT_EQ(joined.size(), 1u);
  EXPECT_TRUE(joined[0].ring);
  const std::vector<ChainPoint>& ring = joined[0].points;
  EXPECT_EQ(ring.size(), pieces[0].size() + pieces[1].size() + pieces[2].size());
  EXPECT_LT((ring.front().p - ring.back().p).norm(), 2.0);  // closed by boundary.cc's rule
  for (size_t i = 1; i < ring.size(); ++i) EXPECT_LT((ring[i].p - ring[i - 1].p).norm(), 1.6) << i;
}

TEST(ChainLinking, ARingJoinedAcrossGapsWiderThanTheClosingRuleIsARing) {
  // Three pieces 2.5 px apart (boundary.cc's own rule closes only under 2 px): whichever
  // join is the seam, the result is one ring; and one chain whose ends are 2.5 px apart
  // closes on itself.
  const double gap = 2.5 / 40.0;
  const auto joined = LinkChainEnds({Arc(0.0, 2.0), Arc(2.0 + gap, 4.0), Arc(4.0 + gap, 2 * M_PI - gap)});
  ASSERT_EQ(joined.size(), 1u);
  EXPECT_TRUE(joined[0].ring);
  const auto single = LinkChainEnds({Arc(0.0, 2 * M_PI - gap)});
  ASSERT_EQ(single.size(), 1u);
  EXPECT_TRUE(single[0].ring);
  // ... but not a short chain (under min_ring_points), nor a half circle.
  EXPECT_FALSE(LinkChainEnds({Arc(0.0, 0.1)})[0].ring);
  EXPECT_FALSE(LinkChainEnds({Arc(0.0, M_PI)})[0].ring);
}

TEST(ChainLinking, ChainsTooShortForADirectionComeBackAsTheyAre) {
  std::vector<ChainPoint> lone(1);
  lone[0].p = Eigen::Vector2d(40.0, 0.0);
  lone[0].normal = Eigen::Vector2d(1.0, 0.0);
  const auto joined = LinkChainEnds({Arc(0.0, 1.0), lone, {}});
  ASSERT_EQ(joined.size(), 3u);
  EXPECT_EQ(joined[1].points.size(), 1u);
  EXPECT_TRUE(joined[2].points.empty());
}

TEST(ChainLinking, LeavesGapsWiderThanTheLimitAndOppositeEdgesApart) {
  // 4 px gap (a speck's neck): not joined.
  EXPECT_EQ(LinkChainEnds({Arc(0.0, 1.0), Arc(1.0 + 4.0 / 40, 2.0)}).size(), 2u);
  // Ends 1 px apart whose normals are opposite (the two sides of a thin slot): not joined.
  std::vector<ChainPoint> a = Arc(0.0, 1.0), b = Arc(1.0 + 1.0 / 40, 2.0);
  for (ChainPoint& p : b) p.normal = -p.normal;
  EXPECT_EQ(LinkChainEnds({a, b}).size(), 2u);
  // Two parallel edges side by side, ends 1 px apart but heading the same way: not joined.
  std::vector<ChainPoint> c = Arc(0.0, 1.0), d = Arc(0.0, 1.0);
  for (ChainPoint& p : d) p.p *= 41.0 / 40.0;
  EXPECT_EQ(LinkChainEnds({c, d}).size(), 2u);
}

TEST(ChainLinking, TrimsASpurThatRunsPastTheNextPiecesStart) {
  // The first piece's last 2 points overlap the second piece's start (a spur refined onto
  // the edge): they are dropped, and the joined chain never steps back.
  std::vector<ChainPoint> first = Arc(0.0, 1.0 + 2.0 / 40), second = Arc(1.0 + 0.5 / 40, 2.0);
  const auto joined = LinkChainEnds({first, second});
  ASSERT_EQ(joined.size(), 1u);
  EXPECT_FALSE(joined[0].ring);
  const std::vector<ChainPoint>& chain = joined[0].points;
  for (size_t i = 1; i < chain.size(); ++i) {
    const Eigen::Vector2d step = chain[i].p - chain[i - 1].p;
    const Eigen::Vector2d tangent(-chain[i].normal.y(), chain[i].normal.x());
    EXPECT_GT(step.dot(tangent), 0.2) << i;
  }
}

}  // namespace
}  // namespace flatscan
