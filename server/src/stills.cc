#include "stills.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

namespace forklift::server {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4f", v);
  return buf;
}

}  // namespace

Stills::Stills(std::string renderer_binary, std::string cache_dir, std::string data_dir)
    : binary_(std::move(renderer_binary)), cache_dir_(std::move(cache_dir)), data_dir_(std::move(data_dir)) {}

bool Stills::available() const { return access(binary_.c_str(), X_OK) == 0; }

std::string Stills::png(const StillRequest& r, double timeout_s) {
  if (!std::regex_match(r.key, std::regex("[A-Za-z0-9_.-]{1,100}"))) throw std::logic_error("bad still key " + r.key);
  const std::string out = cache_dir_ + "/" + r.key + ".png";
  if (std::filesystem::exists(out)) return slurp(out);
  if (!available()) throw std::runtime_error("the renderer (" + binary_ + ") has not been built");
  std::lock_guard<std::mutex> lock(render_mu_);
  if (std::filesystem::exists(out)) return slurp(out);  // rendered while we waited
  std::filesystem::create_directories(cache_dir_);
  const std::string tmp = out + ".tmp.png", err = out + ".err";
  std::vector<std::string> args = {binary_, "--scenario", r.scenario_file, "--pose",
                                   number(r.x_m) + "," + number(r.y_m) + "," + number(r.yaw_deg),
                                   "--fork-height", number(r.fork_height_m), "--view", "chase",
                                   "--size", "640x400", "--data-dir", data_dir_, "--out", tmp};
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) {
    const int fd = open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) { dup2(fd, 1); dup2(fd, 2); }
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > until) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
      throw std::runtime_error("the renderer took over " + std::to_string(int(timeout_s)) + " s");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || !std::filesystem::exists(tmp)) {
    std::string why = slurp(err);
    if (why.size() > 500) why.resize(500);
    throw std::runtime_error("the renderer failed: " + why);
  }
  std::filesystem::rename(tmp, out);  // whole files only in the cache
  std::filesystem::remove(err);
  return slurp(out);
}

}  // namespace forklift::server
