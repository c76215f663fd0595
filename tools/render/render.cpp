// Renders labelled point clouds in the style of the paper's figures 3-8 (Lyons et al. 2013, section 4):
// up-laser light grey, down-laser dark grey, ghost points black, filtered points white, robot tracks.
#include "tools/render/render.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

namespace teamscan::render {

Result<View> view_from_string(std::string_view s) {
  if (s == "top") return View::top;
  if (s == "side") return View::side;
  if (s == "perspective") return View::perspective;
  return Error{"unknown view (top, side, perspective)"};
}
Result<ColorMode> color_from_string(std::string_view s) {
  if (s == "class") return ColorMode::class_label;
  if (s == "robot") return ColorMode::robot;
  if (s == "filter") return ColorMode::filter;
  return Error{"unknown colour mode (class, robot, filter)"};
}
const char* to_string(View v) {
  switch (v) {
    case View::top: return "top";
    case View::side: return "side";
    case View::perspective: return "perspective";
  }
  return "?";
}
const char* to_string(ColorMode c) {
  switch (c) {
    case ColorMode::class_label: return "class";
    case ColorMode::robot: return "robot";
    case ColorMode::filter: return "filter";
  }
  return "?";
}

namespace {

// The paper's shading (figure 3): scene light grey, down-laser darker grey, ghosts black. Filter mode
// (figures 4-8: filtered points white) uses a slate background so that white points stand out; its
// greys are a little darker than the plain ones for the same reason.
constexpr Rgb kWhite{255, 255, 255};
constexpr Rgb kBlack{0, 0, 0};
constexpr Rgb kSceneGrey{185, 185, 185};
constexpr Rgb kLightGrey{190, 190, 190};
constexpr Rgb kDarkGrey{110, 110, 110};
constexpr Rgb kFilterBackground{64, 84, 112};
constexpr Rgb kFilterLightGrey{172, 176, 182};
constexpr Rgb kFilterDarkGrey{118, 122, 128};
constexpr Rgb kTextDark{25, 25, 25};
constexpr Rgb kTextLight{240, 240, 240};
// Third and later robots, and the tracks: distinct, muted colours.
constexpr Rgb kPalette[] = {{31, 119, 180}, {255, 127, 14}, {44, 160, 44}, {148, 103, 189}, {140, 86, 75},
                            {227, 119, 194}, {188, 189, 34}, {23, 190, 207}};
constexpr Rgb kTrackColours[] = {{31, 119, 180}, {230, 85, 13}, {44, 160, 44}, {148, 103, 189}, {140, 86, 75},
                                 {227, 119, 194}, {188, 189, 34}, {23, 190, 207}};

int text_scale(const RenderOptions& o) { return o.width_px >= 600 && o.height_px >= 400 ? 2 : 1; }
int margin(const RenderOptions& o) { return 4 * text_scale(o); }
int legend_row_px(const RenderOptions& o) { return 7 * text_scale(o) + 6; }

Vec3 normalized(Vec3 v) {
  const double n = v.norm();
  return n > 0 ? (1.0 / n) * v : v;
}

// Robot id -> style index: by role where the data set gives one (down-laser dark, up-laser light),
// else by order of id (first dark, second light, then palette colours).
struct RobotStyles {
  std::map<std::uint8_t, int> index;  // 0 = dark grey, 1 = light grey, 2.. = palette[i - 2]
  std::map<std::uint8_t, std::string> label;
};

RobotStyles robot_styles(const RenderInput& in) {
  RobotStyles s;
  std::vector<std::uint8_t> ids;
  for (const auto& r : in.robots) ids.push_back(r.id);
  {
    bool seen[256] = {};
    for (const auto& p : in.points) seen[p.robot] = true;
    for (int id = 0; id < 256; ++id)
      if (seen[id] && std::find(ids.begin(), ids.end(), static_cast<std::uint8_t>(id)) == ids.end())
        ids.push_back(static_cast<std::uint8_t>(id));
  }
  bool used_dark = false, used_light = false;
  for (const auto& r : in.robots) {
    if (r.role == "down-laser" && !used_dark) { s.index[r.id] = 0; used_dark = true; }
    else if (r.role == "up-laser" && !used_light) { s.index[r.id] = 1; used_light = true; }
  }
  int next_colour = 2;
  for (const auto id : ids) {
    if (s.index.count(id) != 0) continue;
    if (!used_dark) { s.index[id] = 0; used_dark = true; }
    else if (!used_light) { s.index[id] = 1; used_light = true; }
    else s.index[id] = next_colour++;
  }
  for (const auto id : ids) {
    std::string name = "robot" + std::to_string(id);
    for (const auto& r : in.robots)
      if (r.id == id) {
        if (!r.name.empty()) name = r.name;
        if (!r.role.empty()) name += " " + r.role;
      }
    s.label[id] = name;
  }
  return s;
}

Rgb robot_colour(const RobotStyles& s, std::uint8_t robot, bool filter_mode) {
  const auto it = s.index.find(robot);
  const int i = it == s.index.end() ? 0 : it->second;
  if (i == 0) return filter_mode ? kFilterDarkGrey : kDarkGrey;
  if (i == 1) return filter_mode ? kFilterLightGrey : kLightGrey;
  return kPalette[static_cast<std::size_t>(i - 2) % std::size(kPalette)];
}

Rgb track_colour(std::size_t i) { return kTrackColours[i % std::size(kTrackColours)]; }

class Canvas {
 public:
  Canvas(Image& image, PlotRect rect) : image_(image), rect_(rect) {}
  void set(int x, int y, Rgb c) {
    const auto i = 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(image_.width_px) + static_cast<std::size_t>(x));
    image_.rgb[i] = c.r;
    image_.rgb[i + 1] = c.g;
    image_.rgb[i + 2] = c.b;
  }
  // A square of side `size` centred on (u, v), depth-tested against `zbuf` (nearer wins, ties keep the first).
  void splat(double u, double v, double depth, int size, Rgb c, std::vector<float>& zbuf) {
    const int x0 = static_cast<int>(std::floor(u)) - (size - 1) / 2;
    const int y0 = static_cast<int>(std::floor(v)) - (size - 1) / 2;
    const auto d = static_cast<float>(depth);
    for (int y = std::max(y0, rect_.y0); y < std::min(y0 + size, rect_.y1); ++y)
      for (int x = std::max(x0, rect_.x0); x < std::min(x0 + size, rect_.x1); ++x) {
        float& z = zbuf[static_cast<std::size_t>(y) * static_cast<std::size_t>(image_.width_px) + static_cast<std::size_t>(x)];
        if (d < z) {
          z = d;
          set(x, y, c);
        }
      }
  }
  void fill(int x0, int y0, int x1, int y1, Rgb c) {
    for (int y = std::max(0, y0); y < std::min(y1, image_.height_px); ++y)
      for (int x = std::max(0, x0); x < std::min(x1, image_.width_px); ++x) set(x, y, c);
  }

