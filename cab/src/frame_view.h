// The cab's picture: Frames from its worker, decoded, shown in a window (SDL2) when a display
// is present, and saved as PNG when asked.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include "forklift/protocol/protocol.h"
#include "forklift/image/image.h"

namespace forklift {

class FrameView {
 public:
  struct Options {
    bool window = false;            // open a window (needs a display)
    std::string save_last;          // PNG of the newest frame, written at exit
    std::string save_dir;           // every `save_every`-th frame as DIR/frame_NNNNNN.png
    int save_every = 30;
  };
  FrameView(dds::Participant& participant, const std::string& cab, Options opt);
  ~FrameView();
  // Takes what arrived, shows and saves it; false when the window was closed.
  bool poll();
  long frames() const { return frames_; }
  double fps() const;  // frames received per second over the last second or so
  void finish();       // writes save_last

 private:
  bool decode(const fk_Frame& f);
  void show();

  dds::Reader<fk_Frame> reader_;
  std::string cab_;
  Options opt_;
  Image last_;
  long frames_ = 0, bad_ = 0;
  long window_frames_ = 0;
  std::chrono::steady_clock::time_point window_start_ = std::chrono::steady_clock::now();
  double fps_ = 0;
  struct Window;
  std::unique_ptr<Window> window_;
};

}  // namespace forklift
