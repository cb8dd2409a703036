// The cab's picture: the newest one shown in the window, from the worker's Frames (decoded) or
// drawn in the cab itself (--render local, local_view.h), and saved as PNG when asked.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include "forklift/protocol/protocol.h"
#include "forklift/image/image.h"

namespace forklift {

class FrameView {
 public:
  struct Options {
    std::string save_last;          // PNG of the newest frame, written at exit
    std::string save_dir;           // every `save_every`-th frame as DIR/frame_NNNNNN.png
    int save_every = 30;
  };
  // Where pictures come from: true with a new one in `picture` (and its sim time) when there is one.
  using Source = std::function<bool(Image& picture, double& sim_time_s)>;
  // The worker's frames for this cab (a frame whose size or encoding does not add up is dropped).
  static Source worker_frames(dds::Participant& participant, const std::string& cab);

  FrameView(Source source, Options opt);
  ~FrameView();
  // Takes what arrived and saves it; true when a new frame was decoded (last()).
  bool poll();
  const Image& last() const { return last_; }
  double last_sim_time_s() const { return last_sim_time_s_; }
  long frames() const { return frames_; }
  double fps() const;  // frames received per second over the last second or so
  void finish();       // writes save_last

 private:
  Source source_;
  Options opt_;
  Image last_;
  long frames_ = 0;
  long window_frames_ = 0;
  std::chrono::steady_clock::time_point window_start_ = std::chrono::steady_clock::now();
  double fps_ = 0;
  double last_sim_time_s_ = -1;
};

}  // namespace forklift
