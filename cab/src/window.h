// The cab's window: the worker's latest frame scaled to the window, the head-up display drawn
// over it (SDL2_ttf with Debian's DejaVu fonts), and pictures of the whole window on demand.
#pragma once

#include <SDL.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "forklift/image/image.h"
#include "hud.h"

namespace forklift::cab {

class CabWindow {
 public:
  // Opens the window (SDL video must be initialised). Throws std::runtime_error with SDL's words.
  CabWindow(const std::string& title, int width, int height, const std::string& font, const std::string& font_bold);
  ~CabWindow();
  CabWindow(const CabWindow&) = delete;
  CabWindow& operator=(const CabWindow&) = delete;

  void set_frame(const Image& frame);  // the picture to show from now on
  // Draws the frame and the HUD and presents them; with `capture`, the picture is also read back
  // into it (what the pupil sees, for F12 and --save-window).
  void present(const std::vector<HudItem>& hud, Image* capture = nullptr);
  int width() const;
  int height() const;
  uint32_t id() const { return SDL_GetWindowID(window_); }
  bool has_frame() const { return frame_w_ > 0; }

 private:
  Image read_pixels();
  SDL_Texture* text_texture(const HudItem& item, int& w, int& h);

  SDL_Window* window_ = nullptr;
  SDL_Renderer* renderer_ = nullptr;
  SDL_Texture* frame_ = nullptr;
  int frame_w_ = 0, frame_h_ = 0;
  struct Fonts;
  std::unique_ptr<Fonts> fonts_;
  struct Cached {
    SDL_Texture* texture = nullptr;
    int w = 0, h = 0;
    long used = 0;
  };
  std::map<std::string, Cached> cache_;
  long generation_ = 0;
};

}  // namespace forklift::cab