 private:
  Image& image_;
  PlotRect rect_;
};

struct LegendEntry {
  Rgb colour;
  std::string text;
  bool line = false;  // a track: drawn as a short line instead of a square
};

// The "nice" length (1, 2 or 5 x 10^k metres) not longer than `max_m`.
double nice_length_m(double max_m) {
  if (!(max_m > 0)) return 1;
  const double p = std::pow(10.0, std::floor(std::log10(max_m)));
  for (const double m : {5.0, 2.0, 1.0})
    if (m * p <= max_m) return m * p;
  return p;
}

std::string metres_text(double m) {
  char buf[32];
  if (m >= 1) std::snprintf(buf, sizeof buf, "%.0f m", m);
  else if (m >= 0.01) std::snprintf(buf, sizeof buf, "%.0f cm", m * 100);
  else std::snprintf(buf, sizeof buf, "%.0f mm", m * 1000);
  return buf;
}

}  // namespace

PlotRect plot_rect(const RenderOptions& o) {
  const int m = margin(o);
  PlotRect r;
  r.x0 = m;
  r.x1 = o.width_px - m;
  r.y0 = o.title.empty() ? m : 7 * text_scale(o) + 2 * m;
  r.y1 = o.height_px - ((o.draw_legend || o.draw_scale_bar) ? 2 * legend_row_px(o) + m : m);
  return r;
}

