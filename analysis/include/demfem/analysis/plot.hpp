// demfem analysis: charts rendered to SVG by gnuplot (Debian gnuplot-nox) run as a child process.
//
// Contract
// - A Figure is a grid of panels: XY panels (lines or points, optional log axes) and bar panels
//   (grouped bars with error segments, as Figs. 8 and 15).
// - GnuplotRenderer::render(figure, svg) writes a self-contained gnuplot script (data inline as
//   datablocks) to `script` and runs `gnuplot -e "set output '<svg>'" <script>`. The script has
//   no output line so it can be rerun by hand to another file. Series longer than
//   `max_points_per_series` are thinned by keeping the minimum and maximum of each bucket, so peaks
//   survive.
// - A plot is never silently missing: a gnuplot that cannot be started, exits non-zero, prints an
//   error, or leaves no complete SVG (ending in </svg>) throws PlotError with gnuplot's message.
// - Deterministic: the same figure gives the same script and the same SVG.
#pragma once

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

enum class SeriesStyle { Line, DashedLine, Points };

struct Series {
  std::string title;  // empty: no key entry
  std::vector<double> x;
  std::vector<double> y;
  std::string color = kMeasuredColor;
  SeriesStyle style = SeriesStyle::Line;
  double line_width = 1.5;
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

using Panel = std::variant<XYPanel, BarPanel>;

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
  std::string script(const Figure& figure) const;

  // Writes the script to `script_path`, runs gnuplot and checks `svg_path` is a complete SVG.
  void render(const Figure& figure, const std::filesystem::path& script_path, const std::filesystem::path& svg_path) const;

 private:
  std::string executable_;
  std::size_t max_points_;
};

}  // namespace demfem::analysis
