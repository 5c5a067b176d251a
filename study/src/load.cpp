// Study file loader: JSON text -> Study (SI units). The keys, their types, ranges, defaults and when
// they apply come from the key table (schema.hpp); this file walks the file's sections in order,
// decides which sections a kind has, and hands the result to the cross-field rules (validation.hpp).
// Every problem is collected with its JSON pointer; nothing is thrown until the whole file has been
// checked. The file format is documented in docs/study-file.md.
#include "demfem/study/study.hpp"

#include "enum_names.hpp"
#include "json_reader.hpp"
#include "schema.hpp"
#include "validation.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <thread>

namespace demfem::study {

namespace {

using detail::IssueList;
using detail::KeyContext;
using detail::Need;
using detail::ObjectReader;
using detail::readKeys;
using nlohmann::json;

namespace fs = std::filesystem;

// Deepest nesting of objects and arrays a study file may have (the format needs 5).
constexpr std::size_t kMaxNestingDepth = 64;

// True if `path` exists and is not a socket (ZeroMQ unlinks an ipc path before binding it).
bool existsAsNonSocket(const std::string& path) {
  std::error_code error;
  const fs::file_status status = fs::symlink_status(path, error);
  return fs::exists(status) && status.type() != fs::file_type::socket;
}

const std::string& kindName(StudyKind kind) { return detail::nameOf(detail::kStudyKinds, kind); }

// The value of an enumeration key, if it is present and spelled right (its reader reports it
// otherwise): the keys that depend on it are judged by it.
template <class E>
std::optional<E> peek(const ObjectReader& o, const char* key, const detail::NameTable<E>& table) {
  if (!o.valid() || !o.value()->contains(key) || !o.value()->at(key).is_string()) return std::nullopt;
  for (const auto& [name, value] : table)
    if (name == o.value()->at(key).get<std::string>()) return value;
  return std::nullopt;
}

class StudyParser {
 public:
  StudyParser(const fs::path& origin, IssueList& issues) : base_dir_(origin.parent_path()), issues_(issues) {
    study_.source = origin;
  }

  Study parse(const json& root) {
    ObjectReader top(&root, "", issues_);
    if (!top.valid()) return study_;
    const std::optional<StudyKind> kind = peek(top, "kind", detail::kStudyKinds);
    if (kind) context_.kind = *kind;
    readKeys(top, detail::topSection(), study_, context_, base_dir_);
    if (!study_.name.empty() && !detail::isPlainName(study_.name)) {
      issues_.add("/name", "must contain only letters, digits, '_', '-' and '.' (it names output files), got \"" +
                               study_.name + "\"");
      study_.name.clear();
    }
    if (!kind) {
      // Without a kind the sections cannot be judged; check only that they are known.
      for (const char* key : {"soil", "tools", "weight_drop", "fem", "dem", "coupling", "output"}) top.known(key);
      top.finish();
      return study_;
    }
    study_.kind = *kind;
    const bool soil = hasSoil(*kind);
    const std::string kind_text = "a " + kindName(*kind) + " study";

    if (soil) {
      ObjectReader section = top.object("soil", Need::Required);
      readSoil(section);
    } else {
      top.forbid("soil", kind_text + " simulates no soil");
    }
    if (const json* tools = top.array("tools", Need::Required, 1)) {
      for (std::size_t i = 0; i < tools->size(); ++i) readTool((*tools)[i], "/tools/" + std::to_string(i));
    }
    if (*kind == StudyKind::WeightDrop) {
      ObjectReader section = top.object("weight_drop", Need::Required);
      study_.weight_drop = WeightDrop{};
      readSection(section, detail::weightDropSection(), *study_.weight_drop);
    } else {
      top.forbid("weight_drop", "only a weight-drop study hangs a calibration weight");
    }
    {
      ObjectReader section = top.object("fem", Need::Required);
      readSection(section, detail::femSection(), study_.fem);
    }
    if (soil) {
      ObjectReader dem = top.object("dem", Need::Required);
      readDem(dem);
      ObjectReader coupling = top.object("coupling", Need::Optional);
      readCoupling(coupling);
    } else {
      top.forbid("dem", kind_text + " runs no DEM");
      top.forbid("coupling", kind_text + " runs no DEM to couple to");
    }
    ObjectReader output = top.object("output", Need::Optional);
    study_.output.directory = fs::path("out") / study_.name;
    readSection(output, detail::outputSection(), study_.output);
    top.finish();

    const std::vector<Issue> reading = issues_.items();
    detail::checkStudy(study_, detail::ReadFacts{reading, center_x_given_}, issues_);
    return study_;
  }

