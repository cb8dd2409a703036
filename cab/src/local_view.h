// The cab's own picture (forklift-cab --render local), for a cab with a graphics card: the
// scenario's scene drawn here by the worker's renderer from what moves in it (the worker's
// SceneMotion samples), with the same cameras, aids and quality as the worker's frames, as often
// as the scene moves or the pupil looks elsewhere. The worker then draws no frames for this cab;
// its frames stay the default for thin cabs and for the instructor's view.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "forklift/image/image.h"
#include "forklift/protocol/protocol.h"
#include "forklift/render/loader.h"
#include "forklift/session/session.h"

namespace forklift {

// What the worker's frames would draw for this sample of the scene's motion.
RenderState render_state_of(const fk_SceneMotion& motion);

class LocalView {
 public:
  // Loads the scenario as the worker does (throws std::runtime_error naming the file and the
  // problem); the renderer is made with the first picture.
  LocalView(dds::Participant& participant, const std::string& cab, const std::string& scenario_file,
            const std::string& data_dir, int width, int height);
  ~LocalView();
  // What the pupil looks at: the camera and view the cab's controls ask for, and the aids the
  // worker grants (TruckState.aids).
  void ask(int camera, const ViewOptions& view, uint8_t aids);
  // FrameView's source: a new picture when the scene moved or the pupil looks elsewhere.
  bool draw(Image& picture, double& sim_time_s);
  long motions() const { return motions_; }

 private:
  dds::Reader<fk_SceneMotion> reader_;
  std::string cab_;
  SessionModel model_;
  int width_, height_;
  std::unique_ptr<FrameRenderer> renderer_;
  std::optional<RenderState> state_;
  double sim_time_s_ = -1;
  bool moved_ = false;
  int camera_ = 0;
  ViewOptions view_;
  uint8_t aids_ = 0;
  bool view_changed_ = true;
  bool failed_ = false;  // the renderer could not start: no picture, said once
  long motions_ = 0;
};

}  // namespace forklift
