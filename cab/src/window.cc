#include "window.h"

#include <SDL_ttf.h>

#include <stdexcept>

namespace forklift::cab {

struct CabWindow::Fonts {
  TTF_Font* size[3] = {nullptr, nullptr, nullptr};
  ~Fonts() {
    for (TTF_Font* f : size)
      if (f) TTF_CloseFont(f);
    TTF_Quit();
  }
};

CabWindow::CabWindow(const std::string& title, int width, int height, const std::string& font, const std::string& bold) {
  window_ = SDL_CreateWindow(title.c_str(), SDL_WINDOWPOS_UNDEFINED, SDL_WINDOWPOS_UNDEFINED, width, height,
                             SDL_WINDOW_RESIZABLE);
  if (!window_) throw std::runtime_error(std::string("cannot open the cab's window: ") + SDL_GetError());
  renderer_ = SDL_CreateRenderer(window_, -1, 0);
  if (!renderer_) throw std::runtime_error(std::string("cannot draw in the cab's window: ") + SDL_GetError());
  SDL_SetRenderDrawBlendMode(renderer_, SDL_BLENDMODE_BLEND);
  if (TTF_Init() != 0) throw std::runtime_error(std::string("no fonts for the head-up display: ") + TTF_GetError());
  fonts_ = std::make_unique<Fonts>();
  const int line = hud_line_px(height);
  for (int i = 0; i < 3; ++i) {
    fonts_->size[i] = TTF_OpenFont((i == 0 ? font : bold).c_str(), hud_font_px(i, line));
    if (!fonts_->size[i])
      throw std::runtime_error("cannot open the head-up display's font " + (i == 0 ? font : bold) + ": " + TTF_GetError());
  }
  // A first picture at once, so the pupil sees the window is the cab before the first frame.
  SDL_SetRenderDrawColor(renderer_, 30, 30, 30, 255);
  SDL_RenderClear(renderer_);
  SDL_RenderPresent(renderer_);
}

CabWindow::~CabWindow() {
  for (auto& [key, c] : cache_) SDL_DestroyTexture(c.texture);
  fonts_.reset();
  if (frame_) SDL_DestroyTexture(frame_);
  if (renderer_) SDL_DestroyRenderer(renderer_);
  if (window_) SDL_DestroyWindow(window_);
}

int CabWindow::width() const {
  int w = 0, h = 0;
  SDL_GetRendererOutputSize(renderer_, &w, &h);
  return w;
}

int CabWindow::height() const {
  int w = 0, h = 0;
  SDL_GetRendererOutputSize(renderer_, &w, &h);
  return h;
}

void CabWindow::set_frame(const Image& f) {
  if (f.width <= 0 || f.height <= 0) return;
  if (!frame_ || frame_w_ != f.width || frame_h_ != f.height) {
    if (frame_) SDL_DestroyTexture(frame_);
    frame_ = SDL_CreateTexture(renderer_, SDL_PIXELFORMAT_RGB24, SDL_TEXTUREACCESS_STREAMING, f.width, f.height);
    frame_w_ = f.width;
    frame_h_ = f.height;
  }
  if (frame_) SDL_UpdateTexture(frame_, nullptr, f.rgb.data(), f.width * 3);
}

SDL_Texture* CabWindow::text_texture(const HudItem& item, int& w, int& h) {
  const int size = std::clamp(item.size, 0, 2);
  const std::string key = std::to_string(size) + ':' + std::to_string(item.w) + ':' + std::to_string(item.colour.r) + ',' + std::to_string(item.colour.g) +
                          ',' + std::to_string(item.colour.b) + ':' + item.text;
  auto it = cache_.find(key);
  if (it == cache_.end()) {
    const SDL_Color c{item.colour.r, item.colour.g, item.colour.b, item.colour.a};
    SDL_Surface* s = item.w > 0 ? TTF_RenderUTF8_Blended_Wrapped(fonts_->size[size], item.text.c_str(), c, Uint32(item.w))
                                : TTF_RenderUTF8_Blended(fonts_->size[size], item.text.c_str(), c);
    if (!s) return nullptr;
    Cached entry{SDL_CreateTextureFromSurface(renderer_, s), s->w, s->h, generation_};
    SDL_FreeSurface(s);
    it = cache_.emplace(key, entry).first;
  }
  it->second.used = generation_;
  w = it->second.w;
  h = it->second.h;
  return it->second.texture;
}

void CabWindow::present(const std::vector<HudItem>& hud, Image* capture) {
  ++generation_;
  SDL_SetRenderDrawColor(renderer_, 30, 30, 30, 255);
  SDL_RenderClear(renderer_);
  if (frame_) {
    // Keep the picture's shape: letterbox it in the window.
    const int W = width(), H = height();
    const double scale = std::min(double(W) / frame_w_, double(H) / frame_h_);
    SDL_Rect dst{int((W - frame_w_ * scale) / 2), int((H - frame_h_ * scale) / 2), int(frame_w_ * scale), int(frame_h_ * scale)};
    SDL_RenderCopy(renderer_, frame_, nullptr, &dst);
  }
  for (const HudItem& i : hud) {
    if (i.kind == HudItem::Kind::kFill) {
      SDL_SetRenderDrawColor(renderer_, i.colour.r, i.colour.g, i.colour.b, i.colour.a);
      const SDL_Rect r{i.x, i.y, i.w, i.h};
      SDL_RenderFillRect(renderer_, &r);
      continue;
    }
    if (i.kind == HudItem::Kind::kLine) {
      SDL_SetRenderDrawColor(renderer_, i.colour.r, i.colour.g, i.colour.b, i.colour.a);
      SDL_RenderDrawLine(renderer_, i.x, i.y, i.x + i.w, i.y + i.h);
      continue;
    }
    if (i.text.empty()) continue;
    int w = 0, h = 0;
    if (SDL_Texture* t = text_texture(i, w, h)) {
      const SDL_Rect r{i.x, i.y, w, h};
      SDL_RenderCopy(renderer_, t, nullptr, &r);
    }
  }
  if (capture) *capture = read_pixels();  // before presenting: the back buffer is undefined after it
  SDL_RenderPresent(renderer_);
  // Texts not drawn for a while go: the cache holds what is on screen, not every speed shown.
  for (auto it = cache_.begin(); it != cache_.end();) {
    if (generation_ - it->second.used > 30) {
      SDL_DestroyTexture(it->second.texture);
      it = cache_.erase(it);
    } else {
      ++it;
    }
  }
}

Image CabWindow::read_pixels() {
  Image img;
  img.width = width();
  img.height = height();
  img.rgb.resize(size_t(img.width) * img.height * 3);
  if (SDL_RenderReadPixels(renderer_, nullptr, SDL_PIXELFORMAT_RGB24, img.rgb.data(), img.width * 3) != 0)
    throw std::runtime_error(std::string("cannot read the window's pixels: ") + SDL_GetError());
  return img;
}

}  // namespace forklift::cab