 private:
  template <class T>
  void readSection(ObjectReader& o, const detail::Section<T>& section, T& target) {
    readKeys(o, section, target, context_, base_dir_);
    o.finish();
  }

  // Each element of the array `key` of `o` read as one T by `section`.
  template <class T>
  void readEntries(ObjectReader& o, const char* key, const detail::Section<T>& section, std::vector<T>& target) {
    const json* entries = o.array(key, Need::Required, 1);
    if (!entries) return;
    for (std::size_t i = 0; i < entries->size(); ++i) {
      ObjectReader entry(&(*entries)[i], o.pathOf(key) + "/" + std::to_string(i), issues_);
      readSection(entry, section, target.emplace_back());
    }
  }

  void readSoil(ObjectReader& o) {
    Soil& soil = study_.soil;
    ObjectReader bin = o.object("bin", Need::Required);
    readSection(bin, detail::binSection(), soil);
    readKeys(o, detail::soilSection(), soil, context_, base_dir_);
    ObjectReader particles = o.object("particles", Need::Required);
    readSection(particles, detail::particlesSection(), soil);
    readEntries(o, "materials", detail::materialSection(), soil.materials);
    ObjectReader contact = o.object("contact", Need::Required);
    context_.normal = peek(contact, "normal", detail::kNormalModels);
    context_.cohesion = peek(contact, "cohesion", detail::kCohesionModels);
    context_.rolling = peek(contact, "rolling", detail::kRollingModels);
    readSection(contact, detail::contactSection(), soil.contact);
    readEntries(o, "layers", detail::layerSection(), soil.layers);
    readEntries(o, "interactions", detail::interactionSection(), soil.interactions);
    ObjectReader deposition = o.object("deposition", Need::Optional);
    readSection(deposition, detail::depositionSection(), soil);
    o.finish();
  }

  void readTool(const json& value, const std::string& path) {
    ObjectReader t(&value, path, issues_);
    Tool& tool = study_.tools.emplace_back();
    const StudyKind kind = study_.kind;
    const bool soil = hasSoil(kind);
    readKeys(t, detail::toolSection(), tool, context_, base_dir_);
    if (t.has("name") && !detail::isPlainName(tool.name))
      issues_.add(path + "/name", "must contain only letters, digits, '_', '-' and '.', got \"" + tool.name + "\"");

    ObjectReader g = t.object("geometry", Need::Required);
    const std::optional<GeometryKind> geometry = peek(g, "kind", detail::kGeometryKinds);
    const bool deformable = kind == StudyKind::Coupled || kind == StudyKind::WeightDrop || kind == StudyKind::FemOnly;
    KeyContext context = context_;
    context.geometry = geometry;
    context.deformable = deformable;
    readKeys(g, detail::geometrySection(), tool.geometry, context, base_dir_);
    g.finish();
    const bool cone = geometry == GeometryKind::Cone;
    if (geometry && cone != (kind == StudyKind::ConePenetration))
      issues_.add(g.pathOf("kind"), cone ? "a cone is only used by a cone-penetration study"
                                         : "a cone-penetration study needs geometry kind \"cone\"");

    tool.fem.deformable = deformable;
    if (deformable || kind == StudyKind::DemOnly) {
      // A DEM-only tool is rigid, but its load cell reads the static split of its FEM model.
      ObjectReader f = t.object("fem", Need::Required);
      readKeys(f, detail::toolFemSection(), tool.fem, context, base_dir_);
      f.finish();
    } else {
      t.forbid("fem", "the tool of a " + kindName(kind) + " study is rigid");
    }
    if (!cone) {
      ObjectReader c = t.object("constraints", Need::Required);
      readKeys(c, detail::constraintsSection(), tool.constraints, context, base_dir_);
      c.finish();
    } else {
      t.forbid("constraints", "a penetrometer is rigid and has no clamp or sensors");
    }
    if (deformable) {
      ObjectReader s = t.object("sensors", Need::Optional);
      readKeys(s, detail::sensorsSection(), tool.sensors, context, base_dir_);
      s.finish();
    } else {
      t.forbid("sensors", "sensor gains apply to the FEM tool's load cell and deformation sensor");
    }
    if (soil) {
      ObjectReader m = t.object("motion", Need::Required);
      readKeys(m, detail::motionSection(), tool.motion, context, base_dir_);
      center_x_given_.push_back(m.has("center_x_mm"));
      if (!m.has("center_x_mm")) tool.motion.center_x_m = study_.soil.bin_width_m / 2;
      m.finish();
    } else {
      center_x_given_.push_back(false);
      t.forbid("motion", "a " + kindName(kind) + " study does not move the tool");
    }
    t.finish();
  }

