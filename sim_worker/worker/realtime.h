// Real-time priority for a worker's tick (forklift-worker --realtime).
//
// On a simulation PC that also renders every cab's frames, a worker's 1 ms tick competes with
// other workers and their render threads for the cores: at normal priority eight framed cabs on
// two cores saw ticks 4-12 ms late (forklift-bench-dds --framed-fleet 8). SCHED_FIFO for the
// physics loop and for DDS's receive threads (which hand the cab's controls to it) keeps them
// ahead of all normal work; the render thread runs at nice 10, so frames take what is left.
#pragma once

#include <string>

namespace forklift::worker {

// The priority the tick runs at: low among real-time priorities (1-99), so the kernel's own
// real-time threads stay above it.
constexpr int kRealtimePriority = 10;

// SCHED_FIFO at kRealtimePriority for the calling thread and this process's DDS receive threads.
// Needs CAP_SYS_NICE or an RLIMIT_RTPRIO of at least the priority (systemd: LimitRTPRIO=10);
// returns "" when granted, else why not, in words (the worker then runs on at normal priority).
std::string enter_realtime();

// The calling thread back to normal priority: the session's end (its mark, the log's signature,
// files) is no real-time work and must not hold up other workers' ticks.
void leave_realtime();

}  // namespace forklift::worker