Camera Camera::fit(View view, Vec3 lo, Vec3 hi, PlotRect rect, std::span<const Vec3> samples) {
  Camera c;
  c.view_ = view;
  constexpr double kMinExtentM = 0.1;  // a single point or a flat cloud still gets a sensible scale
  const Vec3 centre = 0.5 * (lo + hi);
  const Vec3 ext{std::max(hi.x - lo.x, kMinExtentM), std::max(hi.y - lo.y, kMinExtentM), std::max(hi.z - lo.z, kMinExtentM)};
  const double w = rect.x1 - rect.x0, h = rect.y1 - rect.y0;
  c.offset_u_ = rect.x0 + 0.5 * w;
  c.offset_v_ = rect.y0 + 0.5 * h;
  constexpr double kFill = 0.96;  // leave a thin border inside the plot
  if (view == View::top) {
    c.scale_ = kFill * std::min(w / ext.x, h / ext.y);
    c.eye_ = centre;
    c.pixels_per_metre_ = c.scale_;
    return c;
  }
  if (view == View::side) {
    c.scale_ = kFill * std::min(w / ext.x, h / ext.z);
    c.eye_ = centre;
    c.pixels_per_metre_ = c.scale_;
    return c;
  }
  // Perspective: a fixed oblique camera, 35 deg above the horizon, looking from the -x/-y quadrant
  // (azimuth -120 deg) at the box centre, 2.5 box radii away so the whole box is in front of it.
  const double radius = 0.5 * ext.norm();
  const double distance = 2.5 * radius;
  const double az = -120.0 * M_PI / 180.0, el = 35.0 * M_PI / 180.0;
  const Vec3 dir{std::cos(az) * std::cos(el), std::sin(az) * std::cos(el), std::sin(el)};
  c.eye_ = centre + distance * dir;
  c.forward_ = normalized(centre - c.eye_);
  c.right_ = normalized(c.forward_.cross({0, 0, 1}));
  c.up_ = c.right_.cross(c.forward_);
  double amin = 1e300, amax = -1e300, bmin = 1e300, bmax = -1e300;
  for (int k = 0; k < 8; ++k) {
    const Vec3 corner{(k & 1) ? centre.x + 0.5 * ext.x : centre.x - 0.5 * ext.x,
                      (k & 2) ? centre.y + 0.5 * ext.y : centre.y - 0.5 * ext.y,
                      (k & 4) ? centre.z + 0.5 * ext.z : centre.z - 0.5 * ext.z};
    const Vec3 q = c.camera_coords(corner);
    amin = std::min(amin, q.x / q.z); amax = std::max(amax, q.x / q.z);
    bmin = std::min(bmin, q.y / q.z); bmax = std::max(bmax, q.y / q.z);
  }
  if (!samples.empty()) {
    std::vector<double> as, bs;
    as.reserve(samples.size());
    bs.reserve(samples.size());
    for (const auto& p : samples) {
      const Vec3 q = c.camera_coords(p);
      if (q.z <= 1e-6) continue;
      as.push_back(q.x / q.z);
      bs.push_back(q.y / q.z);
    }
    if (as.size() >= 2) {
      const std::size_t n = as.size(), lo_i = n * 2 / 1000, hi_i = n - 1 - n * 2 / 1000;
      std::nth_element(as.begin(), as.begin() + static_cast<long>(lo_i), as.end());
      amin = as[lo_i];
      std::nth_element(as.begin(), as.begin() + static_cast<long>(hi_i), as.end());
      amax = as[hi_i];
      std::nth_element(bs.begin(), bs.begin() + static_cast<long>(lo_i), bs.end());
      bmin = bs[lo_i];
      std::nth_element(bs.begin(), bs.begin() + static_cast<long>(hi_i), bs.end());
      bmax = bs[hi_i];
      // A degenerate spread (all samples on one ray) keeps the box fit's size.
      if (!(amax - amin > 1e-9) || !(bmax - bmin > 1e-9)) amin = amax = bmin = bmax = 0;
    }
    if (amin == amax) {  // fall back to the box
      amin = 1e300; amax = -1e300; bmin = 1e300; bmax = -1e300;
      for (int k = 0; k < 8; ++k) {
        const Vec3 corner{(k & 1) ? centre.x + 0.5 * ext.x : centre.x - 0.5 * ext.x,
                          (k & 2) ? centre.y + 0.5 * ext.y : centre.y - 0.5 * ext.y,
                          (k & 4) ? centre.z + 0.5 * ext.z : centre.z - 0.5 * ext.z};
        const Vec3 q = c.camera_coords(corner);
        amin = std::min(amin, q.x / q.z); amax = std::max(amax, q.x / q.z);
        bmin = std::min(bmin, q.y / q.z); bmax = std::max(bmax, q.y / q.z);
      }
    }
  }
  c.scale_ = kFill * std::min(w / (amax - amin), h / (bmax - bmin));
  // Centre the projected box in the plot.
  c.offset_u_ -= 0.5 * (amin + amax) * c.scale_;
  c.offset_v_ += 0.5 * (bmin + bmax) * c.scale_;
  c.pixels_per_metre_ = c.scale_ / distance;
  return c;
}

