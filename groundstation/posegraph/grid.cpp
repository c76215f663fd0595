// A submap's likelihood grid (grid.hpp).
#include "groundstation/posegraph/grid.hpp"

#include <algorithm>
#include <cmath>

namespace teamscan::posegraph {

Grid::Grid(double resolution_m, double hit_sigma_m, int border_cells)
    : resolution_m_(resolution_m),
      hit_sigma_m_(hit_sigma_m),
      border_cells_(border_cells),
      kernel_cells_(std::max(1, static_cast<int>(std::ceil(2.0 * hit_sigma_m / resolution_m)))) {}

void Grid::grow_to(int x_min, int y_min, int x_max, int y_max) {
  x_min -= border_cells_;
  y_min -= border_cells_;
  x_max += border_cells_;
  y_max += border_cells_;
  if (!values_.empty() && box_.contains(x_min, y_min) && box_.contains(x_max, y_max)) return;
  CellBox next = box_;
  if (values_.empty()) {
    next = {x_min, y_min, x_max - x_min + 1, y_max - y_min + 1};
  } else {
    // Grow by at least a quarter on each side that needs it, so a walking robot reallocates rarely.
    const int gx = std::max(16, box_.width / 4), gy = std::max(16, box_.height / 4);
    const int nx0 = x_min < box_.x0 ? std::min(x_min, box_.x0 - gx) : box_.x0;
    const int ny0 = y_min < box_.y0 ? std::min(y_min, box_.y0 - gy) : box_.y0;
    const int nx1 = x_max >= box_.x0 + box_.width ? std::max(x_max, box_.x0 + box_.width - 1 + gx) : box_.x0 + box_.width - 1;
    const int ny1 = y_max >= box_.y0 + box_.height ? std::max(y_max, box_.y0 + box_.height - 1 + gy) : box_.y0 + box_.height - 1;
    next = {nx0, ny0, nx1 - nx0 + 1, ny1 - ny0 + 1};
  }
  std::vector<float> grown(static_cast<std::size_t>(next.width) * static_cast<std::size_t>(next.height), 0.0f);
  for (int y = box_.y0; !values_.empty() && y < box_.y0 + box_.height; ++y)
    std::copy_n(values_.begin() + static_cast<std::ptrdiff_t>(y - box_.y0) * box_.width, box_.width,
                grown.begin() + static_cast<std::ptrdiff_t>(y - next.y0) * next.width + (box_.x0 - next.x0));
  values_ = std::move(grown);
  box_ = next;
}

void Grid::insert(const std::vector<Vec2>& points_m) {
  if (points_m.empty()) return;
  const double inv = 1.0 / resolution_m_;
  int x_min = 1 << 30, y_min = 1 << 30, x_max = -(1 << 30), y_max = -(1 << 30);
  for (const Vec2& p : points_m) {
    const int cx = static_cast<int>(std::lround(p.x * inv)), cy = static_cast<int>(std::lround(p.y * inv));
    x_min = std::min(x_min, cx - kernel_cells_);
    y_min = std::min(y_min, cy - kernel_cells_);
    x_max = std::max(x_max, cx + kernel_cells_);
    y_max = std::max(y_max, cy + kernel_cells_);
  }
  grow_to(x_min, y_min, x_max, y_max);
  const double k = -0.5 / (hit_sigma_m_ * hit_sigma_m_);
  for (const Vec2& p : points_m) {
    const int cx = static_cast<int>(std::lround(p.x * inv)), cy = static_cast<int>(std::lround(p.y * inv));
    for (int y = cy - kernel_cells_; y <= cy + kernel_cells_; ++y) {
      const double dy = y * resolution_m_ - p.y;
      float* row = values_.data() + static_cast<std::ptrdiff_t>(y - box_.y0) * box_.width - box_.x0;
      for (int x = cx - kernel_cells_; x <= cx + kernel_cells_; ++x) {
        const double dx = x * resolution_m_ - p.x;
        const float v = static_cast<float>(std::exp(k * (dx * dx + dy * dy)));
        row[x] = std::max(row[x], v);
      }
    }
  }
}

}  // namespace teamscan::posegraph
