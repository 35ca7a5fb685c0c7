#pragma once
// Joining the pieces of one edge (boundary.h's chaining step).
//
// Canny's 8-connected edge pixels are walked into chains, and a walk ends where the edge
// branches: a spur of one or two pixels, which a blurred edge grows where its gradient is
// broad and flat-topped (measured: a part whose lens blur reaches 2 px broke into 11 pieces
// 1-2 px apart, and the inspection took the breaks for a dust speck). The sub-pixel points
// of both pieces lie on the same edge, so the pieces are joined here, after refinement and
// before the chains are smoothed.
#include <vector>

#include "flatscan/boundary/edge_refinement.h"

namespace flatscan {

struct ChainLinkOptions {
  // Ends at most this far apart (px) may be joined. A speck of dust touching the edge
  // hides more than this (docs/inspection.md, "Image defects").
  double max_gap_px = 3.0;
  // The ends' normals agree: cos(angle) at least this (about 37 degrees).
  double min_normal_cos = 0.8;
  // Each end heads toward the other: the gap's direction within acos(0.5) = 60 degrees of
  // the end's own direction (over its last few points).
  double min_heading_cos = 0.5;
  // A chain's own two ends are joined (a ring) only when it has at least this many points.
  int min_ring_points = 8;
};

struct LinkedChain {
  std::vector<ChainPoint> points;
  bool ring = false;  // its last point joins its first (closed)
};

// Appends `point` to `chain` unless it is the chain's last point again (within 0.25 px:
// one crossing reached from two edge pixels). The chaining and the joining both build
// chains with it.
void AppendChainPoint(std::vector<ChainPoint>& chain, const ChainPoint& point);

// Joins the chains end to end, closest ends first, each end at most once; a chain is
// reversed where needed. Points of the first piece that run past the start of the
// second (a spur refined onto the edge) are trimmed. A path that comes back to its start
// is a ring (its seam trimmed the same way). Chains of fewer than 2 points are returned
// as they are. Deterministic: the output depends only on the input and its order.
std::vector<LinkedChain> LinkChainEnds(std::vector<std::vector<ChainPoint>> chains,
                                       const ChainLinkOptions& options = {});

}  // namespace flatscan