Vec3 Camera::camera_coords(Vec3 p) const {
  const Vec3 d = p - eye_;
  return {d.dot(right_), d.dot(up_), d.dot(forward_)};
}

Camera::Pixel Camera::project(Vec3 p) const {
  Pixel px;
  switch (view_) {
    case View::top:
      px.u = offset_u_ + (p.x - eye_.x) * scale_;
      px.v = offset_v_ - (p.y - eye_.y) * scale_;
      px.depth = -p.z;  // seen from above: the highest point is the nearest
      px.visible = true;
      return px;
    case View::side:
      px.u = offset_u_ + (p.x - eye_.x) * scale_;
      px.v = offset_v_ - (p.z - eye_.z) * scale_;
      px.depth = p.y;  // seen from -y looking towards +y
      px.visible = true;
      return px;
    case View::perspective: {
      const Vec3 q = camera_coords(p);
      if (q.z <= 1e-6) return px;
      px.u = offset_u_ + q.x / q.z * scale_;
      px.v = offset_v_ - q.y / q.z * scale_;
      px.depth = q.z;
      px.visible = true;
      return px;
    }
  }
  return px;
}

Camera camera_for(const RenderInput& input, const RenderOptions& options) {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  const auto grow = [&](double x, double y, double z) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return;
    lo = {std::min(lo.x, x), std::min(lo.y, y), std::min(lo.z, z)};
    hi = {std::max(hi.x, x), std::max(hi.y, y), std::max(hi.z, z)};
  };
  // Robust bounds: the 0.2 % and 99.8 % quantiles per axis, so a few stray long-range returns do not
  // shrink the room to a corner of the picture (they are still drawn if they fall inside the plot).
  std::vector<float> axis[3];
  for (auto& a : axis) a.reserve(input.points.size());
  for (const auto& p : input.points)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) {
      axis[0].push_back(p.x);
      axis[1].push_back(p.y);
      axis[2].push_back(p.z);
    }
  if (!axis[0].empty()) {
    const std::size_t n = axis[0].size();
    const std::size_t lo_i = n * 2 / 1000, hi_i = n - 1 - n * 2 / 1000;
    double q[3][2];
    for (int k = 0; k < 3; ++k) {
      auto& a = axis[k];
      std::nth_element(a.begin(), a.begin() + static_cast<long>(lo_i), a.end());
      q[k][0] = a[lo_i];
      std::nth_element(a.begin(), a.begin() + static_cast<long>(hi_i), a.end());
      q[k][1] = a[hi_i];
    }
    grow(q[0][0], q[1][0], q[2][0]);
    grow(q[0][1], q[1][1], q[2][1]);
  }
  if (options.draw_tracks)
    for (const auto& t : input.tracks)
      for (const auto& q : t.points_m) grow(q.x, q.y, q.z);
  if (lo.x > hi.x) lo = hi = Vec3{0, 0, 0};  // nothing to draw: any box
  std::vector<Vec3> samples;
  if (options.view == View::perspective) {
    // Fit the picture to the points as seen (at most ~200 000 of them, evenly spaced), not to the box.
    const std::size_t stride = std::max<std::size_t>(1, input.points.size() / 200000);
    for (std::size_t i = 0; i < input.points.size(); i += stride) {
      const auto& p = input.points[i];
      if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) samples.push_back({p.x, p.y, p.z});
    }
    if (options.draw_tracks)
      for (const auto& t : input.tracks)
        for (const auto& q : t.points_m) samples.push_back(q);
  }
  return Camera::fit(options.view, lo, hi, plot_rect(options), samples);
}

