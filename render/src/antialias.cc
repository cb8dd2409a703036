// The edge smoothing pass, row by row, from copies of the rows above, at and below as drawn (the
// pass overwrites the picture as it goes): the rows' greens in 16-bit lanes, then which pixels
// stand on an edge and which way it runs, then the blend of whole pixels (four bytes at once),
// each sweep branch-free so that the compiler vectorises it (eight or four lanes with SSE2). The
// blend is written into the picture a block of pixels at a time, and only in blocks with an edge:
// most of a frame is flat, and a flat block is left as it is.
#include "antialias.h"

#include <algorithm>
#include <cstring>

namespace forklift::render {
namespace {

// Each byte of a and b averaged, rounded down: (a & b) + ((a ^ b) >> 1), lane by lane.
inline __attribute__((always_inline)) uint32_t average(uint32_t a, uint32_t b) { return (a & b) + (((a ^ b) & 0xfefefefeu) >> 1); }

// A pixel of the picture, which is bytes.
typedef uint32_t __attribute__((may_alias)) Pixel;

// Pixels a block of the blend: a flat block (no edge) is skipped whole.
constexpr size_t kBlock = 32;

inline __attribute__((always_inline)) void greens(const uint32_t* row, int16_t* out, size_t n) {
  for (size_t x = 0; x < n; ++x) out[x] = int16_t((row[x] >> 8) & 0xffu);
}

// The pass over the picture, given its scratch rows. Compiled twice, for AVX2 (twice the lanes:
// the machines this runs on have it) and for any x86-64, the one for the processor chosen when
// the program starts.
__attribute__((target_clones("avx2", "default"))) void smooth(uint8_t* rgbx, size_t w, int height, uint32_t* above,
                                                              int16_t* g_above, int16_t* edge) {
  uint32_t *here = above + w, *below = here + w;
  int16_t *g_here = g_above + w, *g_below = g_here + w, *across_rows = edge + w;
  std::memcpy(here, rgbx, w * 4);
  std::memcpy(below, rgbx + w * 4, w * 4);
  greens(here, g_here, w);
  greens(below, g_below, w);
  for (int y = 1; y + 1 < height; ++y) {
    std::swap(above, here);
    std::swap(here, below);
    std::swap(g_above, g_here);
    std::swap(g_here, g_below);
    uint8_t* row = rgbx + size_t(y) * w * 4;
    std::memcpy(below, row + w * 4, w * 4);  // not blended yet
    greens(below, g_below, w);
    for (size_t x = 1; x + 1 < w; ++x) {
      const int16_t m = g_here[x], n = g_above[x], s = g_below[x], west = g_here[x - 1], east = g_here[x + 1];
      const int16_t hi = std::max(std::max(std::max(m, n), std::max(s, west)), east);
      const int16_t lo = std::min(std::min(std::min(m, n), std::min(s, west)), east);
      edge[x] = int16_t(-(hi - lo >= std::max(int16_t(kEdgeContrast), int16_t(hi >> 3))));
      // Which way the brightness bends most: across a horizontal edge (up-down) or a vertical one.
      const int16_t bend_rows = int16_t(n + s - 2 * m), bend_columns = int16_t(west + east - 2 * m);
      across_rows[x] = int16_t(-(std::max(bend_rows, int16_t(-bend_rows)) >= std::max(bend_columns, int16_t(-bend_columns))));
    }
    Pixel* const out = reinterpret_cast<Pixel*>(row);
    for (size_t x0 = 1; x0 + 1 < w; x0 += kBlock) {
      const size_t x1 = std::min(x0 + kBlock, w - 1);
      int16_t any = 0;
      for (size_t x = x0; x < x1; ++x) any |= edge[x];
      if (!any) continue;
      for (size_t x = x0; x < x1; ++x) {
        const uint32_t rows = uint32_t(int32_t(across_rows[x])), on_edge = uint32_t(int32_t(edge[x]));
        const uint32_t vertical = average(average(above[x], below[x]), here[x]);
        const uint32_t horizontal = average(average(here[x - 1], here[x + 1]), here[x]);
        const uint32_t blended = (vertical & rows) | (horizontal & ~rows);
        out[x] = (blended & on_edge) | (here[x] & ~on_edge);
      }
    }
  }
}

}  // namespace

void EdgeSmoother::apply(uint8_t* rgbx, int width, int height) {
  if (width < 3 || height < 3) return;
  const size_t w = size_t(width);
  rows_.resize(3 * w);
  greens_.resize(3 * w);
  masks_.resize(2 * w);
  // Raw pointers: a byte store may alias a vector's own pointer, which would keep the compiler
  // from vectorising.
  smooth(rgbx, w, height, rows_.data(), greens_.data(), masks_.data());
}

}  // namespace forklift::render
