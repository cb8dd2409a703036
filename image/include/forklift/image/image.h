// Frames as pixels and as files: an RGB image, PNG (libpng) and JPEG (libturbojpeg). A library
// of its own, so that the cab and the server, which only encode and decode frames, do not link
// the renderer.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace forklift {

// An RGB image, 8 bits a channel, rows top to bottom.
struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  // width * height * 3
  const uint8_t* pixel(int x, int y) const { return &rgb[(size_t(y) * width + x) * 3]; }
};

// Pixels as the renderer reads them back: 4 bytes a pixel (red, green, blue, one unused), rows
// top to bottom, owned by whoever made them. JPEG takes them as they are, with no copy to RGB.
struct RgbxPixels {
  int width = 0, height = 0;
  const uint8_t* data = nullptr;  // width * height * 4
  const uint8_t* pixel(int x, int y) const { return data + (size_t(y) * width + x) * 4; }
};

// PNG (libpng) and JPEG (libturbojpeg). Writers throw std::runtime_error naming the file.
void write_png(const std::string& path, const Image& image);
Image read_png(const std::string& path);
std::vector<uint8_t> encode_jpeg(const Image& image, int quality = 85);
std::vector<uint8_t> encode_jpeg(const RgbxPixels& pixels, int quality = 85);  // the same stream from RGBX
Image decode_jpeg(const uint8_t* data, size_t size);  // throws std::runtime_error on a bad stream

}  // namespace forklift