// The robots' tracks on the floor (DESIGN: "each robot path is shown"), a line two pixels wide.
static void draw_tracks(Canvas& canvas, const Camera& camera, const RenderInput& in, const RenderOptions& o, std::vector<float>& zbuf) {
  if (!o.draw_tracks || o.view == View::side) return;
  for (std::size_t t = 0; t < in.tracks.size(); ++t) {
    const auto& pts = in.tracks[t].points_m;
    for (std::size_t k = 1; k < pts.size(); ++k) {
      const auto a = camera.project(pts[k - 1]), b = camera.project(pts[k]);
      if (!a.visible || !b.visible) continue;
      const int steps = std::max(1, static_cast<int>(std::ceil(std::max(std::fabs(b.u - a.u), std::fabs(b.v - a.v)))));
      if (steps > 100000) continue;  // a jump across the picture: data error, skip the segment
      for (int s = 0; s <= steps; ++s) {
        const double f = static_cast<double>(s) / steps;
        // In perspective the track is hidden behind walls but drawn over the floor: 0.1 m depth bias.
        const double depth = o.view == View::perspective ? a.depth + f * (b.depth - a.depth) - 0.1 : -1e30;
        canvas.splat(a.u + f * (b.u - a.u), a.v + f * (b.v - a.v), depth, 2, track_colour(t), zbuf);
      }
    }
  }
}

