#include "demfem/analysis/plot.hpp"

#include <spawn.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>

extern char** environ;

namespace demfem::analysis {
namespace {

namespace fs = std::filesystem;

// A gnuplot single-quoted string: the only string gnuplot never interprets (no backslash escapes,
// no backquote command substitution, no macros); a quote inside is doubled. A control character
// would end the command and start another, so it is refused: text from a recording or a peer is
// data, never script (docs/reliability.md, "No code from data").
std::string quoted(const std::string& text) {
  std::string out = "'";
  for (const char c : text) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      throw PlotError("a plot text contains a control character, refused: '" + text + "'");
    if (c == '\'') out += '\'';
    out += c;
  }
  return out + "'";
}

// A text field of an inline data block: double-quoted, the only quoting gnuplot's data reader knows,
// with no escape inside, so a double quote in the text is written as a single one. Data lines are
// never substituted or executed, but a control character could end the block: refused as above.
std::string dataField(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      throw PlotError("a plot text contains a control character, refused: '" + text + "'");
    out += c == '"' ? '\'' : c;
  }
  return out + "\"";
}

void writeNumber(std::ostream& out, double value) {
  if (std::isfinite(value)) out << value;
  else out << "NaN";
}

// Keeps the minimum and maximum of each of max_points/2 buckets (in their original order). Buckets
// are equal ranges of the sample index, or of log10 x on a logarithmic x axis (x ascending), so a
// log-log spectrum keeps its sparse low-frequency points.
std::vector<std::size_t> thinnedIndices(const Series& series, std::size_t max_points, bool log_x) {
  const std::size_t n = series.x.size();
  std::vector<std::size_t> keep;
  if (n <= max_points) {
    for (std::size_t i = 0; i < n; ++i) keep.push_back(i);
    return keep;
  }
  const std::size_t buckets = std::max<std::size_t>(1, max_points / 2);
  const auto position = [&](std::size_t i) {
    if (!log_x) return static_cast<double>(i) / static_cast<double>(n);
    const double lo = std::log10(series.x.front()), hi = std::log10(series.x.back());
    return hi > lo && series.x[i] > 0.0 ? (std::log10(series.x[i]) - lo) / (hi - lo) : 0.0;
  };
  std::size_t begin = 0;
  for (std::size_t b = 0; b < buckets && begin < n; ++b) {
    const double upper = static_cast<double>(b + 1) / static_cast<double>(buckets);
    std::size_t end = begin;
    while (end < n && (position(end) < upper || b + 1 == buckets)) ++end;
    if (end == begin) continue;
    std::size_t lo = begin, hi = begin;
    for (std::size_t i = begin; i < end; ++i) {
      if (series.y[i] < series.y[lo]) lo = i;
      if (series.y[i] > series.y[hi]) hi = i;
    }
    keep.push_back(std::min(lo, hi));
    if (lo != hi) keep.push_back(std::max(lo, hi));
    begin = end;
  }
  return keep;
}

void writeSeriesBlock(std::ostream& out, const std::string& name, const Series& series, std::size_t max_points, bool log_x) {
  const bool band = series.style == SeriesStyle::Band;
  out << name << " << EOD\n";
  for (std::size_t i : thinnedIndices(series, max_points, log_x)) {
    writeNumber(out, series.x[i]);
    out << ' ';
    writeNumber(out, series.y[i]);
    if (band) {
      out << ' ';
      writeNumber(out, series.y_high[i]);
    }
    out << '\n';
  }
  out << "EOD\n";
}

// The plot item of a series stored in datablock `block`.
std::string seriesItem(const std::string& block, const Series& series) {
  std::ostringstream item;
  item << block << " using 1:2" << (series.style == SeriesStyle::Band ? ":3" : "") << " with ";
  switch (series.style) {
    case SeriesStyle::Line: item << "lines dt 1"; break;
    case SeriesStyle::DashedLine: item << "lines dt 2"; break;
    case SeriesStyle::Points: item << "points pt 7 ps 0.3"; break;
    case SeriesStyle::Band: item << "filledcurves fs transparent solid 0.25 noborder"; break;
  }
  if (series.style != SeriesStyle::Band) item << " lw " << series.line_width;
  item << " lc rgb " << quoted(series.color) << " ";
  item << (series.title.empty() ? std::string("notitle") : "title " + quoted(series.title));
  return item.str();
}

