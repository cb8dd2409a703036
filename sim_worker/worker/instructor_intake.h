// The worker's intake of the instructor's actions (fk_InstructorAction, from the server in the
// cab's instructor partition): which are believed and acted on, once each and in order. A sample
// for another session (an earlier one on this cab, kept by the topic's durability) is passed over;
// one that is not well-formed text, not newer than the last taken, not for this cab, an action
// this session cannot take (any, in an exam; a pause while paused, a resume while running), a
// message the display cannot show, or a rewind by anything but a number of seconds in (0, 3600],
// is refused, counted and said. No DDS: the worker hands in each
// sample it takes, the tests hand in their own.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "forklift/protocol/protocol.h"
#include "forklift/session/session_log.h"
#include "forklift/session/vocabulary.h"

namespace forklift::worker {

class InstructorIntake {
 public:
  static constexpr long kRefusalsSaid = 5;

  // `message_max_chars`: data/session.json's instructor.message_max_chars; `say`: the worker's stderr.
  InstructorIntake(std::string cab, std::string session, Mode mode, size_t message_max_chars,
                   std::function<void(const std::string&)> say);

  // The instruction `a` asks for, to act on now with the session `paused` as it is; nullopt when
  // it is passed over or refused.
  std::optional<Instruction> offer(const fk_InstructorAction& a, bool paused);
  // An action taken, then found impossible by the worker (a rewind further back than it keeps):
  // refused, counted and said as the others.
  void refuse(uint64_t seq, const std::string& why);

  long taken() const { return taken_; }
  long refused() const { return refused_; }
  long other_sessions() const { return other_sessions_; }

 private:
  std::optional<std::string> problem(const fk_InstructorAction& a, bool paused, Instruction& out) const;

  std::string cab_, session_;
  Mode mode_;
  size_t message_max_chars_;
  std::function<void(const std::string&)> say_;
  uint64_t last_seq_ = 0;
  long taken_ = 0, refused_ = 0, other_sessions_ = 0;
};

}  // namespace forklift::worker