Result<Image> render(const RenderInput& in, const RenderOptions& o) {
  if (o.width_px < 32 || o.height_px < 32 || o.width_px > 16384 || o.height_px > 16384)
    return Error{"image size must be 32..16384 pixels each way"};
  const PlotRect rect = plot_rect(o);
  if (rect.x1 - rect.x0 < 8 || rect.y1 - rect.y0 < 8) return Error{"image too small for the title, legend and plot"};
  if (!in.keep.empty() && in.keep.size() != in.points.size()) return Error{"keep mask and points differ in length"};

  const bool filter_mode = o.color == ColorMode::filter;
  const Rgb background = filter_mode ? kFilterBackground : kWhite;
  const Rgb text_colour = filter_mode ? kTextLight : kTextDark;
  Image img;
  img.width_px = o.width_px;
  img.height_px = o.height_px;
  img.rgb.resize(3 * static_cast<std::size_t>(o.width_px) * static_cast<std::size_t>(o.height_px));
  for (std::size_t i = 0; i < img.rgb.size(); i += 3) {
    img.rgb[i] = background.r;
    img.rgb[i + 1] = background.g;
    img.rgb[i + 2] = background.b;
  }
  Canvas canvas(img, rect);
  const Camera camera = camera_for(in, o);
  const RobotStyles styles = robot_styles(in);
  const std::size_t n = in.points.size();
  const int size = o.point_size_px > 0 ? o.point_size_px : n <= 2000 ? 3 : n <= 400000 ? 2 : 1;
  const int overlay_size = std::max(size, 2);

  const auto filtered = [&](std::size_t i) {
    if (!in.keep.empty()) return in.keep[i] == 0;
    return (in.points[i].flags & point_flags::kDirectionFiltered) != 0;
  };
  std::size_t ghosts = 0, ghosts_kept = 0, filtered_count = 0;
  // Base layer: every ordinary point, depth-tested. Overlay: ghosts (and, in filter mode, ghosts the
  // method kept) drawn above the base layer as the paper's figures show them, depth-tested among themselves.
  std::vector<float> zbuf(static_cast<std::size_t>(o.width_px) * static_cast<std::size_t>(o.height_px),
                          std::numeric_limits<float>::infinity());
  std::vector<std::size_t> overlay;
  // Perspective: depth cueing, near points up to 15 % darker and far ones up to 15 % lighter, so that
  // shapes read in 3-D; orthographic views keep the paper's flat shades. White (filtered) stays white.
  double depth_lo = 0, depth_hi = 0;
  if (o.view == View::perspective && n > 0) {
    std::vector<float> depths;
    const std::size_t stride = std::max<std::size_t>(1, n / 100000);
    for (std::size_t i = 0; i < n; i += stride) {
      const auto px = camera.project({in.points[i].x, in.points[i].y, in.points[i].z});
      if (px.visible) depths.push_back(static_cast<float>(px.depth));
    }
    if (!depths.empty()) {
      const std::size_t lo_i = depths.size() * 2 / 100, hi_i = depths.size() - 1 - depths.size() * 2 / 100;
      std::nth_element(depths.begin(), depths.begin() + static_cast<long>(lo_i), depths.end());
      depth_lo = depths[lo_i];
      std::nth_element(depths.begin(), depths.begin() + static_cast<long>(hi_i), depths.end());
      depth_hi = depths[hi_i];
    }
  }
  const auto shade = [&](Rgb c, double depth) {
    if (depth_hi <= depth_lo || c == kWhite) return c;
    const double t = std::clamp((depth - depth_lo) / (depth_hi - depth_lo), 0.0, 1.0);
    const double f = 0.85 + 0.3 * t;
    const auto ch = [f](std::uint8_t v) { return static_cast<std::uint8_t>(std::clamp(std::lround(v * f), 0L, 255L)); };
    return Rgb{ch(c.r), ch(c.g), ch(c.b)};
  };
  for (std::size_t i = 0; i < n; ++i) {
    const auto& p = in.points[i];
    const bool ghost = in.has_labels && p.is_ghost();
    ghosts += ghost ? 1 : 0;
    Rgb c = o.color == ColorMode::class_label ? kSceneGrey : robot_colour(styles, p.robot, filter_mode);
    if (filter_mode && filtered(i)) {
      ++filtered_count;
      c = kWhite;
    } else if (ghost) {
      ++ghosts_kept;
      overlay.push_back(i);
      continue;
    }
    const auto px = camera.project({p.x, p.y, p.z});
    if (px.visible) canvas.splat(px.u, px.v, px.depth, size, shade(c, px.depth), zbuf);
  }
  draw_tracks(canvas, camera, in, o, zbuf);
  std::fill(zbuf.begin(), zbuf.end(), std::numeric_limits<float>::infinity());
  for (const std::size_t i : overlay) {
    const auto& p = in.points[i];
    const auto px = camera.project({p.x, p.y, p.z});
    if (px.visible) canvas.splat(px.u, px.v, px.depth, overlay_size, kBlack, zbuf);
  }

  // Title.
  const int ts = text_scale(o), m = margin(o);
  if (!o.title.empty()) draw_text(img, m, m, o.title, text_colour, ts);

  // Legend (up to two rows) and scale bar in the band below the plot.
  const int band_y = rect.y1 + m / 2;
  const int row_h = legend_row_px(o);
  int scale_bar_w = 0;
  if (o.draw_scale_bar) {
    const double ppm = camera.pixels_per_metre();
    const double len_m = nice_length_m(0.2 * (rect.x1 - rect.x0) / ppm);
    const int len_px = static_cast<int>(std::lround(len_m * ppm));
    std::string label = metres_text(len_m);
    if (o.view == View::perspective) label += " at centre";
    const int label_w = text_width_px(label, ts);
    scale_bar_w = len_px + label_w + 8 * ts;
    const int x1 = o.width_px - m, x0 = x1 - len_px;
    const int y = band_y + row_h / 2;
    canvas.fill(x0, y - ts, x1, y + ts, text_colour);            // the bar
    canvas.fill(x0, y - 3 * ts, x0 + ts, y + 3 * ts, text_colour);  // end ticks
    canvas.fill(x1 - ts, y - 3 * ts, x1, y + 3 * ts, text_colour);
    draw_text(img, x0 - label_w - 4 * ts, y - 7 * ts / 2, label, text_colour, ts);
  }
  if (o.draw_legend) {
    std::vector<LegendEntry> entries;
    const auto count = [](std::size_t k) { return " (" + std::to_string(k) + ")"; };
    if (o.color == ColorMode::class_label) {
      entries.push_back({kSceneGrey, "scene" + count(n - ghosts)});
    } else {
      for (const auto& [id, label] : styles.label) entries.push_back({robot_colour(styles, id, filter_mode), label});
    }
    if (in.has_labels) entries.push_back({kBlack, (filter_mode ? "ghost kept" : "ghost") + count(filter_mode ? ghosts_kept : ghosts)});
    if (filter_mode) entries.push_back({kWhite, "filtered" + count(filtered_count)});
    if (o.draw_tracks && o.view != View::side)
      for (std::size_t t = 0; t < in.tracks.size(); ++t)
        entries.push_back({track_colour(t), "track " + std::to_string(in.tracks[t].robot), true});
    int x = m, row = 0;
    const int sw = 7 * ts;  // swatch side
    for (const auto& e : entries) {
      const int w = sw + 2 * ts + text_width_px(e.text, ts) + 6 * ts;
      if (x + w > o.width_px - m - scale_bar_w && x > m) {
        if (++row >= 2) break;  // no room: the band holds two rows
        x = m;
      }
      const int y = band_y + row * row_h + (row_h - sw) / 2;
      if (e.line) {
        canvas.fill(x, y + sw / 2 - 1, x + sw, y + sw / 2 + 1, e.colour);
      } else {
        canvas.fill(x, y, x + sw, y + sw, text_colour);  // a border, so white and background-like swatches show
        canvas.fill(x + 1, y + 1, x + sw - 1, y + sw - 1, e.colour);
      }
      draw_text(img, x + sw + 2 * ts, y, e.text, text_colour, ts);
      x += w;
    }
  }
  return img;
}

