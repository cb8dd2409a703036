// forklift-render: one still of a scenario, as PNG.
//
//   forklift-render --scenario FILE [--pose x,y,yaw_deg] [--fork-height M]
//                   [--view driver|chase|plan] [--size WxH] --out FILE.png
//   forklift-render --scenario FILE --describe    (prints the task's summary, else the
//                                                  scenario's description; for docs scripts)
//
// The truck stands at the pose (the scenario's start pose without --pose) with its wheels
// settled on the ground, forks at the given lift. Relative paths that do not exist from the
// current directory are looked up in the data directory. Any error: a message on stderr and
// exit status 2; never a crash.
#include <CLI/CLI.hpp>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "forklift/render/render.h"

using namespace forklift;

namespace {

constexpr int kUsageError = 2;

// Strict number parsing: the whole string, finite.
double parse_number(const std::string& text, const std::string& what) {
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (end == begin || *end != '\0' || errno == ERANGE || !std::isfinite(v))
    throw std::invalid_argument(what + ": '" + text + "' is not a finite number");
  return v;
}

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> parts;
  size_t start = 0;
  for (;;) {
    const size_t at = text.find(sep, start);
    parts.push_back(text.substr(start, at == std::string::npos ? std::string::npos : at - start));
    if (at == std::string::npos) return parts;
    start = at + 1;
  }
}

struct Pose {
  double x_m, y_m, yaw_rad;
};

Pose parse_pose(const std::string& text) {
  const std::vector<std::string> p = split(text, ',');
  if (p.size() != 3) throw std::invalid_argument("--pose: '" + text + "' is not x,y,yaw (metres, metres, degrees)");
  return {parse_number(p[0], "--pose x"), parse_number(p[1], "--pose y"),
          parse_number(p[2], "--pose yaw") * M_PI / 180.0};
}

void parse_size(const std::string& text, int& width, int& height) {
  const std::vector<std::string> p = split(text, 'x');
  auto dimension = [&](const std::string& s) {
    const double v = parse_number(s, "--size");
    if (v != std::floor(v) || v < 16 || v > 8192)
      throw std::invalid_argument("--size: '" + text + "' is not WxH with whole numbers 16..8192");
    return int(v);
  };
  if (p.size() != 2) throw std::invalid_argument("--size: '" + text + "' is not WxH (for example 640x480)");
  width = dimension(p[0]);
  height = dimension(p[1]);
}

// A relative path that does not exist from here is taken relative to the data directory.
std::string resolve(const std::string& path, const std::string& data_dir) {
  namespace fs = std::filesystem;
  if (path.empty() || fs::path(path).is_absolute() || fs::exists(path)) return path;
  return (fs::path(data_dir) / path).string();
}

int run(int argc, char** argv) {
  CLI::App app{"forklift-render: one still of a scenario, as PNG"};
  app.set_version_flag("--version", FORKLIFT_VERSION);
  app.option_defaults()->always_capture_default();  // --help shows each option's default
  std::string scenario_file, pose_text, view_text = "driver", size_text = "640x480", out_file;
  std::string data_dir = FORKLIFT_DATA_DIR;
  double fork_height_m = 0;
  bool describe = false;
  app.add_option("--scenario", scenario_file, "scenario file (data/scenarios/*.json)")->required();
  app.add_option("--pose", pose_text, "truck pose x,y,yaw: metres, metres, degrees (default: the scenario's start)");
  app.add_option("--fork-height", fork_height_m, "fork lift, metres (0: lowered)");
  app.add_option("--view", view_text, "driver, chase or plan");
  app.add_option("--size", size_text, "image size WxH");
  app.add_option("--out", out_file, "PNG file to write");
  app.add_flag("--describe", describe, "print the task's summary (else the description) and exit");
  app.add_option("--data-dir", data_dir, "where relative data paths are resolved");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : kUsageError;  // --help and --version: 0
  }

  if (out_file.empty() && !describe) throw std::invalid_argument("--out FILE.png is required");
  const View view = parse_view(view_text);
  int width = 0, height = 0;
  parse_size(size_text, width, height);
  std::optional<Pose> pose;
  if (!pose_text.empty()) pose = parse_pose(pose_text);
  if (!std::isfinite(fork_height_m) || fork_height_m < 0)
    throw std::invalid_argument("--fork-height must be a finite number >= 0");

  const Scene scene = load_scene(resolve(scenario_file, data_dir), data_dir);
  if (describe) {
    std::printf("%s\n", (scene.task.summary.empty() ? scene.description : scene.task.summary).c_str());
    return 0;
  }
  const TruckParams truck = load_truck(scene.scenario.truck_file);
  if (fork_height_m > truck.limits.lift_max_m)
    throw std::invalid_argument("--fork-height " + std::to_string(fork_height_m) + " m is above the truck's lift of " +
                                std::to_string(truck.limits.lift_max_m) + " m");
  TruckShape shape;
  try {
    shape = load_truck_shape(scene.scenario.truck_file, data_dir);
  } catch (const SceneError& e) {
    std::cerr << "forklift-render: warning: drawing no truck: " << e.what() << "\n";
  }

  // The truck at rest on the ground at the pose.
  const Pose at = pose.value_or(Pose{scene.scenario.x_m, scene.scenario.y_m, scene.scenario.yaw_rad});
  Environment environment;
  environment.ground = scene.ground;
  TruckDynamics dynamics(truck, environment);
  if (scene.scenario.load) dynamics.attach_load(*scene.scenario.load);
  StateVector x = dynamics.rest_state(at.x_m, at.y_m, at.yaw_rad, 0, 0, fork_height_m);
  if (!dynamics.settle_static(x))
    std::cerr << "forklift-render: warning: no static equilibrium with all wheels down at this pose\n";

  RenderState state;
  state.q = coordinates(x);
  Renderer renderer(scene, shape, truck, width, height);
  write_png(out_file, renderer.render(state, view));
  std::printf("wrote %s (%dx%d, %s view)\n", out_file.c_str(), width, height, view_name(view));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "forklift-render: " << e.what() << "\n";
    return kUsageError;
  }
}
