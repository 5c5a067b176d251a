// demfem-example-recordings OUTDIR: writes the synthetic example recordings of examples/data
// (docs/analysis.md): OUTDIR/measured (raw DAQ format, three repeats per soil-bin case, two
// calibration-weight repeats) and OUTDIR/simulated (the FEM client's format). The numbers are
// made up, shaped like the paper's PMMA tool; the truth behind them is in the code below.
#include "demfem/analysis/synthetic.hpp"

#include <filesystem>
#include <iostream>
#include <string>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: demfem-example-recordings OUTDIR\n";
    return 2;
  }
  namespace fs = std::filesystem;
  using namespace demfem::analysis;
  try {
    const fs::path out(argv[1]);
    fs::create_directories(out / "measured");
    fs::create_directories(out / "simulated");
    struct Case {
      double depth_mm, force_N, deformation_mm, simulated_scale, velocity_mm_s;
    };
    // Steady values loosely after Fig. 14 / Fig. 15 (PMMA tool); simulated 8 % and 15 % off.
    for (const Case c : {Case{18.0, 12.0, 1.4, 1.08, 36.1}, Case{30.0, 24.0, 3.1, 0.85, 28.8}}) {
      const std::string depth = std::to_string(static_cast<int>(c.depth_mm));
      for (int r = 1; r <= 3; ++r) {
        SoilBinTruth t;
        t.depth_mm = c.depth_mm;
        t.repeat = r;
        t.seed = static_cast<std::uint64_t>(100 * c.depth_mm) + static_cast<std::uint64_t>(r);
        t.force_N = c.force_N * (1.0 + 0.03 * (r - 2));
        t.deformation_mm = c.deformation_mm * (1.0 + 0.03 * (r - 2));
        t.velocity_mm_s = c.velocity_mm_s;
        t.noise_fraction = 0.01;
        writeSyntheticRecording(makeSoilBinRecording(t, RecordingFormat::Raw),
                                out / "measured" / ("pmma_" + depth + "mm_r" + std::to_string(r) + ".csv"));
      }
      SoilBinTruth s;
      s.depth_mm = c.depth_mm;
      s.seed = static_cast<std::uint64_t>(c.depth_mm);
      s.sample_rate_Hz = 100.0;
      s.velocity_mm_s = c.velocity_mm_s;
      s.force_N = c.force_N * c.simulated_scale;
      s.deformation_mm = c.deformation_mm * c.simulated_scale;
      s.fluctuation_a = 0.008;
      s.fluctuation_b = -0.6;
      s.noise_fraction = 0.0;
      s.start_time_s = 0.0;
      s.rest_after_s = 0.0;
      writeSyntheticRecording(makeSoilBinRecording(s, RecordingFormat::Calibrated), out / "simulated" / ("pmma_" + depth + "mm.csv"));
    }
    for (int r = 1; r <= 2; ++r) {
      WeightDropTruth w;
      w.repeat = r;
      w.seed = 900 + static_cast<std::uint64_t>(r);
      w.drop_time_s = 0.8 + 0.3 * r;
      writeSyntheticRecording(makeWeightDropRecording(w, RecordingFormat::Raw), out / "measured" / ("pmma_1kg_r" + std::to_string(r) + ".csv"));
    }
    WeightDropTruth ws;
    ws.sample_rate_Hz = 200.0;
    ws.drop_time_s = 0.0;
    ws.duration_s = 6.0;
    ws.frequency_Hz = 3.2;
    ws.damping_ratio = 0.065;
    ws.noise_fraction = 0.0;
    writeSyntheticRecording(makeWeightDropRecording(ws, RecordingFormat::Calibrated), out / "simulated" / "pmma_1kg.csv");
  } catch (const std::exception& e) {
    std::cerr << "demfem-example-recordings: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
