#include "frame_view.h"

#include <SDL.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>

namespace forklift {

struct FrameView::Window {
  SDL_Window* window = nullptr;
  SDL_Renderer* renderer = nullptr;
  SDL_Texture* texture = nullptr;
  int w = 0, h = 0;
  ~Window() {
    if (texture) SDL_DestroyTexture(texture);
    if (renderer) SDL_DestroyRenderer(renderer);
    if (window) SDL_DestroyWindow(window);
    SDL_QuitSubSystem(SDL_INIT_VIDEO);
  }
};

FrameView::FrameView(dds::Participant& participant, const std::string& cab, Options opt)
    : reader_(participant, dds::cab_partition(cab)), cab_(cab), opt_(std::move(opt)) {
  if (!opt_.save_dir.empty()) std::filesystem::create_directories(opt_.save_dir);
  if (opt_.window) {
    if (SDL_InitSubSystem(SDL_INIT_VIDEO) != 0) {
      std::cerr << "forklift-cab: no window (" << SDL_GetError() << "); frames are still received\n";
    } else {
      window_ = std::make_unique<Window>();
    }
  }
}

FrameView::~FrameView() = default;

// A frame whose size or encoding does not add up is counted and dropped, never shown.
bool FrameView::decode(const fk_Frame& f) {
  const std::string enc = f.encoding;
  try {
    if (enc == "rgb8") {
      const size_t n = size_t(f.width) * f.height * 3;
      if (f.width == 0 || f.height == 0 || f.pixels._length != n) return false;
      last_.width = f.width;
      last_.height = f.height;
      last_.rgb.assign(f.pixels._buffer, f.pixels._buffer + n);
      return true;
    }
    if (enc == "jpeg") {
      last_ = decode_jpeg(f.pixels._buffer, f.pixels._length);
      return true;
    }
  } catch (const std::exception& e) {
    std::cerr << "forklift-cab: bad frame " << f.seq << ": " << e.what() << '\n';
  }
  return false;
}

void FrameView::show() {
  if (!window_) return;
  Window& w = *window_;
  if (!w.window) {
    w.window = SDL_CreateWindow(("forklift cab " + cab_).c_str(), SDL_WINDOWPOS_UNDEFINED, SDL_WINDOWPOS_UNDEFINED,
                                last_.width, last_.height, SDL_WINDOW_RESIZABLE);
    if (w.window) w.renderer = SDL_CreateRenderer(w.window, -1, 0);
    if (!w.window || !w.renderer) {
      std::cerr << "forklift-cab: no window (" << SDL_GetError() << ")\n";
      window_.reset();
      return;
    }
  }
  if (!w.texture || w.w != last_.width || w.h != last_.height) {
    if (w.texture) SDL_DestroyTexture(w.texture);
    w.texture = SDL_CreateTexture(w.renderer, SDL_PIXELFORMAT_RGB24, SDL_TEXTUREACCESS_STREAMING, last_.width, last_.height);
    w.w = last_.width;
    w.h = last_.height;
  }
  SDL_UpdateTexture(w.texture, nullptr, last_.rgb.data(), last_.width * 3);
  SDL_RenderClear(w.renderer);
  SDL_RenderCopy(w.renderer, w.texture, nullptr, nullptr);
  SDL_RenderPresent(w.renderer);
}

bool FrameView::poll() {
  bool fresh = false;
  reader_.take_each([&](const fk_Frame& f) {
    if (cab_ != f.cab_id) return;
    if (!decode(f)) {
      ++bad_;
      return;
    }
    fresh = true;
    ++frames_;
    ++window_frames_;
    if (!opt_.save_dir.empty() && frames_ % opt_.save_every == 1 % opt_.save_every) {
      char name[32];
      std::snprintf(name, sizeof name, "/frame_%06ld.png", frames_);
      write_png(opt_.save_dir + name, last_);
    }
  });
  const auto now = std::chrono::steady_clock::now();
  const double span = std::chrono::duration<double>(now - window_start_).count();
  if (span >= 1.0) {
    fps_ = window_frames_ / span;
    window_frames_ = 0;
    window_start_ = now;
  }
  if (fresh) show();
  if (window_) {
    SDL_Event e;
    while (SDL_PollEvent(&e))
      if (e.type == SDL_QUIT) return false;
  }
  return true;
}

double FrameView::fps() const { return fps_; }

void FrameView::finish() {
  if (!opt_.save_last.empty() && last_.width > 0) write_png(opt_.save_last, last_);
}

}  // namespace forklift
