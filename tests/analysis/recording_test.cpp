// Reading recordings: formats, sidecars, and the messages for bad input (file, line, column).
#include "demfem/analysis/recording.hpp"
#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

#include <fstream>

using namespace demfem::analysis;
using demfem::support::TempDir;

namespace {

const char* kRawSoilBinSidecar =
    R"({"tool":"PMMA","depth_mm":18,"stroke_mm":600,"sample_rate_hz":50,"force_factor":0.5,"deformation_factor":0.01,"repeat":2})";

void writeFile(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

// Five rows at 50 Hz.
std::string rawCsv(const std::string& header = "t,force,deformation") {
  return header + "\n0.00,1,10\n0.02,2,11\n0.04,3,12\n0.06,4,13\n0.08,5,14\n";
}

std::string errorOf(const std::filesystem::path& csv) {
  try {
    readRecording(csv);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST_CASE("a raw soil-bin recording is read with its sidecar, columns found by name", "[analysis]") {
  TempDir dir("read-raw");
  writeFile(dir / "run.csv", "# soil bin, PMMA\ndeformation,t,force\n10,0.00,1\n11,0.02,2\n12,0.04,3\n");
  writeFile(dir / "run.json", kRawSoilBinSidecar);
  const Recording rec = readRecording(dir / "run.csv");
  CHECK(rec.format == RecordingFormat::Raw);
  CHECK(rec.key.kind == CaseKind::SoilBin);
  CHECK(rec.key.tool == "PMMA");
  CHECK(rec.key.depth_mm == 18.0);
  CHECK(rec.repeat == 2);
  CHECK(rec.stroke_mm == 600.0);
  CHECK(rec.force_factor_N_per_unit == 0.5);
  REQUIRE(rec.size() == 3);
  CHECK(rec.time_s[2] == 0.04);
  CHECK(rec.force[1] == 2.0);
  CHECK(rec.deformation[0] == 10.0);
  CHECK(rec.line == std::vector<std::size_t>{3, 4, 5});
  CHECK(rec.key.label() == "PMMA_18mm");
}

TEST_CASE("a simulated recording in the FEM client's columns is read as calibrated", "[analysis]") {
  TempDir dir("read-sim");
  writeFile(dir / "sim.csv", "t_s,displacement_mm,force_N,deformation_mm,tilt_deg\n0,0,0,0,0\n0.01,0.3,1.5,0.2,0.1\n");
  writeFile(dir / "sim.json", R"({"tool":"S235","depth_mm":42})");
  const Recording rec = readRecording(dir / "sim.csv");
  CHECK(rec.format == RecordingFormat::Calibrated);
  CHECK(rec.repeat == 1);
  CHECK(rec.displacement_mm == std::vector<double>{0.0, 0.3});
  CHECK(rec.tilt_deg == std::vector<double>{0.0, 0.1});
}

TEST_CASE("a truncated column is reported with file, line and the missing column", "[analysis]") {
  TempDir dir("truncated");
  writeFile(dir / "run.csv", "t,force,deformation\n0.00,1,10\n0.02,2,11\n0.04,3\n");
  writeFile(dir / "run.json", kRawSoilBinSidecar);
  const std::string message = errorOf(dir / "run.csv");
  CHECK_THAT(message, Catch::Contains((dir / "run.csv").string() + ":4:3:"));
  CHECK_THAT(message, Catch::Contains("column 'deformation' (3) is missing"));
}

TEST_CASE("a shuffled time column is reported as non-monotonic time at its line", "[analysis]") {
  TempDir dir("shuffled");
  writeFile(dir / "run.csv", "t,force,deformation\n0.00,1,10\n0.04,2,11\n0.02,3,12\n0.06,4,13\n");
  writeFile(dir / "run.json", kRawSoilBinSidecar);
  const std::string message = errorOf(dir / "run.csv");
  CHECK_THAT(message, Catch::Contains((dir / "run.csv").string() + ":4:1: column 't'"));
  CHECK_THAT(message, Catch::Contains("does not increase"));
}

TEST_CASE("a missing column, a non-numeric cell and an empty cell are reported where they are", "[analysis]") {
  TempDir dir("cells");
  writeFile(dir / "run.json", kRawSoilBinSidecar);
  writeFile(dir / "run.csv", rawCsv("t,force,deflection"));
  CHECK_THAT(errorOf(dir / "run.csv"), Catch::Contains(":1: missing column 'deformation'"));

  writeFile(dir / "run.csv", "t,force,deformation\n0.00,1,10\n0.02,2x,11\n");
  CHECK_THAT(errorOf(dir / "run.csv"), Catch::Contains(":3:2: column 'force': cannot read '2x' as a number"));

  writeFile(dir / "run.csv", "t,force,deformation\n0.00,1,10\n0.02,,11\n");
  CHECK_THAT(errorOf(dir / "run.csv"), Catch::Contains(":3:2: column 'force': empty cell"));

  writeFile(dir / "run.csv", "t,force,deformation\n0.00,1,10\n0.02,nan,11\n");
  CHECK_THAT(errorOf(dir / "run.csv"), Catch::Contains("not a finite number"));
}

TEST_CASE("a sidecar that does not match its recording is rejected naming the key", "[analysis]") {
  TempDir dir("sidecar");
  writeFile(dir / "run.csv", rawCsv());
  SECTION("sample rate disagrees with the time column") {
    writeFile(dir / "run.json",
              R"({"tool":"PMMA","depth_mm":18,"stroke_mm":600,"sample_rate_hz":100,"force_factor":0.5,"deformation_factor":0.01,"repeat":1})");
    const std::string message = errorOf(dir / "run.csv");
    CHECK_THAT(message, Catch::Contains((dir / "run.json").string() + ": /sample_rate_hz: does not match the recording"));
    CHECK_THAT(message, Catch::Contains("(50 Hz)"));
  }
  SECTION("required calibration factor missing") {
    writeFile(dir / "run.json", R"({"tool":"PMMA","depth_mm":18,"stroke_mm":600,"sample_rate_hz":50,"deformation_factor":0.01,"repeat":1})");
    CHECK_THAT(errorOf(dir / "run.csv"), Catch::Contains("/force_factor: missing"));
  }
  SECTION("wrong type") {
    writeFile(dir / "run.json",
              R"({"tool":"PMMA","depth_mm":"18","stroke_mm":600,"sample_rate_hz":50,"force_factor":0.5,"deformation_factor":0.01,"repeat":1})");
    CHECK_THAT(errorOf(dir / "run.csv"), Catch::Contains("/depth_mm: expected a number, found string"));
  }
  SECTION("both depth and mass") {
    writeFile(dir / "run.json",
              R"({"tool":"PMMA","depth_mm":18,"mass_kg":1,"stroke_mm":600,"sample_rate_hz":50,"force_factor":0.5,"deformation_factor":0.01,"repeat":1})");
    CHECK_THAT(errorOf(dir / "run.csv"), Catch::Contains("exactly one of depth_mm"));
  }
  SECTION("no sidecar at all") {
    CHECK_THAT(errorOf(dir / "run.csv"), Catch::Contains((dir / "run.json").string() + ": cannot open the sidecar"));
  }
  SECTION("not JSON") {
    writeFile(dir / "run.json", "{\"tool\": ");
    CHECK_THAT(errorOf(dir / "run.csv"), Catch::Contains("not valid JSON"));
  }
}

TEST_CASE("calibration factors beside an already calibrated recording are rejected, not ignored", "[analysis]") {
  TempDir dir("calibrated-factors");
  writeFile(dir / "sim.csv", "t_s,displacement_mm,force_N,deformation_mm\n0,0,0,0\n0.1,3,1,0.1\n");
  writeFile(dir / "sim.json", R"({"tool":"PMMA","depth_mm":18,"force_factor":0.5})");
  CHECK_THAT(errorOf(dir / "sim.csv"), Catch::Contains("/force_factor: given, but") && Catch::Contains("already calibrated"));
  writeFile(dir / "sim.json", R"({"tool":"PMMA","depth_mm":18,"sample_rate_hz":100})");
  CHECK_THAT(errorOf(dir / "sim.csv"), Catch::Contains("/sample_rate_hz: does not match the recording"));
  writeFile(dir / "sim.json", R"({"tool":"PMMA","depth_mm":18,"sample_rate_hz":10})");
  CHECK(readRecording(dir / "sim.csv").sample_rate_hz == 10.0);
}

TEST_CASE("a run marked incomplete is rejected", "[analysis]") {
  TempDir dir("incomplete");
  writeFile(dir / "sim.csv", "t_s,displacement_mm,force_N,deformation_mm\n0,0,0,0\n0.1,3,1,0.1\n# incomplete: DEM server gone\n");
  writeFile(dir / "sim.json", R"({"tool":"PMMA","depth_mm":18})");
  CHECK_THAT(errorOf(dir / "sim.csv"), Catch::Contains(":4:1: the recording is marked incomplete"));
  writeFile(dir / "sim.csv", "t_s,displacement_mm,force_N,deformation_mm\n0,0,0,0\n0.1,3,1,0.1\n");
  writeFile(dir / "sim.json", R"({"tool":"PMMA","depth_mm":18,"complete":false})");
  CHECK_THAT(errorOf(dir / "sim.csv"), Catch::Contains("/complete: the run is marked incomplete"));
}

TEST_CASE("directories expand to their recordings and a repeat claimed twice is rejected", "[analysis]") {
  TempDir dir("directory");
  writeFile(dir / "a.csv", rawCsv());
  writeFile(dir / "a.json", kRawSoilBinSidecar);
  writeFile(dir / "b.csv", rawCsv());
  writeFile(dir / "b.json",
            R"({"tool":"PMMA","depth_mm":18,"stroke_mm":600,"sample_rate_hz":50,"force_factor":0.5,"deformation_factor":0.01,"repeat":3})");
  const auto recordings = readRecordings({dir.path()});
  REQUIRE(recordings.size() == 2);
  CHECK(recordings[0].repeat == 2);
  CHECK(recordings[1].repeat == 3);

  writeFile(dir / "b.json", kRawSoilBinSidecar);  // repeat 2 again
  try {
    readRecordings({dir.path()});
    FAIL("expected an error");
  } catch (const InputError& e) {
    CHECK_THAT(std::string(e.what()), Catch::Contains("/repeat: repeat 2 of case PMMA, 18 mm depth is also claimed by"));
  }
  CHECK_THROWS_WITH(readRecordings({dir / "missing.csv"}), Catch::Contains("no such file or directory"));
}

TEST_CASE("spreadsheet exports with a byte order mark and CRLF line ends are read", "[analysis]") {
  TempDir dir("bom");
  writeFile(dir / "run.csv", "\xEF\xBB\xBFt,force,deformation\r\n0.00,1,10\r\n0.02,2,11\r\n");
  writeFile(dir / "run.json", kRawSoilBinSidecar);
  const Recording rec = readRecording(dir / "run.csv");
  CHECK(rec.deformation == std::vector<double>{10.0, 11.0});
  CHECK_THROWS_WITH(readRecordings({dir / "run.json"}), Catch::Contains("run.json: not a recording (expected a .csv file"));
}

TEST_CASE("a FEM client output directory reads as one recording: sidecar-less CSVs are skipped, depth round-off ignored", "[analysis]") {
  TempDir dir("fem-output");
  writeFile(dir / "sensors.csv", "t_s,displacement_mm,force_N,deformation_mm,tilt_deg\n0,0,0,0,0\n0.001,0.036,0.1,0.01,0.005\n");
  writeFile(dir / "sensors.json", R"({"tool":"tool","depth_mm":18.000000000000004,"study":"pmma_coupled_18","complete":true})");
  writeFile(dir / "keypoints.csv", "id,x_m,y_m,z_m\n0,0,0,0\n");
  const auto recordings = readRecordings({dir.path()}, std::string("PMMA"));
  REQUIRE(recordings.size() == 1);
  CHECK(recordings[0].key.tool == "PMMA");
  CHECK(recordings[0].key.depth_mm == 18.0);
  CHECK_THROWS_WITH(readRecordings({dir / "keypoints.csv"}), Catch::Contains("keypoints.json: cannot open the sidecar"));
}
