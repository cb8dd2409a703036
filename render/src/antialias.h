// Private: anti-aliasing after drawing, on the CPU, in the read-back picture (an FXAA-like
// pass without its search along the edge): llvmpipe's multisampling or a second GL pass over
// the frame cost more than the whole frame's budget allows (forklift-bench-render's quality rows).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace forklift::render {

// Where a pixel's brightness (its green: what the eye reads most) steps against its four
// neighbours by at least kEdgeContrast, and by at least an eighth of the brightest of them, it
// is blended 1:2:1 with its neighbours across the edge (above and below it on an edge that runs
// across the picture, left and right on one that runs up it), so that a stepped edge becomes a
// ramp two pixels wide and no longer crawls as the truck moves. Flat areas and gentle shading
// are left exactly as drawn, and so is the picture's outermost ring of pixels.
inline constexpr int kEdgeContrast = 24;  // of 255

class EdgeSmoother {
 public:
  // `rgbx`: width x height pixels of 4 bytes (R, G, B, unused), rows one after another; in place.
  void apply(uint8_t* rgbx, int width, int height);

 private:
  std::vector<uint32_t> rows_;    // rows y - 1, y and y + 1 as drawn
  std::vector<int16_t> greens_;   // the three rows' greens
  std::vector<int16_t> masks_;    // row y: on an edge; the edge runs across the rows (all ones: yes)
};

}  // namespace forklift::render
