// `teamscan render DIR|FILE.pcd --out FILE.png`: pictures of a data set or any PCD like the paper's
// figures 3-8 (tools/render). Thin: reads the input, fills RenderOptions, writes the PNG.
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>

#include "common/dataset/dataset.hpp"
#include "common/dataset/pcd.hpp"
#include "tools/render/render.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {

struct RenderArgs {
  std::string input, out, view = "top", color = "class", size = "1200x900", title;
  bool no_tracks = false, no_legend = false;
  int point_size_px = 0;
};

int fail(const std::string& where, const Error& e) {
  std::fprintf(stderr, "teamscan render: %s: %s", where.c_str(), e.what);
  if (e.detail != 0) std::fprintf(stderr, " (line/item %ld)", e.detail);
  if (e.sys_errno != 0) std::fprintf(stderr, " (%s)", std::strerror(e.sys_errno));
  std::fputc('\n', stderr);
  return 1;
}

// A bad option value: a usage error, exit 2.
int usage(const std::string& where, const Error& e) {
  fail(where, e);
  return 2;
}

int run_render(const RenderArgs& a) {
  render::RenderOptions o;
  const auto view = render::view_from_string(a.view);
  if (!view) return usage("--view " + a.view, view.error());
  const auto color = render::color_from_string(a.color);
  if (!color) return usage("--color " + a.color, color.error());
  o.view = *view;
  o.color = *color;
  unsigned w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(a.size.c_str(), "%ux%u%c", &w, &h, &tail) != 2 || w < 32 || h < 32 || w > 16384 || h > 16384)
    return usage("--size " + a.size, Error{"expected WxH, 32..16384 pixels each, e.g. 1200x900"});
  o.width_px = static_cast<int>(w);
  o.height_px = static_cast<int>(h);
  o.draw_tracks = !a.no_tracks;
  o.draw_legend = !a.no_legend;
  o.point_size_px = a.point_size_px;
  const std::filesystem::path in{a.input};
  o.title = a.title.empty() ? in.filename().string() + " - " + render::to_string(o.view) + ", " + render::to_string(o.color)
                            : a.title;
  if (a.title.empty() && in.filename().empty()) o.title = in.parent_path().filename().string() + " - " + render::to_string(o.view);

  std::error_code ec;
  Result<render::Image> image = Error{"nothing rendered"};
  if (std::filesystem::is_directory(in, ec)) {
    const auto dataset = read_dataset(a.input);
    if (!dataset) return fail(a.input, dataset.error());
    image = render::render(render::input_from_dataset(*dataset), o);
  } else if (std::filesystem::exists(in, ec)) {
    const auto cloud = read_pcd(a.input);
    if (!cloud) return fail(a.input, cloud.error());
    const auto scene = render::scene_from_pcd(*cloud);
    render::RenderInput input;
    input.points = scene.points;
    input.keep = scene.keep;
    input.has_labels = scene.has_labels;
    image = render::render(input, o);
  } else {
    return fail(a.input, Error{"no such data set folder or PCD file"});
  }
  if (!image) return fail(a.input, image.error());
  if (const auto s = render::write_png(a.out, *image); !s) return fail(a.out, s.error());
  std::printf("wrote %s (%dx%d, %s view, %s colours)\n", a.out.c_str(), o.width_px, o.height_px, render::to_string(o.view),
              render::to_string(o.color));
  return 0;
}

const SubcommandRegistration kRender{
    {"render", "Draw a data set or a PCD as a PNG like the paper's figures (top/side/perspective)", [](CLI::App& app) {
       auto args = std::make_shared<RenderArgs>();
       app.add_option("input", args->input, "Data set folder (dataset.toml, points.pcd, ...) or any PCD file")->required();
       app.add_option("--out,-o", args->out, "Output PNG file")->required();
       app.add_option("--view", args->view, "top | side | perspective")->capture_default_str();
       app.add_option("--color", args->color,
                      "class (scene grey, ghosts black) | robot (a grey per robot) | filter (filtered points white: "
                      "the PCD's `keep` field, else the flags' direction-filtered bit)")
           ->capture_default_str();
       app.add_option("--size", args->size, "Image size WxH in pixels")->capture_default_str();
       app.add_option("--title", args->title, "Title drawn at the top (default: input name, view, colours)");
       app.add_option("--point-size", args->point_size_px, "Point square side in pixels (0 = automatic)");
       app.add_flag("--no-tracks", args->no_tracks, "Do not draw the robot tracks");
       app.add_flag("--no-legend", args->no_legend, "Do not draw the legend");
       return [args] { return run_render(*args); };
     }}};

}  // namespace
}  // namespace teamscan::tool
