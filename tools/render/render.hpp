// Point-cloud pictures like the paper's figures 3-8 (Lyons et al. 2013): top, side and perspective
// views; colour by class (ghosts black), by robot (light/dark grey per laser) or by filter result
// (filtered points white); robot tracks, a legend and a scale bar; written as PNG (libpng).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/dataset/pcd.hpp"
#include "common/pose.hpp"
#include "common/result.hpp"

namespace teamscan::render {

enum class View : std::uint8_t { top, side, perspective };
// class_label: scene light grey, ghosts black. robot: a grey (or colour) per robot, ghosts black.
// filter: kept points as `robot`, filtered points white, on a slate background so white shows.
enum class ColorMode : std::uint8_t { class_label, robot, filter };

[[nodiscard]] Result<View> view_from_string(std::string_view s);          // "top" | "side" | "perspective"
[[nodiscard]] Result<ColorMode> color_from_string(std::string_view s);    // "class" | "robot" | "filter"
[[nodiscard]] const char* to_string(View v);
[[nodiscard]] const char* to_string(ColorMode c);

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
  friend bool operator==(Rgb, Rgb) = default;
};

struct Image {
  int width_px = 0, height_px = 0;
  std::vector<std::uint8_t> rgb;  // row-major, 3 bytes per pixel, top row first
  [[nodiscard]] Rgb at(int x, int y) const {
    const auto i = 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width_px) + static_cast<std::size_t>(x));
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

struct RenderOptions {
  View view = View::top;
  ColorMode color = ColorMode::class_label;
  int width_px = 1200, height_px = 900;
  std::string title;                 // drawn at the top; empty = none
  bool draw_tracks = true;           // top and perspective views (a track on the floor adds nothing seen from the side)
  bool draw_legend = true;
  bool draw_scale_bar = true;
  int point_size_px = 0;             // square side; 0 = automatic from the point count
};

// A robot's path, map frame (z = 0 on the floor).
struct Track {
  std::uint8_t robot = 0;
  std::vector<Vec3> points_m;
};

// What to draw. Spans point into the caller's data (a Dataset or a cloud read from a PCD).
struct RenderInput {
  std::span<const LabelledPoint> points;
  // One entry per point, 0 = filtered by the method being shown. Empty: in filter mode, a point is
  // filtered if its flags carry point_flags::kDirectionFiltered (the onboard filter's decision).
  std::span<const std::uint8_t> keep;
  std::vector<Track> tracks;
  std::vector<DatasetRobot> robots;  // roles pick the greys (down-laser dark, up-laser light); may be empty
  bool has_labels = true;            // false: a plain PCD without `label` (no ghosts known)
};

// Where the plot sits in the image (title above, legend and scale bar below).
struct PlotRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // inclusive-exclusive pixel bounds
};
[[nodiscard]] PlotRect plot_rect(const RenderOptions& options);

// The projection of a view fitted to a bounding box: map-frame metres to pixels.
class Camera {
 public:
  struct Pixel {
    double u = 0, v = 0;   // pixel coordinates (u right, v down)
    double depth = 0;      // smaller is nearer the viewer
    bool visible = false;  // false if behind the perspective camera
  };
  // Fits `view` to the box [lo, hi] inside `rect`, keeping the aspect ratio (1 m is as long across as up).
  // Perspective: the camera looks at the box; with `samples` the picture is fitted to where the samples
  // project (their 0.2 %..99.8 % quantiles), else to the box's corners.
  static Camera fit(View view, Vec3 lo, Vec3 hi, PlotRect rect, std::span<const Vec3> samples = {});
  [[nodiscard]] Pixel project(Vec3 p_map) const;
  // Pixels per metre at the box centre (exact for the orthographic views).
  [[nodiscard]] double pixels_per_metre() const { return pixels_per_metre_; }

 private:
  View view_ = View::top;
  Vec3 eye_, right_, up_, forward_;
  double scale_ = 1, offset_u_ = 0, offset_v_ = 0, pixels_per_metre_ = 1;
  [[nodiscard]] Vec3 camera_coords(Vec3 p) const;
};

// The camera `render` uses for this input (bounding box of the points and tracks).
[[nodiscard]] Camera camera_for(const RenderInput& input, const RenderOptions& options);

[[nodiscard]] Result<Image> render(const RenderInput& input, const RenderOptions& options);

// PNG (8-bit RGB, no time chunk: identical images give identical bytes).
[[nodiscard]] Result<std::vector<std::uint8_t>> encode_png(const Image& image);
[[nodiscard]] Status write_png(const std::string& path, const Image& image);

// Input for a data set: its points, its robots and the tracks from truth.csv (odom.csv if truth is empty).
[[nodiscard]] RenderInput input_from_dataset(const Dataset& dataset, std::span<const std::uint8_t> keep = {});

// Points and keep mask built from a generic PCD: x y z always; `robot`, `label`, `flags` and `keep`
// fields when present (a `keep` field of 0 marks a filtered point).
struct PcdScene {
  std::vector<LabelledPoint> points;
  std::vector<std::uint8_t> keep;  // empty unless the PCD has a `keep` field
  bool has_labels = false;
};
[[nodiscard]] PcdScene scene_from_pcd(const PcdCloud& cloud);

// Convenience for the evaluation: render a data set (with an optional keep mask) to a PNG file.
[[nodiscard]] Status render_dataset_png(const std::string& path, const Dataset& dataset, std::span<const std::uint8_t> keep,
                                        const RenderOptions& options);

// A tiny built-in 5x7 bitmap font (letters, digits, common punctuation; others drawn as '?'). Draws `text` with its top-left corner at (x, y), each font pixel `scale` pixels wide.
void draw_text(Image& image, int x, int y, std::string_view text, Rgb colour, int scale);
[[nodiscard]] int text_width_px(std::string_view text, int scale);

}  // namespace teamscan::render
