// The evaluation allocates nothing on a tick without an event (as Drake proves of its
// evaluations): this binary counts every operator new made in the evaluation stage of step().
#include <atomic>
#include <cstdlib>
#include <new>

#include "evaluation/harness.h"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};

void* counted(std::size_t n, std::size_t align = 0) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1, std::memory_order_relaxed);
  void* p = align ? std::aligned_alloc(align, (n + align - 1) / align * align) : std::malloc(n ? n : 1);
  if (!p) throw std::bad_alloc();
  return p;
}
}  // namespace

void* operator new(std::size_t n) { return counted(n); }
void* operator new[](std::size_t n) { return counted(n); }
void* operator new(std::size_t n, std::align_val_t a) { return counted(n, std::size_t(a)); }
void* operator new[](std::size_t n, std::align_val_t a) { return counted(n, std::size_t(a)); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace {

using namespace evt;

// Counts the allocations made inside the evaluation stage of the session's step.
struct CountEvaluation : StageObserver {
  void begin(Stage s) override {
    if (s == Stage::kEvaluation) { g_allocations = 0; g_counting = true; }
  }
  void end(Stage s) override {
    if (s == Stage::kEvaluation) { g_counting = false; total += g_allocations; }
  }
  long total = 0;
};

// Drives `seconds` along y = `lane` at `v` through the session's step, counting the allocations
// made by the evaluation only.
long allocations_while_driving(Session& s, double lane, double v, double seconds) {
  Driver d{s};
  d.lift_to = 0.2;
  CountEvaluation counter;
  for (int64_t end = s.ticks + int64_t(seconds / Session::kTick); s.ticks < end;) {
    if (s.ticks % 10 == 0) {
      Controls c = d.levers();
      d.speed(c, v);
      c.steer_rad = d.steer_to_line(lane);
      s.set(c);
    }
    s.tick(&counter);
  }
  return counter.total;
}

TEST(Allocation, ATickWithoutAnEventAllocatesNothing) {
  Session yard(scene("zones.json"));
  EXPECT_EQ(allocations_while_driving(yard, 0, 1.0, 6.0), 0);
  EXPECT_TRUE(yard.events.empty()) << yard.summary();

  // The warehouse: 13 zones, a route, a task, about 70 objects; on the first tick the evaluator
  // sizes its per-pallet state once.
  Session warehouse(load_scene(data("scenarios/practical_exam.json"), FORKLIFT_DATA_DIR));
  allocations_while_driving(warehouse, 4.5, 0.5, 0.01);
  EXPECT_EQ(allocations_while_driving(warehouse, 4.5, 1.0, 3.0), 0);
  EXPECT_TRUE(warehouse.events.empty()) << warehouse.summary();
}

TEST(Allocation, TheCounterSeesAnEventsAllocations) {
  Session s(scene("zones.json"));
  EXPECT_GT(allocations_while_driving(s, 0, 3.4, 6.0), 0);  // over the yard's limit: an event
  EXPECT_EQ(s.count("speed_open_aisle"), 1) << s.summary();
}

}  // namespace