  void readDem(ObjectReader& d) {
    DemSettings& dem = study_.dem;
    context_.explicit_dem_step = d.has("dt_s");
    // Default: every core of this machine (results are reproducible per thread count).
    dem.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    readSection(d, detail::demSection(), dem);
    if (d.has("backend") && !detail::isPlainName(dem.backend)) {
      issues_.add(d.pathOf("backend"), "must be a backend name (letters, digits, '_', '-' and '.'), got \"" +
                                           dem.backend + "\"");
      dem.backend = DemSettings{}.backend;
    }
  }

  void readCoupling(ObjectReader& c) {
    CouplingSettings& coupling = study_.coupling;
    readSection(c, detail::couplingSection(), coupling);
    const std::string v = coupling.endpoint;
    if (v.empty()) return;
    if (v.starts_with("ipc://") && existsAsNonSocket(v.substr(6)))
      issues_.add(c.pathOf("endpoint"), "the ipc path " + v.substr(6) +
                                            " exists and is not a socket: binding would delete it; name a path "
                                            "that does not exist (or leave the endpoint to demfem run)");
    else if (!v.starts_with("inproc://") && !v.starts_with("ipc://") && !v.starts_with("tcp://"))
      issues_.add(c.pathOf("endpoint"), "must start with inproc://, ipc:// or tcp://, got \"" + v + "\"");
    else
      return;
    coupling.endpoint.clear();
  }

