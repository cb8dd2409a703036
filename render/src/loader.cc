#include "forklift/render/loader.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <system_error>

namespace forklift {
namespace {

using OpenFn = FrameRenderer* (*)(const Scene*, const TruckShape*, const TruckParams*, int, int, const RenderQuality*, char*,
                                  unsigned);

std::string module_path() {
  if (const char* p = std::getenv("FORKLIFT_RENDER_MODULE"); p && *p) return p;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("cannot find this program's folder to load the renderer: " + ec.message());
  return (exe.parent_path().parent_path() / "lib" / "libforklift_render_module.so").string();
}

// Loaded once per process and never unloaded (OSMesa keeps threads and state of its own).
OpenFn open_fn() {
  static std::mutex m;
  static OpenFn fn = nullptr;
  std::lock_guard<std::mutex> lock(m);
  if (fn) return fn;
  const std::string path = module_path();
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) throw std::runtime_error(std::string("cannot load the renderer (") + dlerror() + ")");
  fn = reinterpret_cast<OpenFn>(dlsym(handle, "forklift_render_module_open"));
  if (!fn) throw std::runtime_error("the renderer module " + path + " has no entry point");
  return fn;
}

}  // namespace

std::unique_ptr<FrameRenderer> load_renderer(const Scene& scene, const TruckShape& shape, const TruckParams& truck,
                                             int width, int height, const RenderQuality& quality) {
  char error[512] = {};
  FrameRenderer* r = open_fn()(&scene, &shape, &truck, width, height, &quality, error, sizeof error);
  if (!r) throw std::runtime_error(error);
  return std::unique_ptr<FrameRenderer>(r);
}

}  // namespace forklift
