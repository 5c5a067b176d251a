// example-dem-server: a DEM code of one's own behind demfem's coupling API (docs/coupling-guide.md,
// "Coupling your own DEM code"). The "DEM" here is an elastic foundation: every node of one square
// plate is held by a spring of stiffness kSpring_N_m to where it started, so the force the "soil"
// exerts on node i is F_i = -k (x_i - x0_i) (local frame, N). A real code puts its particle
// contacts here; the serving part stays the same.
//
//   example-dem-server ENDPOINT     serve until the FEM client shuts it down (ipc://PATH; tcp needs keys)
//   example-dem-server --self-check serve in a thread, drive it through the remote proxy and print
//                                   {"force_z_N": ..., "expected_force_z_N": ...}; exit 0 if equal
#include "demfem/adapter/coupling_api.hpp"
#include "demfem/adapter/remote_proxy.hpp"
#include "demfem/adapter/server.hpp"
#include "demfem/protocol/transport.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>
#include <thread>

namespace {

using namespace demfem;

constexpr double kSpring_N_m = 2.0e4;
constexpr double kDemStep_s = 1e-5;
constexpr char kPlate[] = "plate";

class ElasticFoundation final : public adapter::CouplingApi {
 public:
  adapter::BackendInfo info() override { return {"elastic-foundation", "1", 1, kDemStep_s, {}}; }
  std::vector<adapter::GeometryInfo> geometries() override { return {{kPlate, 4, {{0, 1, 2}, {0, 2, 3}}}}; }
  double time() override { return steps_ * kDemStep_s; }
  adapter::NodeArray nodePositions(const std::string& geometry) override {
    check(geometry);
    return positions_;
  }
  adapter::NodeArray nodeForces(const std::string& geometry, adapter::ForceMode) override {
    check(geometry);
    adapter::NodeArray forces(rest_.size());
    for (std::size_t i = 0; i < rest_.size(); ++i) forces[i] = -kSpring_N_m * (positions_[i] - rest_[i]);
    return forces;
  }
  void setNodePositions(const std::string& geometry, const adapter::NodeArray& xyz) override {
    check(geometry);
    if (xyz.size() != rest_.size())
      throw adapter::CouplingError(adapter::ErrorCode::SizeMismatch, "the plate has 4 nodes: 12 numbers");
    positions_ = xyz;
  }
  void simulate(double duration_s) override { steps_ += adapter::demStepCount(duration_s, kDemStep_s, steps_); }
  adapter::RigidMotion rigidMotion(const std::string& geometry) override {
    check(geometry);
    return motion_;
  }
  void setRigidMotion(const std::string& geometry, const adapter::RigidMotion& motion) override {
    check(geometry);
    motion_ = motion;
  }
  void checkpoint(const std::filesystem::path&) override { unsupported(); }
  void restore(const std::filesystem::path&) override { unsupported(); }
  void shutdown() override {}

 private:
  static void check(const std::string& geometry) {
    if (geometry != kPlate)
      throw adapter::CouplingError(adapter::ErrorCode::UnknownGeometry, "no geometry '" + geometry + "'");
  }
  [[noreturn]] static void unsupported() {
    throw adapter::CouplingError(adapter::ErrorCode::Unsupported, "the elastic foundation keeps no checkpoints");
  }

  const adapter::NodeArray rest_{0, 0, 0, 0.04, 0, 0, 0.04, 0.2, 0, 0, 0.2, 0};  // 40 x 200 mm plate
  adapter::NodeArray positions_ = rest_;
  adapter::RigidMotion motion_;
  std::int64_t steps_ = 0;
};

void serve(protocol::Context& context, const std::string& endpoint) {
  ElasticFoundation dem;
  protocol::ServerSocket socket(context, endpoint);
  adapter::Server server(dem);
  std::fprintf(stderr, "example-dem-server: serving on %s\n", socket.endpoint().c_str());
  server.serve(socket, std::chrono::seconds(60));
}

// Pushes node 0 by 1 mm against the travel and reads the spring force back through the protocol.
int selfCheck() {
  protocol::Context context;
  const std::string endpoint = "inproc://example-dem-server";
  std::exception_ptr failure;
  std::thread server([&] {
    try {
      serve(context, endpoint);
    } catch (...) {
      failure = std::current_exception();
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // inproc: bind before connect
  adapter::RemoteProxy dem({endpoint}, &context);
  adapter::NodeArray xyz = dem.nodePositions(kPlate);
  const double push_m = -1e-3;
  xyz[2] += push_m;
  dem.setNodePositions(kPlate, xyz);
  dem.simulate(1e-3);
  const double force = dem.nodeForces(kPlate)[2];
  const double expected = -kSpring_N_m * push_m;
  std::printf("{\"force_z_N\": %.17g, \"expected_force_z_N\": %.17g, \"time_s\": %.17g}\n", force, expected, dem.time());
  dem.shutdown();
  server.join();
  if (failure) std::rethrow_exception(failure);
  return std::abs(force - expected) <= 1e-9 * std::abs(expected) ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc != 2) {
      std::fprintf(stderr, "usage: example-dem-server ENDPOINT | --self-check\n");
      return 2;
    }
    if (std::string(argv[1]) == "--self-check") return selfCheck();
    protocol::Context context;
    serve(context, argv[1]);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "example-dem-server: %s\n", e.what());
    return 1;
  }
}
