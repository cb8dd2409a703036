#include "stills.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <regex>
#include <stdexcept>
#include <vector>

#include "child.h"
#include "forklift/units/decimals.h"

namespace forklift::server {

Stills::Stills(std::string renderer_binary, std::string cache_dir, std::string data_dir)
    : binary_(std::move(renderer_binary)), cache_dir_(std::move(cache_dir)), data_dir_(std::move(data_dir)) {}

bool Stills::available() const { return access(binary_.c_str(), X_OK) == 0; }

std::string Stills::png(const StillRequest& r, double timeout_s) {
  if (!std::regex_match(r.key, std::regex("[A-Za-z0-9_.-]{1,100}"))) throw std::logic_error("bad still key " + r.key);
  const std::string out = cache_dir_ + "/" + r.key + ".png";
  if (std::filesystem::exists(out)) return slurp_file(out);
  if (!available()) throw std::runtime_error("the renderer (" + binary_ + ") has not been built");
  std::lock_guard<std::mutex> lock(render_mu_);
  if (std::filesystem::exists(out)) return slurp_file(out);  // rendered while we waited
  std::filesystem::create_directories(cache_dir_);
  const std::string tmp = out + ".tmp.png", err = out + ".err";
  std::vector<std::string> args = {binary_, "--scenario", r.scenario_file, "--pose",
                                   fixed_decimals(r.x_m, 4) + "," + fixed_decimals(r.y_m, 4) + "," + fixed_decimals(r.yaw_deg, 4),
                                   "--fork-height", fixed_decimals(r.fork_height_m, 4), "--view", "chase",
                                   "--size", "640x400", "--data-dir", data_dir_, "--out", tmp};
  const int status = run_child(args, err, err, timeout_s, "the renderer");
  if (status != 0 || !std::filesystem::exists(tmp)) {
    throw std::runtime_error("the renderer failed: " + child_complaint(err));
  }
  std::filesystem::rename(tmp, out);  // whole files only in the cache
  std::filesystem::remove(err);
  return slurp_file(out);
}

}  // namespace forklift::server
