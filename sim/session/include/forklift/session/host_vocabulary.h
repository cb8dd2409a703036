// The worker hosts' protocol words, in the session vocabulary's form (name() and parse(),
// vocabulary.h): a host's state (fk_HostStatus.state), what a server asks of it for a session's
// worker (fk_WorkerRequest.action), and what became of that worker (fk_WorkerReport.state). The
// IDL carries them as strings, produced and parsed here only, by forklift-host and the server.
#pragma once

#include "forklift/session/vocabulary.h"

namespace forklift {

enum class HostState { kReady, kStopping };  // "ready"; "stopping": it takes no new worker
enum class WorkerAction {
  kStart,  // "start"
  kAbort,  // "abort": the instructor's (the worker ends its session as aborted)
  kKill,   // "kill": hung, or its session is over
};
enum class WorkerReportState {
  kStarting,  // "starting": started, its participant not yet known
  kRunning,   // "running"
  kExited,    // "exited": with its files
  kRefused,   // "refused": not started, and why
};

const char* name(HostState state);
const char* name(WorkerAction action);
const char* name(WorkerReportState state);
template <> std::optional<HostState> parse<HostState>(std::string_view name);
template <> std::optional<WorkerAction> parse<WorkerAction>(std::string_view name);
template <> std::optional<WorkerReportState> parse<WorkerReportState>(std::string_view name);

}  // namespace forklift
