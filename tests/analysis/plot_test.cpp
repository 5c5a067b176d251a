// Plot texts are data: whatever a title, label, legend or bar category holds, gnuplot draws it and
// runs nothing (docs/reliability.md, "No code from data").
#include "demfem/analysis/plot.hpp"
#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <string>

using namespace demfem::analysis;
using demfem::support::readText;
using demfem::support::TempDir;

namespace {

// A text that creates a file in `dir` under each of gnuplot's substitutions if it were script.
std::string hostile(const std::filesystem::path& dir, const std::string& tag) {
  const std::string mark = (dir / ("executed-" + tag)).string();
  return tag + " `touch " + mark + "-bq` \" . system(\"touch " + mark + "-sys\") . \" ' . system('touch " + mark + "-sq') . ' @m \\\\";
}

Figure hostileFigure(const std::filesystem::path& dir) {
  Figure figure;
  figure.title = hostile(dir, "figure");
  XYPanel xy{hostile(dir, "panel"), hostile(dir, "x"), hostile(dir, "y"), false, false, {}};
  xy.series.push_back(Series{hostile(dir, "series"), {0.0, 1.0, 2.0}, {1.0, 3.0, 2.0}, kMeasuredColor, SeriesStyle::Line, 1.0});
  BarPanel bars;
  bars.title = hostile(dir, "bars");
  bars.y_label = hostile(dir, "ylabel");
  bars.categories = {hostile(dir, "category"), "plain"};
  bars.groups.push_back(BarGroup{hostile(dir, "group"), kMeasuredColor, {1.0, 2.0}, {0.1, 0.0}});
  figure.panels = {xy, bars};
  return figure;
}

int traces(const std::filesystem::path& dir) {
  int n = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.path().filename().string().rfind("executed", 0) == 0) ++n;
  return n;
}

}  // namespace

TEST_CASE("texts holding gnuplot command substitutions are drawn as text and run nothing", "[analysis]") {
  TempDir dir("plot-hostile");
  const GnuplotRenderer renderer;
  const Figure figure = hostileFigure(dir.path());
  renderer.render(figure, dir / "f.gp", dir / "f.svg", ImageFormat::Svg);
  renderer.render(figure, dir / "f-png.gp", dir / "f.png", ImageFormat::Png);
  CHECK(traces(dir.path()) == 0);
  const std::string svg = readText(dir / "f.svg");
  // The texts arrive whole (a legend this long does not fit its panel and is left out by gnuplot).
  CHECK(svg.find("panel `touch ") != std::string::npos);
  CHECK(svg.find("category `touch ") != std::string::npos);
  CHECK(svg.find(". system(\"touch ") != std::string::npos);
  // An image path with a quote in it is written where it says.
  renderer.render(figure, dir / "q.gp", dir / "it's.svg", ImageFormat::Svg);
  CHECK(std::filesystem::exists(dir / "it's.svg"));
  CHECK(traces(dir.path()) == 0);
}

TEST_CASE("a plot text with a control character is refused before gnuplot starts", "[analysis]") {
  TempDir dir("plot-control");
  const GnuplotRenderer renderer;
  for (const std::string text : {std::string("title\nsystem('touch x')"), std::string("title\rx"), std::string("a\x7f")}) {
    Figure figure;
    figure.title = text;
    figure.panels = {XYPanel{"p", "x", "y", false, false, {Series{"s", {0.0, 1.0}, {1.0, 2.0}, kMeasuredColor, SeriesStyle::Line, 1.0}}}};
    CHECK_THROWS_WITH(renderer.script(figure), Catch::Contains("control character"));
  }
  Figure bars;
  bars.panels = {BarPanel{"b", "y", {"one\ntwo"}, {BarGroup{"g", kMeasuredColor, {1.0}, {0.0}}}}};
  CHECK_THROWS_AS(renderer.render(bars, dir / "b.gp", dir / "b.svg"), PlotError);
  CHECK_FALSE(std::filesystem::exists(dir / "b.svg"));
}
