// The render module's one entry point (loader.h): a Renderer behind FrameRenderer, made inside the
// module so that OSMesa is only ever linked here.
#include <cstdio>
#include <exception>

#include "forklift/render/loader.h"

namespace forklift {
namespace {

class ModuleRenderer final : public FrameRenderer {
 public:
  ModuleRenderer(const Scene& scene, const TruckShape& shape, const TruckParams& truck, int width, int height,
                 const RenderQuality& quality)
      : renderer_(scene, shape, truck, width, height, quality) {}
  const Image& render(const RenderState& state, View view, const ViewOptions& options) override {
    return renderer_.render(state, view, options);
  }
  RgbxPixels render_rgbx(const RenderState& state, View view, const ViewOptions& options) override {
    return renderer_.render_rgbx(state, view, options);
  }

 private:
  Renderer renderer_;
};

}  // namespace
}  // namespace forklift

// nullptr and the reason in `error` when the renderer cannot start (no exception crosses dlopen).
extern "C" __attribute__((visibility("default"))) forklift::FrameRenderer* forklift_render_module_open(
    const forklift::Scene* scene, const forklift::TruckShape* shape, const forklift::TruckParams* truck, int width,
    int height, const forklift::RenderQuality* quality, char* error, unsigned error_size) {
  try {
    return new forklift::ModuleRenderer(*scene, *shape, *truck, width, height, *quality);
  } catch (const std::exception& e) {
    std::snprintf(error, error_size, "%s", e.what());
  } catch (...) {
    std::snprintf(error, error_size, "unknown error");
  }
  return nullptr;
}
