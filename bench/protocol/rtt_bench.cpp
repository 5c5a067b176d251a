// Round-trip time of one coupling exchange — get_node_forces, set_node_positions, simulate(0) — for
// the PMMA tool's 738 keypoints (200 x 40 x 4 mm plate, 5 mm grid), over ipc:// and tcp://127.0.0.1
// (and inproc:// for reference), side by side. The server (constant test backend) runs on a thread
// of this process; the messages still cross the kernel for ipc and tcp.
#include "demfem/adapter/remote_proxy.hpp"
#include "demfem/adapter/server.hpp"
#include "demfem/adapter/test_backends.hpp"
#include "demfem/cli/cli_support.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <thread>
#include <unistd.h>

namespace {

using namespace demfem;
using namespace std::chrono_literals;

struct Result {
  std::string transport;
  double median_us = 0, p90_us = 0, mean_us = 0, min_us = 0;
};

Result measure(const std::string& transport, const std::string& endpoint, int repetitions) {
  study::Tool pmma;
  pmma.geometry.thickness_m = 0.004;
  auto backend = adapter::makeTestBackend("constant", {pmma}, adapter::TestLoad{});
  protocol::Context context;
  protocol::ServerSocket socket(context, endpoint, {.insecure_tcp = true});  // loopback, as the transports compare
  adapter::ServerOptions options;
  options.idle_timeout = 10s;
  adapter::Server server(*backend, options);
  std::thread thread([&] { server.serve(socket, 10s); });
  adapter::RemoteProxy dem({socket.endpoint(), 10s, std::nullopt, "bench"}, &context);
  adapter::NodeArray x = dem.nodePositions("tool");
  if (x.size() != 738 * 3) throw std::runtime_error("expected the PMMA tool's 738 keypoints");
  std::vector<double> us;
  for (int i = -repetitions / 10; i < repetitions; ++i) {  // first 10 % warm up
    const auto t0 = std::chrono::steady_clock::now();
    const adapter::NodeArray f = dem.nodeForces("tool");
    dem.setNodePositions("tool", x);
    dem.simulate(0.0);
    const auto t1 = std::chrono::steady_clock::now();
    if (i >= 0) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    x[2] += 1e-12 * f[2];  // use the reply so nothing is optimised away
  }
  dem.shutdown();
  thread.join();
  std::sort(us.begin(), us.end());
  Result r{transport};
  r.median_us = us[us.size() / 2];
  r.p90_us = us[us.size() * 9 / 10];
  r.min_us = us.front();
  for (double v : us) r.mean_us += v / static_cast<double>(us.size());
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Round-trip time of one get-forces/set-positions/simulate(0) exchange, 738 keypoints, ipc vs tcp"};
  app.name("bench_protocol_rtt");
  int repetitions = 2000;
  app.add_option("--repetitions", repetitions, "Measured exchanges per transport")->check(CLI::PositiveNumber);
  std::string& json = cli::addJsonOption(app);
  app.callback([&] {
    const auto dir = std::filesystem::temp_directory_path() / ("demfem-bench-" + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    std::vector<Result> results{measure("inproc", "inproc://bench", repetitions),
                                measure("ipc", "ipc://" + (dir / "bench.ipc").string(), repetitions),
                                measure("tcp", "tcp://127.0.0.1:*", repetitions)};
    std::filesystem::remove_all(dir);
    std::FILE* const table = cli::textStream(json);
    std::fprintf(table, "one exchange = get_node_forces + set_node_positions + simulate(0), 738 keypoints (%zu bytes each way per array)\n",
                static_cast<std::size_t>(738 * 3 * 8));
    std::fprintf(table, "%-9s %12s %12s %12s %12s\n", "transport", "median_us", "p90_us", "mean_us", "min_us");
    nlohmann::json rows = nlohmann::json::array();
    for (const auto& r : results) {
      std::fprintf(table, "%-9s %12.1f %12.1f %12.1f %12.1f\n", r.transport.c_str(), r.median_us, r.p90_us, r.mean_us, r.min_us);
      rows.push_back({{"transport", r.transport}, {"median_us", r.median_us}, {"p90_us", r.p90_us},
                      {"mean_us", r.mean_us}, {"min_us", r.min_us}});
    }
    cli::writeJson(json, {{"keypoints", 738}, {"repetitions", repetitions}, {"results", rows}});
  });
  return cli::runApp(app, argc, argv);
}
