// The renderer, loaded when first needed: OSMesa brings LLVM, which costs a program about
// 100 ms of start-up and 60 MB, so a program that may never draw (a worker whose cab asks for no
// frames) loads the renderer as a module, from build/lib, the first time it draws.
#pragma once

#include <memory>
#include <string>

#include "forklift/render/render.h"

namespace forklift {

// What a loaded renderer offers: the worker's frames. Inline, so that the module and the program
// each have the vtable without sharing symbols.
class FrameRenderer {
 public:
  virtual ~FrameRenderer() = default;
  virtual const Image& render(const RenderState& state, View view, const ViewOptions& options) = 0;
  virtual RgbxPixels render_rgbx(const RenderState& state, View view, const ViewOptions& options) = 0;
};

// Loads the render module (FORKLIFT_RENDER_MODULE, or lib/libforklift_render_module.so beside the
// program's bin/) and makes a renderer of the scene, as Renderer's constructor does. Throws
// std::runtime_error naming the module and what went wrong.
std::unique_ptr<FrameRenderer> load_renderer(const Scene& scene, const TruckShape& shape, const TruckParams& truck,
                                             int width, int height, const RenderQuality& quality = {});

}  // namespace forklift
