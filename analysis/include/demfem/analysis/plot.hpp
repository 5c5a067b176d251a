// demfem analysis: charts rendered to SVG by gnuplot (Debian gnuplot-nox) run as a child process.
//
// Contract
// - A Figure is a grid of panels: XY panels (lines, points or filled bands, optional log axes), bar
//   panels (grouped bars with error segments, as Figs. 8 and 15) and map panels (a grid of cell values
//   as a colour map with line overlays, as the velocity sections of Fig. 16).
// - GnuplotRenderer::render(figure, script, image, format) writes a self-contained gnuplot script
//   (data inline as datablocks) to `script` and runs `gnuplot -e "set output '<image>'" <script>`,
//   drawing SVG (the default) or PNG (gnuplot's cairo terminal). The script has
//   no output line so it can be rerun by hand to another file. Series longer than
//   `max_points_per_series` are thinned by keeping the minimum and maximum of each bucket, so peaks
//   survive.
// - A plot is never silently missing: a gnuplot that cannot be started, exits non-zero, prints an
//   error, or leaves no complete image (an SVG ending in </svg>, a PNG with its IEND chunk) throws
//   PlotError with gnuplot's message.
// - Deterministic: the same figure gives the same script and the same SVG.
#pragma once

#include "demfem/analysis/staged_output.hpp"

#include <filesystem>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

namespace demfem::analysis {

class PlotError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The paper's colours (Figs. 9, 17): measurement RGB 91,155,213; simulation RGB 237,125,49.
inline constexpr const char* kMeasuredColor = "#5b9bd5";
inline constexpr const char* kSimulatedColor = "#ed7d31";
inline constexpr const char* kRepeatColor = "#a9c9e8";

enum class SeriesStyle { Line, DashedLine, Points, Band };

struct Series {
  std::string title;  // empty: no key entry
  std::vector<double> x;
  std::vector<double> y;       // Band: the lower edge
  std::string color = kMeasuredColor;
  SeriesStyle style = SeriesStyle::Line;
  double line_width = 1.5;
  std::vector<double> y_high{};  // Band only: the upper edge, one per x
};

struct XYPanel {
  std::string title;
  std::string x_label;
  std::string y_label;
  bool log_x = false;
  bool log_y = false;
  std::vector<Series> series;
  std::string key_position = "top left";  // gnuplot `set key` position, e.g. "bottom right"
};

struct BarGroup {
  std::string title;
  std::string color;
  std::vector<double> values;  // one per category
  std::vector<double> errors;  // one per category (0: no segment)
};

struct BarPanel {
  std::string title;
  std::string y_label;
  std::vector<std::string> categories;
  std::vector<BarGroup> groups;
};

// A colour map of nx x ny cells (x fastest) from (x0, y0) in steps dx, dy; NaN cells stay blank.
struct MapPanel {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::string value_label;
  double x0 = 0, dx = 1, y0 = 0, dy = 1;
  int nx = 0, ny = 0;
  std::vector<double> values;
  std::vector<Series> overlays;  // lines drawn over the map (outlines)
};

using Panel = std::variant<XYPanel, BarPanel, MapPanel>;

enum class ImageFormat { Svg, Png };

struct Figure {
  std::string title;
  std::vector<Panel> panels;
  int columns = 1;
  int width_px = 960;
  int row_height_px = 360;
};

class GnuplotRenderer {
 public:
  explicit GnuplotRenderer(std::string executable = "gnuplot", std::size_t max_points_per_series = 4000);

  // The gnuplot script of `figure` (no output line).
  std::string script(const Figure& figure, ImageFormat format = ImageFormat::Svg) const;

  // Writes the script to `script_path`, runs gnuplot and checks `image_path` is a complete image.
  void render(const Figure& figure, const std::filesystem::path& script_path, const std::filesystem::path& image_path,
              ImageFormat format = ImageFormat::Svg) const;

 private:
  std::string executable_;
  std::size_t max_points_;
};

// Stages and renders `figure` as STEM.gp + STEM.svg and STEM-png.gp + STEM.png (paths relative to `out`).
void renderSvgAndPng(const GnuplotRenderer& renderer, StagedOutput& out, const Figure& figure, const std::string& stem);

}  // namespace demfem::analysis