RenderInput input_from_dataset(const Dataset& dataset, std::span<const std::uint8_t> keep) {
  RenderInput in;
  in.points = dataset.points;
  in.keep = keep;
  in.robots = dataset.robots;
  in.has_labels = true;
  const auto& samples = dataset.truth.empty() ? dataset.odom : dataset.truth;
  std::map<std::uint8_t, std::size_t> index;
  for (const auto& s : samples) {
    auto it = index.find(s.robot);
    if (it == index.end()) {
      it = index.emplace(s.robot, in.tracks.size()).first;
      in.tracks.push_back(Track{s.robot, {}});
    }
    in.tracks[it->second].points_m.push_back({s.pose.x_m, s.pose.y_m, 0.0});
  }
  return in;
}

PcdScene scene_from_pcd(const PcdCloud& cloud) {
  PcdScene s;
  const int robot = cloud.field("robot"), label = cloud.field("label"), flags = cloud.field("flags"), keep = cloud.field("keep");
  s.has_labels = label >= 0;
  s.points.resize(cloud.size());
  if (keep >= 0) s.keep.resize(cloud.size());
  const auto col = [&](int f, std::size_t i) { return cloud.columns[static_cast<std::size_t>(f)][i]; };
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    auto& p = s.points[i];
    p.x = cloud.xyz[3 * i];
    p.y = cloud.xyz[3 * i + 1];
    p.z = cloud.xyz[3 * i + 2];
    if (robot >= 0 && col(robot, i) >= 0 && col(robot, i) <= 255) p.robot = static_cast<std::uint8_t>(col(robot, i));
    if (label >= 0 && col(label, i) >= 0 && col(label, i) <= 5) p.label = static_cast<PointClass>(static_cast<int>(col(label, i)));
    if (flags >= 0 && col(flags, i) >= 0 && col(flags, i) <= 65535) p.flags = static_cast<std::uint16_t>(col(flags, i));
    if (keep >= 0) s.keep[i] = col(keep, i) != 0 ? 1 : 0;
  }
  return s;
}

Status render_dataset_png(const std::string& path, const Dataset& dataset, std::span<const std::uint8_t> keep,
                          const RenderOptions& options) {
  const auto image = render(input_from_dataset(dataset, keep), options);
  if (!image) return image.error();
  return write_png(path, *image);
}

}  // namespace teamscan::render
