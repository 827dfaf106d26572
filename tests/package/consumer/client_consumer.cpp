// Uses the installed geoprox::client against a running geoproxd serving "spot" (data/meshes/spot.obj).
//   client_consumer PORT EXACT_DISTANCE
// EXACT_DISTANCE is the exact geodesic distance v:0 -> f:100:0.2:0.3:0.5 computed offline by the
// installed geoprox::core (core_consumer). Exits 0 when every check holds.
#include <geoprox/geoprox_client.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

namespace {

int failures = 0;

void check(bool ok, const std::string& what) {
  std::printf("%s: %s\n", ok ? "ok" : "FAILED", what.c_str());
  if (!ok) ++failures;
}

double distance_between(const nlohmann::json& a, const nlohmann::json& b) {
  double sum = 0;
  for (int i = 0; i < 3; ++i) {
    const double d = a.at(i).get<double>() - b.at(i).get<double>();
    sum += d * d;
  }
  return std::sqrt(sum);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: client_consumer PORT EXACT_DISTANCE\n");
    return 2;
  }
  const auto port = static_cast<std::uint16_t>(std::atoi(argv[1]));
  const double exact_offline = std::strtod(argv[2], nullptr);
  const std::string source = "v:0", target = "f:100:0.2:0.3:0.5";
  try {
    geoprox::client::Client client("127.0.0.1", port, {.connect_timeout_ms = 5000});
    // Wait (at most 120 s) for spot's graph.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    for (;;) {
      const nlohmann::json meshes = client.mesh_list().at("meshes");
      if (!meshes.empty() && meshes.at(0).at("state") == "ready") break;
      if (std::chrono::steady_clock::now() > deadline) {
        std::fprintf(stderr, "spot not ready after 120 s: %s\n", meshes.dump().c_str());
        return 1;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }

    const double zero = client.distance("spot", source, source).at("distance").get<double>();
    check(zero == 0.0, "distance v:0 -> v:0 is 0 (got " + std::to_string(zero) + ")");

    const double graph = client.distance("spot", source, target).at("distance").get<double>();
    const nlohmann::json exact_reply = client.distance("spot", source, target, /*exact=*/true);
    const double exact = exact_reply.at("distance").get<double>();
    check(exact_reply.at("exact").get<bool>(), "exact=true gives an exact answer");
    check(std::abs(exact - exact_offline) <= 1e-9 * exact_offline,
          "daemon's exact distance " + std::to_string(exact) +
              " equals geoprox::core's offline one " + std::to_string(exact_offline));
    // The graph answer is the length of a real surface path, so never below the exact distance
    // (up to rounding), and close to it on this mesh (docs/accuracy.md: well under 5 %).
    check(graph >= exact * (1 - 1e-9) && graph <= exact * 1.05,
          "graph distance " + std::to_string(graph) + " within [exact, 1.05 exact]");

    const nlohmann::json path = client.path("spot", source, target);
    const nlohmann::json& points = path.at("points");
    double length = 0;
    for (std::size_t i = 1; i < points.size(); ++i) {
      length += distance_between(points[i - 1].at("position"), points[i].at("position"));
    }
    const double straight =
        distance_between(points.front().at("position"), points.back().at("position"));
    const double path_distance = path.at("distance").get<double>();
    check(points.size() >= 2 && std::abs(length - path_distance) <= 1e-6 * path_distance,
          "path polyline length " + std::to_string(length) + " equals its distance " +
              std::to_string(path_distance));
    check(straight > 0 && exact >= straight * (1 - 1e-12),
          "exact distance >= straight line " + std::to_string(straight));

    try {
      client.distance("no_such_mesh", source, target);
      check(false, "an unknown mesh throws ServerError");
    } catch (const geoprox::client::ServerError& e) {
      check(e.reason() == "UnknownMesh" && !e.retryable(),
            "an unknown mesh throws ServerError UnknownMesh (got " + e.reason() + ")");
    }
  } catch (const geoprox::client::ClientError& e) {
    std::fprintf(stderr, "client error: %s\n", e.what());
    return 1;
  }
  std::printf("%d failed\n", failures);
  return failures == 0 ? 0 : 1;
}
