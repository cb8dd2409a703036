// Private: the surfaces' textures, made in code when a renderer starts (no image files): small
// tileable grey-level pictures that shade a surface's own colour, one layer of a texture array
// for each textured Pattern (geometry.h), read with one nearest tap (shaders.h says why).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "geometry.h"

namespace forklift::render {

inline constexpr int kTextureSize = 128;  // texels a side
inline constexpr int kTextureLayers = 5;  // plain (all 1), concrete, worn paint, wood, steel

// The layer a pattern's surfaces read (plain: layer 0, whose every texel is 1, so the colour is
// the surface's own, exactly).
int texture_layer(Pattern pattern);

// Every layer, kTextureSize x kTextureSize one-byte texels (255: the surface's colour; less:
// darker), layer after layer. The same bytes every time.
std::vector<uint8_t> surface_textures();

// What a layer's texels average, 0..1: the shader divides by it, so a textured surface keeps
// the brightness of its colour on average and only its grain shows.
std::array<float, kTextureLayers> texture_means(const std::vector<uint8_t>& layers);

}  // namespace forklift::render