// Whether `image` is a complete file of `format`.
bool completeImage(const std::string& image, ImageFormat format) {
  switch (format) {
    case ImageFormat::Svg: return image.find("</svg>") != std::string::npos;
    case ImageFormat::Png: return image.rfind("\x89PNG", 0) == 0 && image.find("IEND") != std::string::npos;
  }
  return false;
}

std::string readFile(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

GnuplotRenderer::GnuplotRenderer(std::string executable, std::size_t max_points_per_series)
    : executable_(std::move(executable)), max_points_(max_points_per_series) {}

std::string GnuplotRenderer::script(const Figure& figure, ImageFormat format) const {
  std::ostringstream out;
  out << std::setprecision(9);
  const int columns = std::max(1, figure.columns);
  const int rows = static_cast<int>((figure.panels.size() + static_cast<std::size_t>(columns) - 1) / static_cast<std::size_t>(columns));
  const int height = figure.row_height_px * std::max(1, rows) + 40;
  switch (format) {
    case ImageFormat::Svg:
      out << "# Generated by demfem analysis. Render with: gnuplot -e \"set output 'FILE.svg'\" THIS_SCRIPT\n";
      out << "set terminal svg size " << figure.width_px << "," << height << " noenhanced font 'Helvetica,12' background rgb 'white'\n";
      break;
    case ImageFormat::Png:
      out << "# Generated by demfem analysis. Render with: gnuplot -e \"set output 'FILE.png'\" THIS_SCRIPT\n";
      out << "set terminal pngcairo size " << figure.width_px << "," << height << " noenhanced font 'Helvetica,10' background rgb 'white'\n";
      break;
  }
  out << "set encoding utf8\n";

  // Data blocks first.
  for (std::size_t p = 0; p < figure.panels.size(); ++p) {
    if (const auto* xy = std::get_if<XYPanel>(&figure.panels[p])) {
      for (std::size_t s = 0; s < xy->series.size(); ++s) writeSeriesBlock(out, "$p" + std::to_string(p) + "s" + std::to_string(s), xy->series[s], max_points_, xy->log_x);
    } else if (const auto* map = std::get_if<MapPanel>(&figure.panels[p])) {
      out << "$p" << p << "map << EOD\n";
      for (int j = 0; j < map->ny; ++j) {
        for (int i = 0; i < map->nx; ++i) {
          writeNumber(out, map->x0 + (i + 0.5) * map->dx);
          out << ' ';
          writeNumber(out, map->y0 + (j + 0.5) * map->dy);
          out << ' ';
          writeNumber(out, map->values[static_cast<std::size_t>(j) * static_cast<std::size_t>(map->nx) + static_cast<std::size_t>(i)]);
          out << '\n';
        }
        out << '\n';
      }
      out << "EOD\n";
      for (std::size_t s = 0; s < map->overlays.size(); ++s) writeSeriesBlock(out, "$p" + std::to_string(p) + "o" + std::to_string(s), map->overlays[s], max_points_, false);
    } else {
      const auto& bars = std::get<BarPanel>(figure.panels[p]);
      out << "$p" << p << "bars << EOD\n";
      for (std::size_t c = 0; c < bars.categories.size(); ++c) {
        out << dataField(bars.categories[c]);
        for (const auto& group : bars.groups) {
          out << ' ';
          writeNumber(out, group.values[c]);
          out << ' ';
          writeNumber(out, group.errors[c]);
        }
        out << '\n';
      }
      out << "EOD\n";
    }
  }

  out << "set multiplot layout " << rows << "," << columns << " title " << quoted(figure.title) << "\n";
  for (std::size_t p = 0; p < figure.panels.size(); ++p) {
    out << "reset\nset grid\n";
    if (const auto* xy = std::get_if<XYPanel>(&figure.panels[p])) {
      out << "set key " << xy->key_position << " opaque\n";
      out << "set title " << quoted(xy->title) << "\nset xlabel " << quoted(xy->x_label) << "\nset ylabel " << quoted(xy->y_label) << "\n";
      if (xy->log_x) out << "set logscale x\nset format x '%g'\n";
      if (xy->log_y) out << "set logscale y\nset format y '%g'\n";
      std::vector<std::string> items;
      for (std::size_t s = 0; s < xy->series.size(); ++s)
        if (!xy->series[s].x.empty()) items.push_back(seriesItem("$p" + std::to_string(p) + "s" + std::to_string(s), xy->series[s]));
      if (items.empty()) {
        out << "set xrange [0:1]\nset yrange [0:1]\nset label 1 'no data' at 0.5,0.5 center\nplot NaN notitle\n";
      } else {
        out << "plot ";
        for (std::size_t i = 0; i < items.size(); ++i) out << (i ? ", \\\n     " : "") << items[i];
        out << "\n";
      }
    } else if (const auto* map = std::get_if<MapPanel>(&figure.panels[p])) {
      out << "set key below\nset title " << quoted(map->title) << "\nset xlabel " << quoted(map->x_label) << "\nset ylabel "
          << quoted(map->y_label) << "\nset cblabel " << quoted(map->value_label) << "\n";
      out << "set size ratio -1\nset palette rgbformulae 33,13,10\nset xrange [" << map->x0 << ":" << map->x0 + map->nx * map->dx
          << "]\nset yrange [" << map->y0 << ":" << map->y0 + map->ny * map->dy << "]\n";
      out << "plot $p" << p << "map using 1:2:3 with image notitle";
      for (std::size_t s = 0; s < map->overlays.size(); ++s)
        if (!map->overlays[s].x.empty()) out << ", \\\n     " << seriesItem("$p" + std::to_string(p) + "o" + std::to_string(s), map->overlays[s]);
      out << "\n";
    } else {
      const auto& bars = std::get<BarPanel>(figure.panels[p]);
      out << "set key below\nset title " << quoted(bars.title) << "\nset ylabel " << quoted(bars.y_label) << "\n";
      out << "set style data histogram\nset style histogram errorbars gap 1 lw 1.5\n"
             "set style fill solid 0.85 border rgb 'black'\nset boxwidth 0.9\nset yrange [0:*]\nset xtics nomirror\n";
      if (bars.groups.empty() || bars.categories.empty()) {
        out << "set xrange [0:1]\nset yrange [0:1]\nset label 1 'no data' at 0.5,0.5 center\nplot NaN notitle\n";
      } else {
        out << "plot ";
        for (std::size_t g = 0; g < bars.groups.size(); ++g) {
          out << (g ? ", \\\n     " : "") << "$p" << p << "bars using " << 2 + 2 * g << ":" << 3 + 2 * g;
          if (g == 0) out << ":xtic(1)";
          out << " title " << quoted(bars.groups[g].title) << " lc rgb " << quoted(bars.groups[g].color);
        }
        out << "\n";
      }
    }
  }
  out << "unset multiplot\n";
  return out.str();
}

void GnuplotRenderer::render(const Figure& figure, const fs::path& script_path, const fs::path& svg_path, ImageFormat format) const {
  {
    std::ofstream out(script_path);
    out << script(figure, format);
    if (!out) throw PlotError("cannot write the gnuplot script " + script_path.string());
  }
  fs::remove(svg_path);
  const fs::path log_path = fs::path(svg_path).concat(".gnuplot-log");
  const std::string set_output = "set output " + quoted(svg_path.string());
  const std::string script_arg = script_path.string();
  std::vector<char*> argv = {const_cast<char*>(executable_.c_str()), const_cast<char*>("-e"), const_cast<char*>(set_output.c_str()),
                             const_cast<char*>(script_arg.c_str()), nullptr};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int spawn_error = posix_spawnp(&pid, executable_.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawn_error != 0) {
    fs::remove(log_path);
    throw PlotError("cannot start '" + executable_ + "' to draw " + svg_path.string() + ": " + std::strerror(spawn_error) +
                    " (install Debian's gnuplot-nox, or skip plots explicitly with --no-plots)");
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw PlotError("waiting for gnuplot failed: " + std::string(std::strerror(errno)));
  }
  const std::string log = readFile(log_path);
  fs::remove(log_path);
  const bool exited_ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  const std::string svg = fs::exists(svg_path) ? readFile(svg_path) : std::string();
  const bool complete = completeImage(svg, format);
  if (!exited_ok || !complete || log.find("error") != std::string::npos) {
    fs::remove(svg_path);
    throw PlotError("gnuplot failed to draw " + svg_path.string() + " from " + script_path.string() +
                    (exited_ok ? "" : " (exit status " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")") +
                    (complete ? "" : " (no complete image written)") + (log.empty() ? std::string() : ":\n" + log));
  }
}

void renderSvgAndPng(const GnuplotRenderer& renderer, StagedOutput& out, const Figure& figure, const std::string& stem) {
  renderer.render(figure, out.stage(stem + ".gp"), out.stage(stem + ".svg"), ImageFormat::Svg);
  renderer.render(figure, out.stage(stem + "-png.gp"), out.stage(stem + ".png"), ImageFormat::Png);
}

}  // namespace demfem::analysis
