#include "frame_view.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>

namespace forklift {
namespace {

// A frame whose size or encoding does not add up is counted and dropped, never shown.
bool decode(const fk_Frame& f, Image& out) {
  const std::string enc = f.encoding;
  try {
    if (enc == "rgb8") {
      const size_t n = size_t(f.width) * f.height * 3;
      if (f.width == 0 || f.height == 0 || f.pixels._length != n) return false;
      out.width = f.width;
      out.height = f.height;
      out.rgb.assign(f.pixels._buffer, f.pixels._buffer + n);
      return true;
    }
    if (enc == "jpeg") {
      out = decode_jpeg(f.pixels._buffer, f.pixels._length);
      return true;
    }
  } catch (const std::exception& e) {
    std::cerr << "forklift-cab: bad frame " << f.seq << ": " << e.what() << '\n';
  }
  return false;
}

}  // namespace

FrameView::Source FrameView::worker_frames(dds::Participant& participant, const std::string& cab) {
  auto reader = std::make_shared<dds::Reader<fk_Frame>>(participant, dds::cab_partition(cab));
  return [reader, cab](Image& picture, double& sim_time_s) {
    bool fresh = false;
    reader->take_each([&](const fk_Frame& f) {
      if (cab != f.cab_id || !decode(f, picture)) return;
      fresh = true;
      sim_time_s = f.sim_time_s;
    });
    return fresh;
  };
}

FrameView::FrameView(Source source, Options opt) : source_(std::move(source)), opt_(std::move(opt)) {
  if (!opt_.save_dir.empty()) std::filesystem::create_directories(opt_.save_dir);
}

FrameView::~FrameView() = default;

bool FrameView::poll() {
  double t = last_sim_time_s_;
  const bool fresh = source_(last_, t);
  if (fresh) {
    last_sim_time_s_ = t;
    ++frames_;
    ++window_frames_;
    if (!opt_.save_dir.empty() && frames_ % opt_.save_every == 1 % opt_.save_every) {
      char name[32];
      std::snprintf(name, sizeof name, "/frame_%06ld.png", frames_);
      write_png(opt_.save_dir + name, last_);
    }
  }
  const auto now = std::chrono::steady_clock::now();
  const double span = std::chrono::duration<double>(now - window_start_).count();
  if (span >= 1.0) {
    fps_ = window_frames_ / span;
    window_frames_ = 0;
    window_start_ = now;
  }
  return fresh;
}

double FrameView::fps() const { return fps_; }

void FrameView::finish() {
  if (!opt_.save_last.empty() && last_.width > 0) write_png(opt_.save_last, last_);
}

}  // namespace forklift