  Study study_;
  fs::path base_dir_;
  IssueList& issues_;
  KeyContext context_;
  std::vector<bool> center_x_given_;
};

// Line and column (1-based) of byte offset `byte` (nlohmann counts the offending byte, 1-based).
std::pair<std::size_t, std::size_t> lineColumn(const std::string& text, std::size_t byte) {
  std::size_t line = 1, column = 1;
  const std::size_t end = std::min(byte > 0 ? byte - 1 : 0, text.size());
  for (std::size_t i = 0; i < end; ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return {line, column};
}

// Builds the document from nlohmann's SAX events, so that every problem of the text itself gets a
// line, a column and the JSON path where it happened: duplicate keys (nlohmann would keep the last
// one silently), nesting deeper than kMaxNestingDepth (refused before it costs memory), numbers
// outside the double range (1e400) and syntax or UTF-8 errors.
class DocumentBuilder final : public json::json_sax_t {
 public:
  DocumentBuilder(const std::string& text, IssueList& issues) : text_(text), issues_(issues) {}

  json root;

  bool null() override { return add(nullptr); }
  bool boolean(bool v) override { return add(v); }
  bool number_integer(number_integer_t v) override { return add(v); }
  bool number_unsigned(number_unsigned_t v) override { return add(v); }
  bool number_float(number_float_t v, const string_t&) override { return add(v); }
  bool string(string_t& v) override { return add(std::move(v)); }
  bool binary(binary_t&) override { return false; }  // never produced by text JSON
  bool start_object(std::size_t) override { return open(json::object()); }
  bool start_array(std::size_t) override { return open(json::array()); }
  bool end_object() override { return close(); }
  bool end_array() override { return close(); }
  bool key(string_t& key) override {
    Frame& frame = stack_.back();
    if (frame.value->contains(key))
      issues_.add(frame.path + "/" + detail::pointerToken(key), "duplicate key (JSON keeps only the last value)");
    frame.key = key;
    return true;
  }
  bool parse_error(std::size_t position, const std::string&, const nlohmann::detail::exception& error) override {
    const auto [line, column] = lineColumn(text_, position);
    std::string reason = error.what();
    // "[json.exception.parse_error.101] parse error at line 3, column 11: syntax error ..." -> "syntax error ..."
    if (const std::size_t bracket = reason.find("] "); bracket != std::string::npos) reason = reason.substr(bracket + 2);
    if (const std::size_t column_text = reason.find(", column "); reason.rfind("parse error", 0) == 0 &&
                                                                    column_text != std::string::npos)
      reason = reason.substr(reason.find(": ", column_text) + 2);
    if (error.id == 406) reason += " (outside the range of a double)";
    issues_.add(childPath(), "line " + std::to_string(line) + ", column " + std::to_string(column) + ": " + reason);
    return false;
  }

 private:
  struct Frame {
    json* value;
    std::string path;
    std::string key;
  };

  std::string childPath() const {
    if (stack_.empty()) return "";
    const Frame& parent = stack_.back();
    return parent.path + "/" +
           (parent.value->is_object() ? detail::pointerToken(parent.key) : std::to_string(parent.value->size()));
  }
  // Places `value` where the parser is (root, the current key, or the end of the current array).
  json* place(json value) {
    if (stack_.empty()) {
      root = std::move(value);
      return &root;
    }
    Frame& parent = stack_.back();
    if (parent.value->is_object()) {
      json& slot = (*parent.value)[parent.key];
      slot = std::move(value);
      return &slot;
    }
    parent.value->push_back(std::move(value));
    return &parent.value->back();
  }
  bool add(json value) {
    place(std::move(value));
    return true;
  }
  bool open(json container) {
    std::string path = childPath();
    if (stack_.size() >= kMaxNestingDepth) {
      issues_.add(path, "nested deeper than " + std::to_string(kMaxNestingDepth) + " objects and arrays");
      return false;
    }
    json* value = place(std::move(container));
    stack_.push_back({value, std::move(path), {}});
    return true;
  }
  bool close() {
    stack_.pop_back();
    return true;
  }

  const std::string& text_;
  IssueList& issues_;
  std::vector<Frame> stack_;
};

std::optional<json> parseJson(const std::string& text, IssueList& issues) {
  DocumentBuilder builder(text, issues);
  if (!json::sax_parse(text, &builder)) return std::nullopt;
  return std::move(builder.root);
}

}  // namespace

bool hasSoil(StudyKind kind) {
  return kind == StudyKind::Coupled || kind == StudyKind::DemOnly || kind == StudyKind::ConePenetration;
}

Study parseStudy(const std::string& json_text, const std::string& origin) {
  IssueList issues;
  const std::optional<json> root = parseJson(json_text, issues);
  if (!root) throw StudyError(origin, issues.items());
  StudyParser parser(origin, issues);
  Study study = parser.parse(*root);
  if (!issues.empty()) throw StudyError(origin, issues.items());
  return study;
}

Study loadStudy(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw StudyError(file.string(), {{"", "cannot open the study file"}});
  std::ostringstream text;
  text << in.rdbuf();
  if (!in && !in.eof()) throw StudyError(file.string(), {{"", "cannot read the study file"}});
  return parseStudy(text.str(), file.string());
}

}  // namespace demfem::study

namespace demfem::study {

void validate(const Study& study) {
  const std::string origin = study.source.empty() ? "study \"" + study.name + "\"" : study.source.string();
  IssueList issues;
  StudyParser parser(study.source, issues);
  parser.parse(json::parse(toJson(study).dump()));
  if (!issues.empty()) throw StudyError(origin, issues.items());
}

std::string keyReference() { return detail::keyReferenceTable(); }

}  // namespace demfem::study
