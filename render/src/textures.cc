// The surfaces' textures, made from tileable value noise: concrete, worn paint, wood, steel.
#include "textures.h"

#include <algorithm>
#include <cmath>

namespace forklift::render {
namespace {

constexpr int kN = kTextureSize;
enum Layer { kLayerPlain = 0, kLayerConcrete, kLayerPaint, kLayerWood, kLayerSteel };

// A well-mixed 32-bit hash of a lattice point and a seed, as 0..1.
float hash(int x, int y, uint32_t seed) {
  uint32_t h = uint32_t(x) * 0x8da6b343u ^ uint32_t(y) * 0xd8163841u ^ seed * 0xcb1ab31fu;
  h ^= h >> 15;
  h *= 0x2c1b3c6du;
  h ^= h >> 12;
  h *= 0x297a2d39u;
  h ^= h >> 15;
  return float(h & 0xffffff) / float(0xffffff);
}

// Value noise on a lattice of `cells_u` x `cells_v` cells across the texture, wrapped, so every
// layer tiles: texel (u, v) in 0..kN, result 0..1, smooth between lattice points.
float noise(float u, float v, int cells_u, int cells_v, uint32_t seed) {
  const float x = u * cells_u / kN, y = v * cells_v / kN;
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  const float fx = x - x0, fy = y - y0;
  const float sx = fx * fx * (3 - 2 * fx), sy = fy * fy * (3 - 2 * fy);
  auto at = [&](int i, int j) { return hash(((i % cells_u) + cells_u) % cells_u, ((j % cells_v) + cells_v) % cells_v, seed); };
  const float a = at(x0, y0), b = at(x0 + 1, y0), c = at(x0, y0 + 1), d = at(x0 + 1, y0 + 1);
  return (a + (b - a) * sx) * (1 - sy) + (c + (d - c) * sx) * sy;
}

// Octaves from `cells` cells across up to a texel's size, each half as strong: 0..1.
float fractal(float u, float v, int cells, uint32_t seed) {
  float sum = 0, weight = 0, w = 1;
  for (int c = cells; c <= kN; c *= 2, w *= 0.5f) {
    sum += w * noise(u, v, c, c, seed + uint32_t(c));
    weight += w;
  }
  return sum / weight;
}

float concrete(int u, int v) {
  // Cloudy aggregate, a fine grain and a few dark pores.
  float t = 0.86f + 0.07f * (fractal(u, v, 4, 11) - 0.5f) * 2 + 0.05f * (hash(u, v, 12) - 0.5f);
  if (hash(u, v, 13) < 0.01f) t -= 0.08f;
  return t;
}

float paint(int u, int v) {
  // Paint over concrete, worn through in patches where the noise runs high (wheel tracks).
  const float wear = std::clamp((fractal(u, v, 8, 21) - 0.62f) * 6.0f, 0.0f, 1.0f);
  return (0.97f + 0.04f * (hash(u, v, 22) - 0.5f)) * (1 - wear) + (0.80f + 0.08f * hash(u, v, 23)) * wear;
}

float wood(int u, int v) {
  // Grain along u: growth lines across v, wavy, and fine streaks stretched along the board.
  const float wave = 1.5f * fractal(u, v, 4, 31);
  const float rings = 0.5f + 0.5f * std::sin(2 * float(M_PI) * (7.0f * v / kN + wave));
  const float streaks = noise(u, v, 4, 64, 32);
  return 0.78f + 0.16f * rings * rings * rings + 0.10f * (streaks - 0.5f) + 0.04f * (hash(u, v, 33) - 0.5f);
}

float steel(int u, int v) {
  // Painted steel: faint blotches, a fine grain, and scuffs along u (where pallets slide).
  float t = 0.93f + 0.06f * (fractal(u, v, 8, 41) - 0.5f) * 2 + 0.03f * (hash(u, v, 42) - 0.5f);
  if (noise(u, v, 2, 48, 43) > 0.82f) t -= 0.12f;
  return t;
}

}  // namespace

int texture_layer(Pattern pattern) {
  switch (pattern) {
    case Pattern::kPlain: return kLayerPlain;
    case Pattern::kJoints: return kLayerConcrete;
    case Pattern::kStripes:
    case Pattern::kPaint: return kLayerPaint;
    case Pattern::kWood: return kLayerWood;
    case Pattern::kSteel: return kLayerSteel;
  }
  return kLayerPlain;
}

std::vector<uint8_t> surface_textures() {
  std::vector<uint8_t> out(size_t(kTextureLayers) * kN * kN, 255);
  float (*make[])(int, int) = {nullptr, concrete, paint, wood, steel};
  for (int layer = 1; layer < kTextureLayers; ++layer)
    for (int v = 0; v < kN; ++v)
      for (int u = 0; u < kN; ++u)
        out[(size_t(layer) * kN + v) * kN + u] = uint8_t(std::clamp(make[layer](u, v), 0.0f, 1.0f) * 255.0f + 0.5f);
  return out;
}

std::array<float, kTextureLayers> texture_means(const std::vector<uint8_t>& layers) {
  std::array<float, kTextureLayers> mean{};
  for (int layer = 0; layer < kTextureLayers; ++layer) {
    double sum = 0;
    for (size_t i = 0; i < size_t(kN) * kN; ++i) sum += layers[size_t(layer) * kN * kN + i];
    mean[layer] = float(sum / (double(kN) * kN * 255.0));
  }
  return mean;
}

}  // namespace forklift::render
