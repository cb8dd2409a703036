#include "forklift/render/loader.h"

#include <stdexcept>

#include "forklift/module/module.h"

namespace forklift {
namespace {

using OpenFn = FrameRenderer* (*)(const Scene*, const TruckShape*, const TruckParams*, int, int, const RenderQuality*, char*,
                                  unsigned);

// Loaded once per process and never unloaded (OSMesa keeps threads and state of its own).
OpenFn open_fn() {
  static const OpenFn fn = reinterpret_cast<OpenFn>(
      module::entry_point("libforklift_render_module.so", "FORKLIFT_RENDER_MODULE", "forklift_render_module_open"));
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
