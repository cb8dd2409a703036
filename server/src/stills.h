// Stills at a session's events: `forklift-render` (render/) draws the scenario from the
// truck's pose at that moment into a PNG, which is kept in a cache folder so that each still is
// rendered once. The renderer runs as a child process: a crash or hang there costs one image,
// never the server.
#pragma once

#include <mutex>
#include <string>

namespace forklift::server {

struct StillRequest {
  std::string key;            // cache name, [A-Za-z0-9_.-] only (e.g. "s-000012-e3")
  std::string scenario_file;  // what the session ran
  double x_m = 0, y_m = 0, yaw_deg = 0;  // truck pose, world
  double fork_height_m = 0;
};

class Stills {
 public:
  Stills(std::string renderer_binary, std::string cache_dir, std::string data_dir);
  // Whether the renderer has been built (checked on each call: it may appear while we run).
  bool available() const;
  // The PNG bytes. Renders one still at a time (the machine's cores belong to the sim workers);
  // throws std::runtime_error with the renderer's complaint if it fails or takes over `timeout_s`.
  std::string png(const StillRequest& r, double timeout_s = 60);

 private:
  std::string binary_, cache_dir_, data_dir_;
  std::mutex render_mu_;
};

}  // namespace forklift::server
