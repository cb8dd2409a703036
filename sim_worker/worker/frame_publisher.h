// The worker's frames (forklift-worker): rendered on their own clock in their own thread, only
// while the cab asks for them, and published to the cab's partition.
#pragma once

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "control_intake.h"
#include "forklift/protocol/aids.h"
#include "forklift/protocol/protocol.h"
#include "forklift/render/loader.h"
#include "forklift/session/session.h"

namespace forklift::worker {

// Frames on their own clock, only while the cab asks for them (its newest control sample has
// frames_wanted; a scripted or windowless cab, and a silent one, get none) and something reads
// them (no frame reader matched: no frame drawn): the render thread owns
// the OSMesa context (made when frames are first wanted), draws the newest snapshot the physics
// loop left as the cab asked to see it, within the aids granted, and publishes it. A renderer that
// cannot start costs the session its frames, never the session.
class FramePublisher {
 public:
  // The render thread's nice value: a weight of 110 against a tick's 1024. At 19 (a weight of 15)
  // a session's first frame, 0.3 s of work, took minutes beside eight busy processes.
  static constexpr int kRenderNice = 10;
  struct Options {
    double fps = 30;
    int width = 640, height = 480;
    bool jpeg = false;
    int jpeg_quality = 85;
    RenderQuality quality;  // the depth cues drawn (shadow map size, haze): the picture's cost
    View view = View::kDriver;  // the cab's camera 0 (the driver's eye unless --view says otherwise)
    uint8_t aids = 0;           // granted: aids::Bit
  };
  // What the cab asks to see (its newest good control sample); nullopt: no frames.
  struct Request {
    int camera = 0;
    ViewOptions view;
  };
  static std::optional<Request> request_of(const std::optional<ControlIntake::ViewRequest>& v) {
    if (!v) return std::nullopt;
    return Request{v->camera, {v->look_yaw_rad, v->look_pitch_rad, v->see_through_mast, v->rear_view, v->fork_camera}};
  }
  // `say`: how a renderer that cannot start is told (the worker's stderr).
  FramePublisher(const SessionModel& model, dds::Participant& participant, const std::string& cab, Options opt,
                 std::function<void(const std::string&)> say)
      : model_(model), writer_(participant, dds::cab_partition(cab)), cab_(cab), opt_(opt), say_(std::move(say)) {}
  ~FramePublisher() { stop(); }

  void start() {
    if (opt_.fps <= 0) return;
    // llvmpipe rasterises in this render thread, not on threads of its own (one per core), unless
    // LP_NUM_THREADS says otherwise: with a worker per cab the cores are already shared, and in
    // eight framed cabs on two cores each got 25-28 frames a second this way against 18-23 with
    // llvmpipe's threads (forklift-bench-dds --framed-fleet 8, on a busy shared machine). Read
    // when the first context is made.
    setenv("LP_NUM_THREADS", "0", 0);
    thread_ = std::thread([this] {
      // Frames give way to physics: on a machine with fewer cores than busy threads the tick
      // loop (and with it the cab's controls taking effect) must not wait behind a frame. A nice
      // value, not SCHED_IDLE: an idle thread runs only when nothing else wants the core, so a
      // host kept busy by other work froze every cab's picture (one frame in three minutes beside
      // six busy processes); at nice 10 it slows instead. A tick at --realtime is SCHED_FIFO,
      // above any nice value; a normal one wakes ahead of it (a lower priority needs no privilege).
      setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), kRenderNice);
      run();
    });
  }
  // Called by the physics loop when the truck has moved (cheap: a copy under a lock).
  void offer(const SessionState& s) {
    if (opt_.fps <= 0) return;
    std::lock_guard<std::mutex> lock(m_);
    state_.q = coordinates_of(s);
    state_.pallets = s.handling.pallets();
    state_.pedestrians = s.pedestrians;
    state_.trucks = s.trucks;
    t_ = s.t_s;
  }
  // The cab's wish: frames as `r` asks, or none (nullopt). Aids not granted are ignored.
  void ask(const std::optional<Request>& r) {
    if (opt_.fps <= 0) return;
    {
      std::lock_guard<std::mutex> lock(m_);
      request_ = r;
    }
    cv_.notify_all();
  }
  void stop() {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  long frames() const { return frames_; }

  // The picture a request gets with these aids granted: an aid not granted is not drawn.
  static std::pair<View, ViewOptions> granted(const Request& r, View camera0, uint8_t aids) {
    return granted_view(r.camera, r.view, camera0, aids);
  }

 private:
  void run() {
    std::unique_ptr<FrameRenderer> renderer;
    const auto period = std::chrono::duration<double>(1.0 / opt_.fps);
    auto next = std::chrono::steady_clock::now();
    std::unique_lock<std::mutex> lock(m_);
    while (!stop_) {
      cv_.wait(lock, [this] { return stop_ || request_.has_value(); });  // idle while nobody looks
      if (stop_) break;
      cv_.wait_until(lock, next, [this] { return stop_; });
      if (stop_) break;
      if (!request_) continue;  // the cab stopped asking meanwhile
      if (writer_.matched() == 0) continue;  // nobody reads frames (a cab asking, but gone or blind): none drawn
      next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
      if (next < std::chrono::steady_clock::now()) next = std::chrono::steady_clock::now();  // a slow frame skips, never queues
      const RenderState state = state_;
      const double t = t_;
      const auto [view, options] = granted(*request_, opt_.view, opt_.aids);
      lock.unlock();
      if (!renderer) {
        try {
          renderer = load_renderer(model_.scene, model_.shape, model_.truck, opt_.width, opt_.height, opt_.quality);
        } catch (const std::exception& e) {
          say_(std::string("no frames: ") + e.what());
          return;
        }
      }
      if (opt_.jpeg) {
        // The read-back pixels (RGBX) straight into JPEG: no copy to RGB first.
        const RgbxPixels pixels = renderer->render_rgbx(state, view, options);
        publish(pixels.width, pixels.height, encode_jpeg(pixels, opt_.jpeg_quality), "jpeg", t);
      } else {
        const Image& img = renderer->render(state, view, options);
        publish(img.width, img.height, img.rgb, "rgb8", t);
      }
      lock.lock();
    }
  }
  void publish(int width, int height, const std::vector<uint8_t>& bytes, const char* encoding, double t) {
    fk_Frame f{};
    dds::set_string(f.cab_id, cab_);
    f.seq = static_cast<uint32_t>(++frames_);
    f.sim_time_s = t;
    f.width = static_cast<uint16_t>(width);
    f.height = static_cast<uint16_t>(height);
    dds::set_string(f.encoding, encoding);
    f.pixels._buffer = const_cast<uint8_t*>(bytes.data());
    f.pixels._length = f.pixels._maximum = static_cast<uint32_t>(bytes.size());
    f.pixels._release = false;
    writer_.write(f);
  }

  const SessionModel& model_;
  dds::Writer<fk_Frame> writer_;
  std::string cab_;
  Options opt_;
  std::function<void(const std::string&)> say_;
  std::thread thread_;
  std::mutex m_;
  std::condition_variable cv_;
  RenderState state_;
  double t_ = 0;
  std::optional<Request> request_;
  bool stop_ = false;
  std::atomic<long> frames_{0};
};

}  // namespace forklift::worker
