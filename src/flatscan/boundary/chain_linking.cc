#include "flatscan/boundary/chain_linking.h"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace flatscan {
namespace {

constexpr int kHeadingSpan = 3;     // an end's direction: from the point this many back
constexpr int kMaxTrimmed = 3;      // points of a spur trimmed at a join, at most
constexpr double kSamePointPx = 0.25;  // one crossing reached from two edge pixels
constexpr double kMaxOverlapOffsetPx = 0.5;  // overlapping ends lie on one edge: this far apart across it

// End e of chain e / 2: its front (e even) or its back (e odd).
struct End {
  Eigen::Vector2d p, normal;
  Eigen::Vector2d heading;  // unit, pointing out of the chain
};

End EndOf(const std::vector<ChainPoint>& chain, bool back) {
  const int n = static_cast<int>(chain.size());
  const int at = back ? n - 1 : 0, inner = back ? std::max(0, n - 1 - kHeadingSpan) : std::min(n - 1, kHeadingSpan);
  End end{chain[at].p, chain[at].normal, chain[at].p - chain[inner].p};
  end.heading.normalize();
  return end;
}

// Ends that continue each other: normals alike, headings opposite, and either a gap
// each end heads into, or an overlap (b starts before a ends, a spur's points refined
// onto the edge) lying along the edge.
bool CanJoin(const End& a, const End& b, const ChainLinkOptions& options) {
  const Eigen::Vector2d gap = b.p - a.p;
  const double length = gap.norm();
  if (length > options.max_gap_px || a.normal.dot(b.normal) < options.min_normal_cos) return false;
  if (a.heading.dot(b.heading) > -options.min_heading_cos) return false;
  if (length < kSamePointPx) return true;
  const double along = gap.dot(a.heading), across = std::abs(a.heading.x() * gap.y() - a.heading.y() * gap.x());
  if (along < 0) return across <= kMaxOverlapOffsetPx;
  const Eigen::Vector2d towards = gap / length;
  return a.heading.dot(towards) >= options.min_heading_cos && b.heading.dot(-towards) >= options.min_heading_cos;
}

// Drops up to kMaxTrimmed points at the end of `out` that run past `start` along
// `forward` (a unit direction), and a last point that is `start` again.
void TrimPast(std::vector<ChainPoint>& out, const Eigen::Vector2d& start, const Eigen::Vector2d& forward) {
  for (int k = 0; k < kMaxTrimmed && out.size() > 1 && (out.back().p - start).dot(forward) > -kSamePointPx; ++k)
    out.pop_back();
  if (out.size() > 1 && (out.back().p - start).squaredNorm() < kSamePointPx * kSamePointPx) out.pop_back();
}

// The direction a chain starts in (unit), over its first few points.
Eigen::Vector2d StartDirection(const std::vector<ChainPoint>& chain) {
  return (chain[std::min<size_t>(kHeadingSpan, chain.size() - 1)].p - chain[0].p).normalized();
}

// Appends `next` (already oriented) to `out`, trimming out's points that run past
// next's start along next's direction.
void Append(std::vector<ChainPoint>& out, const std::vector<ChainPoint>& next) {
  if (!out.empty() && next.size() >= 2) TrimPast(out, next[0].p, StartDirection(next));
  for (const ChainPoint& point : next) AppendChainPoint(out, point);
}

}  // namespace

void AppendChainPoint(std::vector<ChainPoint>& chain, const ChainPoint& point) {
  if (chain.empty() || (chain.back().p - point.p).squaredNorm() >= kSamePointPx * kSamePointPx) chain.push_back(point);
}

std::vector<LinkedChain> LinkChainEnds(std::vector<std::vector<ChainPoint>> chains, const ChainLinkOptions& options) {
  const int n = static_cast<int>(chains.size());
  std::vector<End> ends(2 * n);
  for (int c = 0; c < n; ++c)
    if (chains[c].size() >= 2) ends[2 * c] = EndOf(chains[c], false), ends[2 * c + 1] = EndOf(chains[c], true);
  // Candidate joins, closest first (ties in index order): ends of different chains, and a
  // chain's own two ends (it closes into a ring) when it is long enough to be one.
  std::vector<std::tuple<double, int, int>> candidates;
  for (int a = 0; a < 2 * n; ++a) {
    if (chains[a / 2].size() < 2) continue;
    for (int b = a + 1; b < 2 * n; ++b) {
      const bool same = b / 2 == a / 2;
      if (same && static_cast<int>(chains[a / 2].size()) < options.min_ring_points) continue;
      if (chains[b / 2].size() >= 2 && CanJoin(ends[a], ends[b], options))
        candidates.emplace_back((ends[a].p - ends[b].p).norm(), a, b);
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<int> partner(2 * n, -1);
  for (const auto& [distance, a, b] : candidates)
    if (partner[a] < 0 && partner[b] < 0) partner[a] = b, partner[b] = a;

  // Walk each path of joined chains from a free end; what is left are rings, whose last
  // join (the seam, back to the first piece's start) is trimmed like the others.
  std::vector<char> used(n, 0);
  std::vector<LinkedChain> out;
  auto walk = [&](int first, int entry_end) {
    LinkedChain joined;
    int end = entry_end;
    for (int c = first; c >= 0 && !used[c];) {
      used[c] = 1;
      std::vector<ChainPoint>& piece = chains[c];
      if (end % 2 == 1) std::reverse(piece.begin(), piece.end());  // entered at its back
      Append(joined.points, piece);
      end = partner[end ^ 1];
      c = end < 0 ? -1 : end / 2;
    }
    joined.ring = end >= 0 && end == entry_end;
    if (joined.ring && joined.points.size() >= 2)
      TrimPast(joined.points, joined.points.front().p, StartDirection(joined.points));
    out.push_back(std::move(joined));
  };
  for (int c = 0; c < n; ++c)
    if (!used[c] && (partner[2 * c] < 0 || partner[2 * c + 1] < 0)) walk(c, partner[2 * c] < 0 ? 2 * c : 2 * c + 1);
  for (int c = 0; c < n; ++c)
    if (!used[c]) walk(c, 2 * c);
  return out;
}

}  // namespace flatscan
