// A scripted cab's drive for tests: straight ahead at 30 % throttle for `drive_s`, then the
// script ends and the cab falls silent, so the worker's dead man stops the truck.
#pragma once

#include <fstream>
#include <string>

namespace forklift_test {

inline std::string short_script(const std::string& dir, double drive_s) {
  const std::string path = dir + "/short.csv";
  std::ofstream f(path);
  f << "t,steer,accelerator,brake,lift,tilt,shift\n";
  for (double t = 0; t <= drive_s + 1e-9; t += 0.02) f << t << ",0,0.3,0,0,0,0\n";
  return path;
}

}  // namespace forklift_test
