#include "replays.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <stdexcept>

#include "child.h"

namespace forklift::server {

Replays::Replays(std::string sim_binary, std::string cache_dir)
    : binary_(std::move(sim_binary)), cache_dir_(std::move(cache_dir)) {}

bool Replays::available() const { return access(binary_.c_str(), X_OK) == 0; }

std::string Replays::trace(const std::string& key, const std::string& control_log, const std::string& scenario_file,
                           double timeout_s) {
  if (!std::regex_match(key, std::regex("[A-Za-z0-9_.-]{1,100}"))) throw std::logic_error("bad replay key " + key);
  const std::string out = cache_dir_ + "/" + key + ".json";
  if (std::filesystem::exists(out)) return slurp_file(out);
  if (!available()) throw std::runtime_error("replays need forklift-sim (" + binary_ + "), which has not been built");
  std::lock_guard<std::mutex> lock(mu_);
  if (std::filesystem::exists(out)) return slurp_file(out);  // made while we waited
  std::filesystem::create_directories(cache_dir_);
  const std::string log = out + ".ctl", tmp = out + ".tmp", err = out + ".err";
  {
    std::ofstream f(log, std::ios::binary);
    f << control_log;
    if (!f) throw std::runtime_error("cannot write " + log);
  }
  std::vector<std::string> args = {binary_, "trace", log, "--every", "0.1"};
  if (!scenario_file.empty()) args.insert(args.end(), {"--scenario", scenario_file});
  const int status = run_child(args, tmp, err, timeout_s, "the replay");
  std::filesystem::remove(log);
  // 3: a numerical failure part way; the samples up to it are still the session as it ran.
  if ((status != 0 && status != 3) || std::filesystem::file_size(tmp) == 0) {
    throw std::runtime_error("the session could not be replayed: " + child_complaint(err));
  }
  std::filesystem::rename(tmp, out);  // whole files only in the cache
  std::filesystem::remove(err);
  return slurp_file(out);
}

}  // namespace forklift::server
