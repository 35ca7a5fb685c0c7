#pragma once
// Things in the simulated scene that a camera ray can hit, described by a signed
// distance along the ray, so that pixels can be area-sampled exactly at boundaries.
//
// RaySignedDistance(ray) is negative when the ray hits the object and positive when it
// misses; its magnitude is (a lower bound on) how far, in mm measured across the ray
// near the object, the ray would have to move to change that. The silhouette is its
// zero set. Rays are in the support frame (plane z = 0, +z toward the cameras).
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "flatscan/geometry/rigid3.h"

namespace flatscan {

struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;  // need not be unit
};

class Occluder {
 public:
  virtual ~Occluder() = default;
  virtual double RaySignedDistance(const Ray& ray) const = 0;
  // Points (support frame) whose projections bound the object's image; the renderer
  // adds a margin. Also used to measure the local image scale (pixels per mm).
  virtual std::vector<Eigen::Vector3d> BoundingPoints() const = 0;
};

// A zero-thickness shape on a plane: plane_from_support maps support-frame points to
// a frame whose z = 0 is the shape's plane; `sdf` is the 2D signed distance of the
// shape in that plane's (x, y), mm, negative inside.
class PlanarOccluder : public Occluder {
 public:
  using Sdf2d = std::function<double(const Eigen::Vector2d&)>;
  PlanarOccluder(const Rigid3d& plane_from_support, Sdf2d sdf, std::vector<Eigen::Vector2d> outline);
  double RaySignedDistance(const Ray& ray) const override;
  std::vector<Eigen::Vector3d> BoundingPoints() const override;

 private:
  Rigid3d plane_from_support_;
  Sdf2d sdf_;
  std::vector<Eigen::Vector2d> outline_;  // bounding polygon in the plane
};

// Signed distance helpers (2D, mm, negative inside).
double RoundedRectSdf(const Eigen::Vector2d& p, double half_width, double half_height, double radius);
double CircleSdf(const Eigen::Vector2d& p, const Eigen::Vector2d& center, double radius);
double AnnulusSdf(const Eigen::Vector2d& p, const Eigen::Vector2d& center, double inner_radius,
                  double outer_radius);
// Chessboard black squares: squares (i, j) with (i + j) even are black, the board's
// square grid starts at (0, 0) with `cols` x `rows` squares of side `square`.
double CheckerSdf(const Eigen::Vector2d& p, int cols, int rows, double square);

}  // namespace flatscan
