// PNG through libpng's simplified API, JPEG through libturbojpeg (2.1: tjInitCompress etc.).
#include <png.h>
#include <turbojpeg.h>

#include <algorithm>
#include <memory>
#include <stdexcept>

#include "forklift/image/image.h"

namespace forklift {
namespace {

void check_image(const Image& image, const std::string& what) {
  if (image.width <= 0 || image.height <= 0 || image.rgb.size() != size_t(image.width) * image.height * 3)
    throw std::runtime_error(what + ": image is " + std::to_string(image.width) + "x" +
                             std::to_string(image.height) + " with " + std::to_string(image.rgb.size()) +
                             " bytes, not width * height * 3");
}

struct TjDeleter {
  void operator()(void* handle) const { tjDestroy(handle); }
};
using TjHandle = std::unique_ptr<void, TjDeleter>;

}  // namespace

void write_png(const std::string& path, const Image& image) {
  check_image(image, "cannot write PNG " + path);
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = png_uint_32(image.width);
  png.height = png_uint_32(image.height);
  png.format = PNG_FORMAT_RGB;
  if (!png_image_write_to_file(&png, path.c_str(), 0, image.rgb.data(), image.width * 3, nullptr)) {
    const std::string message = png.message;
    png_image_free(&png);
    throw std::runtime_error("cannot write PNG " + path + ": " + message);
  }
}

Image read_png(const std::string& path) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&png, path.c_str())) {
    const std::string message = png.message;
    png_image_free(&png);
    throw std::runtime_error("cannot read PNG " + path + ": " + message);
  }
  png.format = PNG_FORMAT_RGB;  // converts grey, palette and alpha images (alpha over black)
  Image image;
  image.width = int(png.width);
  image.height = int(png.height);
  image.rgb.resize(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, image.rgb.data(), image.width * 3, nullptr)) {
    const std::string message = png.message;
    png_image_free(&png);
    throw std::runtime_error("cannot read PNG " + path + ": " + message);
  }
  return image;
}

namespace {

// 4:2:0, fast DCT: what the worker's stream has always been.
std::vector<uint8_t> compress(const uint8_t* pixels, int width, int height, int pitch, int format, int quality) {
  TjHandle tj(tjInitCompress());
  if (!tj) throw std::runtime_error(std::string("cannot encode JPEG: ") + tjGetErrorStr2(nullptr));
  unsigned char* data = nullptr;
  unsigned long size = 0;
  if (tjCompress2(tj.get(), pixels, width, pitch, height, format, &data, &size, TJSAMP_420, std::clamp(quality, 1, 100),
                  TJFLAG_FASTDCT) != 0) {
    const std::string message = tjGetErrorStr2(tj.get());
    tjFree(data);
    throw std::runtime_error("cannot encode JPEG: " + message);
  }
  std::vector<uint8_t> out(data, data + size);
  tjFree(data);
  return out;
}

}  // namespace

std::vector<uint8_t> encode_jpeg(const Image& image, int quality) {
  check_image(image, "cannot encode JPEG");
  return compress(image.rgb.data(), image.width, image.height, image.width * 3, TJPF_RGB, quality);
}

std::vector<uint8_t> encode_jpeg(const RgbxPixels& pixels, int quality) {
  if (pixels.width <= 0 || pixels.height <= 0 || !pixels.data)
    throw std::runtime_error("cannot encode JPEG: RGBX pixels are " + std::to_string(pixels.width) + "x" +
                             std::to_string(pixels.height) + (pixels.data ? "" : " with no data"));
  return compress(pixels.data, pixels.width, pixels.height, pixels.width * 4, TJPF_RGBX, quality);
}

Image decode_jpeg(const uint8_t* data, size_t size) {
  if (!data || size == 0) throw std::runtime_error("cannot decode JPEG: empty stream");
  TjHandle tj(tjInitDecompress());
  if (!tj) throw std::runtime_error(std::string("cannot decode JPEG: ") + tjGetErrorStr2(nullptr));
  int width = 0, height = 0, subsampling = 0, colourspace = 0;
  if (tjDecompressHeader3(tj.get(), data, static_cast<unsigned long>(size), &width, &height, &subsampling,
                          &colourspace) != 0)
    throw std::runtime_error(std::string("cannot decode JPEG: ") + tjGetErrorStr2(tj.get()));
  if (width <= 0 || height <= 0 || width > 65535 || height > 65535)
    throw std::runtime_error("cannot decode JPEG: bad size " + std::to_string(width) + "x" + std::to_string(height));
  Image image;
  image.width = width;
  image.height = height;
  image.rgb.resize(size_t(width) * height * 3);
  // Warnings (a truncated or damaged stream libjpeg decoded anyway) count as a bad stream too:
  // a frame with grey blocks is not a frame.
  if (tjDecompress2(tj.get(), data, static_cast<unsigned long>(size), image.rgb.data(), width, width * 3, height,
                    TJPF_RGB, TJFLAG_STOPONWARNING) != 0)
    throw std::runtime_error(std::string("cannot decode JPEG: ") + tjGetErrorStr2(tj.get()));
  return image;
}

}  // namespace forklift
