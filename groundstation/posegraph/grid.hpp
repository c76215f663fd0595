// A submap's 2-D grid: a dense, growing array of cells, each the likelihood that a laser return lies
// there (a Gaussian of the distance to the nearest return inserted, so scan matching sees a smooth
// basin around every wall). Cell (i, j) is sampled at (i·resolution, j·resolution) in the submap's
// frame, so a point's continuous cell coordinates are simply x / resolution and y / resolution.
#pragma once

#include <cstdint>
#include <vector>

#include "common/pose.hpp"

namespace teamscan::posegraph {

struct CellBox {
  int x0 = 0, y0 = 0;          // the first cell's index
  int width = 0, height = 0;   // cells
  [[nodiscard]] bool contains(int x, int y) const { return x >= x0 && y >= y0 && x < x0 + width && y < y0 + height; }
};

class Grid {
 public:
  // `hit_sigma_m`: the spread of a return's likelihood; `border_cells`: empty cells kept around the
  // occupied area, so interpolation and the correlative search see zeros there.
  Grid(double resolution_m, double hit_sigma_m, int border_cells = 8);

  // The points (submap frame, metres) as returns: each cell within two sigma takes the larger of its
  // value and the Gaussian of its distance to the point.
  void insert(const std::vector<Vec2>& points_m);

  [[nodiscard]] double resolution_m() const { return resolution_m_; }
  [[nodiscard]] const CellBox& box() const { return box_; }
  // Row-major (y rows, x columns) values of box(); 0 = nothing seen near.
  [[nodiscard]] const std::vector<float>& values() const { return values_; }
  [[nodiscard]] float at(int x, int y) const {
    return box_.contains(x, y) ? values_[static_cast<std::size_t>(y - box_.y0) * static_cast<std::size_t>(box_.width) + static_cast<std::size_t>(x - box_.x0)] : 0.0f;
  }
  [[nodiscard]] bool empty() const { return values_.empty(); }

 private:
  void grow_to(int x_min, int y_min, int x_max, int y_max);

  double resolution_m_;
  double hit_sigma_m_;
  int border_cells_;
  int kernel_cells_;
  CellBox box_;
  std::vector<float> values_;
};

}  // namespace teamscan::posegraph
