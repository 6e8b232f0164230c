// One scene, one peer simulator (RVO2 with -DPEER_RVO2, AVO2 with -DPEER_AVO2),
// one thread. Written against the peers' public APIs (RVO::RVOSimulator,
// AVO::Simulator); the scene loop follows their Circle examples: each step the
// preferred velocity is the vector to the goal (m -> m/s, gain 1/s), capped at
// --pref-speed (default: the maximum speed), then doStep().
//
//   driver_<peer> SCENE OUT [--dt 0.1] [--time-limit 500] [--tolerance 0.1]
//       [--radius 0.5] [--max-speed 1.5] [--max-accel 2] [--accel-interval 2]
//       [--neighbor-dist 15] [--max-neighbors 10] [--time-horizon 10]
//       [--time-horizon-obst 10] [--pref-speed V]
//
// SCENE (text): the robot count n, then n lines "start_x start_y goal_x goal_y" (m).
// OUT (binary, little-endian float64): one row of 1 + 2 n values per state, the
// first row the start: [wall time of the doStep that led to it (s, 0 for the
// start), x_0, y_0, ..., x_{n-1}, y_{n-1} (m)].
// Stops when every robot is within the tolerance of its goal after the same step,
// or at the time limit; prints "steps S arrived T" (T in s, or "never").
// --max-accel and --accel-interval are used by AVO2 only, --time-horizon-obst by
// RVO2 only (the scenes have no obstacles).

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#if defined(PEER_RVO2)
#include "RVO.h"
using Sim = RVO::RVOSimulator;
using Vec = RVO::Vector2;
static double vx(const Vec &v) { return v.x(); }
static double vy(const Vec &v) { return v.y(); }
#elif defined(PEER_AVO2)
#include "AVO.h"
using Sim = AVO::Simulator;
using Vec = AVO::Vector2;
static double vx(const Vec &v) { return v.getX(); }
static double vy(const Vec &v) { return v.getY(); }
#else
#error "define PEER_RVO2 or PEER_AVO2"
#endif

namespace {

struct Options {
  std::map<std::string, double> values{
      {"dt", 0.1},           {"time-limit", 500.0},   {"tolerance", 0.1},
      {"radius", 0.5},       {"max-speed", 1.5},      {"max-accel", 2.0},
      {"accel-interval", 2.0}, {"neighbor-dist", 15.0}, {"max-neighbors", 10.0},
      {"time-horizon", 10.0}, {"time-horizon-obst", 10.0}, {"pref-speed", -1.0}};
  double operator[](const std::string &key) const { return values.at(key); }
};

[[noreturn]] void fail(const std::string &message) {
  std::cerr << "driver: " << message << std::endl;
  std::exit(2);
}

}  // namespace

int main(int argc, char **argv) {
  if (argc < 3) fail("usage: driver SCENE OUT [--key value ...]");
  Options opt;
  for (int k = 3; k < argc; k += 2) {
    std::string key = argv[k];
    if (key.rfind("--", 0) != 0 || k + 1 >= argc) fail("expected --key value, got " + key);
    key = key.substr(2);
    if (!opt.values.count(key)) fail("unknown option --" + key);
    char *end = nullptr;
    opt.values[key] = std::strtod(argv[k + 1], &end);
    if (*end != '\0') fail("--" + key + ": expected a number, got " + argv[k + 1]);
  }

  std::ifstream scene(argv[1]);
  std::size_t n = 0;
  if (!(scene >> n)) fail(std::string(argv[1]) + ": expected the robot count first");
  std::vector<Vec> starts, goals;
  for (std::size_t i = 0; i < n; ++i) {
    double sx, sy, gx, gy;
    if (!(scene >> sx >> sy >> gx >> gy))
      fail(std::string(argv[1]) + ": expected 4 numbers on robot line " + std::to_string(i + 1));
    starts.emplace_back(static_cast<float>(sx), static_cast<float>(sy));
    goals.emplace_back(static_cast<float>(gx), static_cast<float>(gy));
  }

  const float dt = static_cast<float>(opt["dt"]);
  const float vmax = static_cast<float>(opt["max-speed"]);
  const float vpref = opt["pref-speed"] < 0.0 ? vmax : static_cast<float>(opt["pref-speed"]);
  Sim sim;
  sim.setTimeStep(dt);
#if defined(PEER_RVO2)
  sim.setAgentDefaults(static_cast<float>(opt["neighbor-dist"]),
                       static_cast<std::size_t>(opt["max-neighbors"]),
                       static_cast<float>(opt["time-horizon"]),
                       static_cast<float>(opt["time-horizon-obst"]),
                       static_cast<float>(opt["radius"]), vmax);
#else
  sim.setAgentDefaults(static_cast<float>(opt["neighbor-dist"]),
                       static_cast<std::size_t>(opt["max-neighbors"]),
                       static_cast<float>(opt["time-horizon"]),
                       static_cast<float>(opt["radius"]), vmax,
                       static_cast<float>(opt["max-accel"]),
                       static_cast<float>(opt["accel-interval"]));
#endif
  for (const Vec &s : starts) sim.addAgent(s);

  std::FILE *out = std::fopen(argv[2], "wb");
  if (!out) fail(std::string(argv[2]) + ": cannot open for writing");
  std::vector<double> row(1 + 2 * n);
  auto record = [&](double wall) {
    row[0] = wall;
    for (std::size_t i = 0; i < n; ++i) {
      row[1 + 2 * i] = vx(sim.getAgentPosition(i));
      row[2 + 2 * i] = vy(sim.getAgentPosition(i));
    }
    std::fwrite(row.data(), sizeof(double), row.size(), out);
  };
  record(0.0);

  const long limit = std::lround(opt["time-limit"] / opt["dt"]);
  const double tol = opt["tolerance"];
  long steps = 0;
  bool arrived = false;
  while (steps < limit && !arrived) {
    for (std::size_t i = 0; i < n; ++i) {
      Vec to_goal = goals[i] - sim.getAgentPosition(i);
      const float d = abs(to_goal);
      if (d > vpref) to_goal = to_goal * (vpref / d);
      sim.setAgentPrefVelocity(i, to_goal);
    }
    const auto t0 = std::chrono::steady_clock::now();
    sim.doStep();
    const auto t1 = std::chrono::steady_clock::now();
    ++steps;
    record(std::chrono::duration<double>(t1 - t0).count());
    arrived = true;
    for (std::size_t i = 0; i < n && arrived; ++i) {
      const Vec p = sim.getAgentPosition(i);
      arrived = std::hypot(vx(p) - vx(goals[i]), vy(p) - vy(goals[i])) <= tol;
    }
  }
  std::fclose(out);
  if (arrived)
    std::printf("steps %ld arrived %.6f\n", steps, steps * opt["dt"]);
  else
    std::printf("steps %ld arrived never\n", steps);
  return 0;
}
