// The fleet's sample gate with fabricated samples: for each of the seven topics the server reads,
// forged ones (the wrong writer, the wrong partition, no identity), malformed ones (not UTF-8,
// not finite, out of range) and good ones. No DDS: the gate's world is a table of who may speak
// for which session and who each writer is.
#include "sample_gate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <memory>

namespace forklift::server {
namespace {

const std::string kWorkerGuid = "0123456789abcdef0123456789abcdef";  // the worker of cab1's session s-1
const std::string kOtherGuid = "fedcba9876543210fedcba9876543210";
const std::string kNotUtf8 = "\xff\xfe";
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The writers the tests forge, by publication handle.
enum Writer : dds_instance_handle_t {
  kWorker = 1,         // cab1's worker, in its worker partition
  kWorkerInCab,        // cab1's worker, in its cab's partition (where its truck states go)
  kForger,             // another participant in cab1's worker partition
  kWorkerElsewhere,    // cab1's worker's participant, in cab2's worker partition
  kForgerInCab,        // another participant in cab1's cab partition
  kHost1,              // worker host h1, in its partition
  kHost2,              // worker host h2, in its partition
  kCab1,               // cab cab1, in its partition
  kCab2,               // cab cab2, in its partition
  kUnknown = 99,       // a writer discovery does not vouch for
};

struct Refusal {
  RefusalCounter counter;
  std::string what;
};

class FakeWorld : public GateWorld {
 public:
  FakeWorld() {
    speakers["s-1"] = {Speaker::Known::kYes, "cab1", kWorkerGuid};
    speakers["s-2"] = {Speaker::Known::kNotYet, "", ""};
    speakers["s-4"] = {Speaker::Known::kYes, "cab1", ""};  // a log with no participant in it
    senders[kWorker] = {kWorkerGuid, {dds::worker_partition("cab1")}};
    senders[kWorkerInCab] = {kWorkerGuid, {dds::cab_partition("cab1")}};
    senders[kForger] = {kOtherGuid, {dds::worker_partition("cab1")}};
    senders[kWorkerElsewhere] = {kWorkerGuid, {dds::worker_partition("cab2")}};
    senders[kForgerInCab] = {kOtherGuid, {dds::cab_partition("cab1")}};
    senders[kHost1] = {kOtherGuid, {dds::host_partition("h1")}};
    senders[kHost2] = {kOtherGuid, {dds::host_partition("h2")}};
    senders[kCab1] = {kOtherGuid, {dds::cab_partition("cab1")}};
    senders[kCab2] = {kOtherGuid, {dds::cab_partition("cab2")}};
  }
  bool hosts_believed() const override { return believe_hosts; }
  Speaker speaker(const std::string& session) override {
    const auto it = speakers.find(session);
    return it == speakers.end() ? Speaker{} : it->second;
  }
  std::optional<dds::Sender> discover(dds_entity_t, dds_instance_handle_t publication) override {
    const auto it = senders.find(publication);
    if (it == senders.end()) return std::nullopt;
    return it->second;
  }
  void refuse(RefusalCounter counter, const std::string& what) override { refusals.push_back({counter, what}); }

  bool believe_hosts = true;
  std::map<std::string, Speaker> speakers;
  std::map<dds_instance_handle_t, dds::Sender> senders;
  std::vector<Refusal> refusals;
};

dds_sample_info_t from(dds_instance_handle_t writer, bool valid = true) {
  dds_sample_info_t info{};
  info.valid_data = valid;
  info.instance_state = DDS_IST_ALIVE;
  info.publication_handle = writer;
  return info;
}

// One row: what is offered, and what the gate must make of it.
struct Case {
  const char* name;
  std::function<bool(SampleGate&, FakeWorld&)> offer;  // true: let in
  RefusalCounter refused = nullptr;  // nullptr: let in, or dropped uncounted (`in` says which)
  const char* why = "";              // a part of the refusal's words
  bool in = false;
};

void run(const std::vector<Case>& cases) {
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    FakeWorld world;
    SampleGate gate(world);
    const bool in = c.offer(gate, world);
    EXPECT_EQ(in, c.in);
    if (!c.refused) {
      EXPECT_TRUE(world.refusals.empty()) << world.refusals.front().what;
      continue;
    }
    ASSERT_EQ(world.refusals.size(), 1u);
    EXPECT_TRUE(world.refusals[0].counter == c.refused) << world.refusals[0].what;
    EXPECT_NE(world.refusals[0].what.find(c.why), std::string::npos) << world.refusals[0].what;
  }
}

const auto kWrongSender = &RefusedSamples::wrong_sender;
const auto kMalformed = &RefusedSamples::malformed;
const auto kNoIdentity = &RefusedSamples::no_identity;

// --- fk_Event ---

fk_Event event(const std::string& session = "s-1") {
  fk_Event e{};
  dds::set_string(e.session_id, session);
  e.seq = 3;
  e.sim_time_s = 12.5;
  dds::set_string(e.kind, "collision");
  e.worry_level = 3;
  e.x_m = 1;
  e.y_m = 2;
  dds::set_string(e.details, "{}");
  return e;
}

template <typename Edit>
std::function<bool(SampleGate&, FakeWorld&)> offer_event(Writer w, Edit edit) {
  return [w, edit](SampleGate& gate, FakeWorld&) {
    fk_Event e = event();
    edit(e);
    return gate.event(e, from(w), 0, SampleGate::Clock::now()).has_value();
  };
}
auto as_is = [](auto&) {};

TEST(SampleGate, Events) {
  run({
      {"good", offer_event(kWorker, as_is), nullptr, "", true},
      {"another participant in the worker's partition", offer_event(kForger, as_is), kWrongSender, "not from its worker"},
      {"the worker's participant in another cab's partition", offer_event(kWorkerElsewhere, as_is), kWrongSender, "not from its worker"},
      {"from its cab's partition", offer_event(kWorkerInCab, as_is), kWrongSender, "for session s-1"},
      {"a writer discovery does not know", offer_event(kUnknown, as_is), kWrongSender, "not from its worker"},
      {"a session whose log names no participant", [](SampleGate& g, FakeWorld&) {
         return g.event(event("s-4"), from(kWorker), 0, SampleGate::Clock::now()).has_value();
       }, kWrongSender, "s-4"},
      {"another server's session", [](SampleGate& g, FakeWorld&) {
         return g.event(event("s-3"), from(kWorker), 0, SampleGate::Clock::now()).has_value();
       }},
      {"session not UTF-8", offer_event(kWorker, [](fk_Event& e) { dds::set_string(e.session_id, kNotUtf8); }), kMalformed,
       "fk_Event whose session is not UTF-8"},
      {"kind not UTF-8", offer_event(kWorker, [](fk_Event& e) { dds::set_string(e.kind, kNotUtf8); }), kMalformed, "its kind is not UTF-8"},
      {"details not UTF-8", offer_event(kWorker, [](fk_Event& e) { dds::set_string(e.details, kNotUtf8); }), kMalformed,
       "its details is not UTF-8"},
      {"time not finite", offer_event(kWorker, [](fk_Event& e) { e.sim_time_s = kNaN; }), kMalformed, "out of range"},
      {"negative time", offer_event(kWorker, [](fk_Event& e) { e.sim_time_s = -1; }), kMalformed, "out of range"},
      {"position not finite", offer_event(kWorker, [](fk_Event& e) { e.y_m = INFINITY; }), kMalformed, "out of range"},
      {"sequence 0", offer_event(kWorker, [](fk_Event& e) { e.seq = 0; }), kMalformed, "event 0 of session s-1"},
      {"worry level 6", offer_event(kWorker, [](fk_Event& e) { e.worry_level = 6; }), kMalformed, "out of range"},
      {"no kind", offer_event(kWorker, [](fk_Event& e) { e.kind[0] = 0; }), kMalformed, "out of range"},
  });
}

TEST(SampleGate, EventValue) {
  FakeWorld world;
  SampleGate gate(world);
  const auto e = gate.event(event(), from(kWorker), 0, SampleGate::Clock::now());
  ASSERT_TRUE(e);
  EXPECT_EQ(e->session_public_id, "s-1");
  EXPECT_EQ(e->seq, 3);
  EXPECT_EQ(e->kind, "collision");
  EXPECT_EQ(e->worry_level, 3);
  EXPECT_DOUBLE_EQ(e->sim_time_s, 12.5);
}

// A hosted worker's event before its host has named its participant waits in the gate, comes in
// once it is named, and is refused if it never is.
TEST(SampleGate, EventsWaitForTheirWorkerToBeNamed) {
  FakeWorld world;
  SampleGate gate(world);
  const auto t0 = SampleGate::Clock::now();
  EXPECT_FALSE(gate.event(event("s-2"), from(kWorker), 0, t0));
  EXPECT_EQ(gate.held(), 1u);
  EXPECT_TRUE(world.refusals.empty());
  // Still unknown a second later: it waits on.
  auto held = gate.take_held();
  EXPECT_TRUE(gate.events_again(held.events, t0 + std::chrono::seconds(1)).empty());
  EXPECT_EQ(gate.held(), 1u);
  // Named: it comes in.
  world.speakers["s-2"] = {Speaker::Known::kYes, "cab1", kWorkerGuid};
  held = gate.take_held();
  const auto in = gate.events_again(held.events, t0 + std::chrono::seconds(2));
  ASSERT_EQ(in.size(), 1u);
  EXPECT_EQ(in[0].session_public_id, "s-2");
  EXPECT_EQ(gate.held(), 0u);
  EXPECT_TRUE(world.refusals.empty());

  // Never named: refused once it has waited kWait since it first came.
  world.speakers["s-2"] = {Speaker::Known::kNotYet, "", ""};
  EXPECT_FALSE(gate.event(event("s-2"), from(kWorker), 0, t0));
  held = gate.take_held();
  EXPECT_TRUE(gate.events_again(held.events, t0 + SampleGate::kWait - std::chrono::seconds(1)).empty());
  held = gate.take_held();
  EXPECT_TRUE(gate.events_again(held.events, t0 + SampleGate::kWait + std::chrono::seconds(1)).empty());
  EXPECT_EQ(gate.held(), 0u);
  ASSERT_EQ(world.refusals.size(), 1u);
  EXPECT_TRUE(world.refusals[0].counter == kWrongSender);
  EXPECT_NE(world.refusals[0].what.find("whose worker host never named its worker"), std::string::npos);
}

// --- fk_Score ---

struct ScoreSample {
  fk_Score s{};
  fk_FaultCount counts[2]{};
  ScoreSample() {
    dds::set_string(s.session_id, "s-1");
    s.mark = 82.5;
    s.passed = true;
    dds::set_string(counts[0].kind, "collision");
    counts[0].count = 1;
    dds::set_string(counts[1].kind, "overspeed");
    counts[1].count = 2;
    s.counts._length = s.counts._maximum = 2;
    s.counts._buffer = counts;
  }
};

template <typename Edit>
std::function<bool(SampleGate&, FakeWorld&)> offer_score(Writer w, Edit edit) {
  return [w, edit](SampleGate& gate, FakeWorld&) {
    ScoreSample sample;
    edit(sample);
    return gate.score(sample.s, from(w), 0).has_value();
  };
}

TEST(SampleGate, Scores) {
  run({
      {"good", offer_score(kWorker, as_is), nullptr, "", true},
      {"another participant", offer_score(kForger, as_is), kWrongSender, "fk_Score for session s-1 not from its worker"},
      {"another cab's partition", offer_score(kWorkerElsewhere, as_is), kWrongSender, "not from its worker"},
      {"a hosted worker not named yet: dropped, not held", [](SampleGate& g, FakeWorld&) {
         ScoreSample sample;
         dds::set_string(sample.s.session_id, "s-2");
         const bool in = g.score(sample.s, from(kWorker), 0).has_value();
         return in || g.held() > 0;
       }},
      {"mark not finite", offer_score(kWorker, [](ScoreSample& x) { x.s.mark = kNaN; }), kMalformed, "a mark of"},
      {"mark over 100", offer_score(kWorker, [](ScoreSample& x) { x.s.mark = 100.5; }), kMalformed, "a mark of 100.5"},
      {"negative mark", offer_score(kWorker, [](ScoreSample& x) { x.s.mark = -1; }), kMalformed, "a mark of"},
      {"fault kind not UTF-8", offer_score(kWorker, [](ScoreSample& x) { dds::set_string(x.counts[1].kind, kNotUtf8); }), kMalformed,
       "a fault kind that is not UTF-8"},
      {"session not UTF-8", offer_score(kWorker, [](ScoreSample& x) { dds::set_string(x.s.session_id, kNotUtf8); }), kMalformed,
       "fk_Score whose session is not UTF-8"},
  });
  FakeWorld world;
  SampleGate gate(world);
  ScoreSample sample;
  const auto r = gate.score(sample.s, from(kWorker), 0);
  ASSERT_TRUE(r);
  EXPECT_DOUBLE_EQ(r->mark, 82.5);
  EXPECT_TRUE(r->passed);
  EXPECT_EQ(r->counts.at("overspeed"), 2);
}

// --- fk_SessionStatus ---

fk_SessionStatus status(const std::string& state, const std::string& session = "s-1") {
  fk_SessionStatus s{};
  dds::set_string(s.session_id, session);
  dds::set_string(s.cab_id, "cab1");
  dds::set_string(s.state, state);
  dds::set_string(s.reason, "time_limit");
  return s;
}

std::function<bool(SampleGate&, FakeWorld&)> offer_status(Writer w, fk_SessionStatus s) {
  return [w, s](SampleGate& gate, FakeWorld&) { return gate.status(s, from(w), 0, SampleGate::Clock::now()).has_value(); };
}

TEST(SampleGate, Statuses) {
  fk_SessionStatus bad_reason = status("ended");
  dds::set_string(bad_reason.reason, kNotUtf8);
  fk_SessionStatus bad_state = status("ended");
  dds::set_string(bad_state.state, kNotUtf8);
  fk_SessionStatus odd_language = status("running");  // the cab's to judge: the server reads none
  dds::set_string(odd_language.language, "xx");
  fk_SessionStatus bad_language = status("running");
  dds::set_string(bad_language.language, kNotUtf8);
  run({
      {"running", offer_status(kWorker, status("running")), nullptr, "", true},
      {"ended", offer_status(kWorker, status("ended")), nullptr, "", true},
      {"a state only the server sets: dropped", offer_status(kWorker, status("aborted"))},
      {"another participant", offer_status(kForger, status("ended")), kWrongSender, "fk_SessionStatus for session s-1"},
      {"from its cab's partition", offer_status(kWorkerInCab, status("ended")), kWrongSender, "not from its worker"},
      {"reason not UTF-8", offer_status(kWorker, bad_reason), kMalformed, "its reason is not UTF-8"},
      {"state not UTF-8", offer_status(kWorker, bad_state), kMalformed, "its state is not UTF-8"},
      {"a language no cab has", offer_status(kWorker, odd_language), nullptr, "", true},
      {"language not UTF-8", offer_status(kWorker, bad_language), kMalformed, "its language is not UTF-8"},
      {"session not UTF-8", offer_status(kWorker, status("ended", kNotUtf8)), kMalformed, "whose session is not UTF-8"},
  });
  FakeWorld world;
  SampleGate gate(world);
  const auto s = gate.status(status("failed"), from(kWorker), 0, SampleGate::Clock::now());
  ASSERT_TRUE(s);
  EXPECT_EQ(s->session, "s-1");
  EXPECT_EQ(s->state, SessionPhase::kFailed);
  EXPECT_EQ(s->reason, "time_limit");
  // A hosted worker's status waits for its participant, like its events.
  EXPECT_FALSE(gate.status(status("running", "s-2"), from(kWorker), 0, SampleGate::Clock::now()));
  EXPECT_EQ(gate.held(), 1u);
  world.speakers["s-2"] = {Speaker::Known::kYes, "cab1", kWorkerGuid};
  auto held = gate.take_held();
  const auto again = gate.statuses_again(held.statuses, SampleGate::Clock::now());
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].state, SessionPhase::kRunning);
}

// --- fk_TruckState ---

template <typename Edit>
std::function<bool(SampleGate&, FakeWorld&)> offer_state(Writer w, Edit edit) {
  return [w, edit](SampleGate& gate, FakeWorld&) {
    fk_TruckState t{};
    dds::set_string(t.cab_id, "cab1");
    dds::set_string(t.session_id, "s-1");
    t.sim_time_s = 3;
    t.speed_m_s = 1.5;
    edit(t);
    return gate.truck_state(t, from(w), 0);
  };
}

TEST(SampleGate, TruckStates) {
  run({
      {"good, in its cab's partition", offer_state(kWorkerInCab, as_is), nullptr, "", true},
      {"in the worker partition", offer_state(kWorker, as_is), kWrongSender, "fk_TruckState for session s-1 not from its worker"},
      {"another participant in the cab's partition", offer_state(kForgerInCab, as_is), kWrongSender, "not from its worker"},
      {"position not finite", offer_state(kWorkerInCab, [](fk_TruckState& t) { t.x_m = kNaN; }), kMalformed,
       "a truck state that is not finite"},
      {"speed not finite", offer_state(kWorkerInCab, [](fk_TruckState& t) { t.speed_m_s = INFINITY; }), kMalformed, "not finite"},
      {"lift not finite", offer_state(kWorkerInCab, [](fk_TruckState& t) { t.lift_m = -INFINITY; }), kMalformed, "not finite"},
      {"session not UTF-8", offer_state(kWorkerInCab, [](fk_TruckState& t) { dds::set_string(t.session_id, kNotUtf8); }), kMalformed,
       "whose session is not UTF-8"},
      {"another server's session", offer_state(kWorkerInCab, [](fk_TruckState& t) { dds::set_string(t.session_id, "s-9"); })},
      {"good, with a pedestrian walking", offer_state(kWorkerInCab, [](fk_TruckState& t) { t.pedestrian_count = 1; t.pedestrians[0].activity = 1; }),
       nullptr, "", true},
      {"good, with another truck giving way", offer_state(kWorkerInCab, [](fk_TruckState& t) { t.truck_count = 1; t.trucks[0].activity = 2; }),
       nullptr, "", true},
      {"good, with a pallet falling and a spill on the floor",
       offer_state(kWorkerInCab, [](fk_TruckState& t) { t.falls_started = 2; t.spills_on_floor = 1; }), nullptr, "", true},
      {"a pallet down that never fell", offer_state(kWorkerInCab, [](fk_TruckState& t) { t.falls_started = 1; t.falls_landed = 3; }),
       kMalformed, "a pallet on the floor that never left its beams"},
      {"more other trucks than the array holds", offer_state(kWorkerInCab, [](fk_TruckState& t) { t.truck_count = 5; }), kMalformed,
       "more other trucks than it holds"},
      {"another truck of no known activity", offer_state(kWorkerInCab, [](fk_TruckState& t) { t.truck_count = 1; t.trucks[0].activity = 5; }),
       kMalformed, "another truck not finite, of no known activity"},
      {"more pedestrians than the array holds", offer_state(kWorkerInCab, [](fk_TruckState& t) { t.pedestrian_count = 17; }), kMalformed,
       "more pedestrians than it holds"},
      {"a pedestrian not finite", offer_state(kWorkerInCab, [](fk_TruckState& t) { t.pedestrian_count = 2; t.pedestrians[1].y_m = kNaN; }),
       kMalformed, "a pedestrian not finite"},
      {"a pedestrian of no known activity", offer_state(kWorkerInCab, [](fk_TruckState& t) { t.pedestrian_count = 1; t.pedestrians[0].activity = 4; }),
       kMalformed, "of no known activity"},
      {"a pedestrian's id not UTF-8", offer_state(kWorkerInCab, [](fk_TruckState& t) {
         t.pedestrian_count = 1;
         dds::set_string(t.pedestrians[0].id, kNotUtf8);
       }),
       kMalformed, "whose id is not UTF-8"},
  });
}

// --- fk_CabAnnounce ---

template <typename Edit>
std::function<bool(SampleGate&, FakeWorld&)> offer_announce(Writer w, Edit edit) {
  return [w, edit](SampleGate& gate, FakeWorld&) {
    fk_CabAnnounce a{};
    dds::set_string(a.cab_id, "cab1");
    dds::set_string(a.school, "school");
    dds::set_string(a.mode, "keyboard");
    dds::set_string(a.site, "north");
    edit(a);
    return gate.announce(a, from(w), 0).has_value();
  };
}

TEST(SampleGate, CabAnnouncements) {
  run({
      {"good", offer_announce(kCab1, as_is), nullptr, "", true},
      {"a site not UTF-8 is dropped, the rest kept", offer_announce(kCab1, [](fk_CabAnnounce& a) { dds::set_string(a.site, kNotUtf8); }),
       nullptr, "", true},
      {"from another cab's partition", offer_announce(kCab2, as_is), kWrongSender, "an announcement for cab cab1 from another cab's partition"},
      {"a writer discovery does not know: dropped", offer_announce(kUnknown, as_is)},
      {"no cab id", offer_announce(kCab1, [](fk_CabAnnounce& a) { a.cab_id[0] = 0; }), kMalformed, "a cab announcement with no cab id"},
      {"cab id not UTF-8", offer_announce(kCab1, [](fk_CabAnnounce& a) { dds::set_string(a.cab_id, kNotUtf8); }), kMalformed,
       "its cab id is not UTF-8"},
      {"mode not UTF-8", offer_announce(kCab1, [](fk_CabAnnounce& a) { dds::set_string(a.mode, kNotUtf8); }), kMalformed,
       "its mode is not UTF-8"},
      {"school not UTF-8", offer_announce(kCab1, [](fk_CabAnnounce& a) { dds::set_string(a.school, kNotUtf8); }), kMalformed,
       "its school is not UTF-8"},
  });
  FakeWorld world;
  SampleGate gate(world);
  fk_CabAnnounce a{};
  dds::set_string(a.cab_id, "cab1");
  dds::set_string(a.mode, "script");
  dds::set_string(a.site, "north");
  const auto c = gate.announce(a, from(kCab1), 0);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->id, "cab1");
  EXPECT_EQ(c->mode, "script");
  EXPECT_EQ(c->site, "north");
}

// --- fk_HostStatus ---

template <typename Edit>
std::function<bool(SampleGate&, FakeWorld&)> offer_host(Writer w, Edit edit, bool believed = true, bool valid = true) {
  return [=](SampleGate& gate, FakeWorld& world) {
    world.believe_hosts = believed;
    fk_HostStatus h{};
    dds::set_string(h.host_id, "h1");
    dds::set_string(h.site, "north");
    dds::set_string(h.state, "ready");
    h.capacity = 4;
    h.running = 1;
    h.cores = 8;
    h.load_1min = 0.5;
    h.memory_free_mib = 2048;
    edit(h);
    dds_sample_info_t info = from(w, valid);
    if (!valid) info.instance_state = DDS_IST_NOT_ALIVE_NO_WRITERS;
    return gate.host_status(h, info, 0).has_value();
  };
}

TEST(SampleGate, HostStatuses) {
  run({
      {"good", offer_host(kHost1, as_is), nullptr, "", true},
      {"stopping", offer_host(kHost1, [](fk_HostStatus& h) { dds::set_string(h.state, "stopping"); }), nullptr, "", true},
      {"its writer gone", offer_host(kHost1, as_is, true, false), nullptr, "", true},
      {"in clear DDS, hosts not trusted", offer_host(kHost1, as_is, false), kNoIdentity, "a status of worker host h1 in clear DDS"},
      {"from another host's partition", offer_host(kHost2, as_is), kWrongSender, "a status of worker host h1 from outside its partition"},
      {"from a writer discovery does not know", offer_host(kUnknown, as_is), kWrongSender, "from outside its partition"},
      {"no host id: dropped", offer_host(kHost1, [](fk_HostStatus& h) { h.host_id[0] = 0; })},
      {"host id not UTF-8: dropped", offer_host(kHost1, [](fk_HostStatus& h) { dds::set_string(h.host_id, kNotUtf8); })},
      {"no capacity", offer_host(kHost1, [](fk_HostStatus& h) { h.capacity = 0; }), kMalformed, "a status of worker host h1 out of range"},
      {"unknown state", offer_host(kHost1, [](fk_HostStatus& h) { dds::set_string(h.state, "busy"); }), kMalformed, "out of range"},
      {"state not UTF-8", offer_host(kHost1, [](fk_HostStatus& h) { dds::set_string(h.state, kNotUtf8); }), kMalformed, "out of range"},
      {"site not UTF-8", offer_host(kHost1, [](fk_HostStatus& h) { dds::set_string(h.site, kNotUtf8); }), kMalformed, "out of range"},
      {"load not finite", offer_host(kHost1, [](fk_HostStatus& h) { h.load_1min = kNaN; }), kMalformed, "out of range"},
      {"memory not finite", offer_host(kHost1, [](fk_HostStatus& h) { h.memory_free_mib = INFINITY; }), kMalformed, "out of range"},
  });
  FakeWorld world;
  SampleGate gate(world);
  fk_HostStatus h{};
  dds::set_string(h.host_id, "h1");
  dds::set_string(h.state, "ready");
  h.capacity = 4;
  h.running = 3;
  const auto in = gate.host_status(h, from(kHost1), 0);
  ASSERT_TRUE(in);
  EXPECT_FALSE(in->gone);
  EXPECT_EQ(in->capacity, 4);
  EXPECT_EQ(in->running, 3);
  dds_sample_info_t gone = from(kHost1, false);
  gone.instance_state = DDS_IST_NOT_ALIVE_DISPOSED;
  const auto out = gate.host_status(h, gone, 0);
  ASSERT_TRUE(out);
  EXPECT_TRUE(out->gone);
  EXPECT_FALSE(gate.host_status(h, from(kHost1, false), 0));  // invalid but alive: nothing to say
}

// --- fk_WorkerReport ---

template <typename Edit>
std::function<bool(SampleGate&, FakeWorld&)> offer_report(Writer w, Edit edit, bool believed = true) {
  return [=](SampleGate& gate, FakeWorld& world) {
    world.believe_hosts = believed;
    auto r = std::make_unique<fk_WorkerReport>();
    dds::set_string(r->session_id, "s-12");
    dds::set_string(r->host_id, "h1");
    dds::set_string(r->cab_id, "cab1");
    dds::set_string(r->state, "running");
    dds::set_string(r->participant, kWorkerGuid);
    r->pid = 1234;
    edit(*r);
    return gate.report(*r, from(w), 0);
  };
}

TEST(SampleGate, WorkerReports) {
  run({
      {"running", offer_report(kHost1, as_is), nullptr, "", true},
      {"exited", offer_report(kHost1, [](fk_WorkerReport& r) { dds::set_string(r.state, "exited"); }), nullptr, "", true},
      {"refused, no participant yet", offer_report(kHost1, [](fk_WorkerReport& r) {
         dds::set_string(r.state, "refused");
         r.participant[0] = 0;
       }), nullptr, "", true},
      {"in clear DDS, hosts not trusted", offer_report(kHost1, as_is, false), kNoIdentity,
       "a report of worker host h1 on session s-12 in clear DDS"},
      {"naming no host", offer_report(kHost1, [](fk_WorkerReport& r) { r.host_id[0] = 0; }), kWrongSender, "names no worker host"},
      {"from another host's partition", offer_report(kHost2, as_is), kWrongSender, "a report of worker host h1 from outside its partition"},
      {"from a writer discovery does not know", offer_report(kUnknown, as_is), kWrongSender, "from outside its partition"},
      {"a session id that would name other files", offer_report(kHost1, [](fk_WorkerReport& r) { dds::set_string(r.session_id, "../etc"); }),
       kMalformed, "a report on session '../etc'"},
      {"an unknown state", offer_report(kHost1, [](fk_WorkerReport& r) { dds::set_string(r.state, "sleeping"); }), kMalformed,
       "a report of a worker sleeping"},
      {"a participant that is not a GUID", offer_report(kHost1, [](fk_WorkerReport& r) { dds::set_string(r.participant, "zz"); }),
       kMalformed, "a report naming participant 'zz'"},
      {"reason not UTF-8", offer_report(kHost1, [](fk_WorkerReport& r) { dds::set_string(r.reason, kNotUtf8); }), kMalformed,
       "a fk_WorkerReport sample: its reason is not UTF-8"},
      {"cab not UTF-8", offer_report(kHost1, [](fk_WorkerReport& r) { dds::set_string(r.cab_id, kNotUtf8); }), kMalformed,
       "its cab is not UTF-8"},
      {"host not UTF-8", offer_report(kHost1, [](fk_WorkerReport& r) { dds::set_string(r.host_id, kNotUtf8); }), kMalformed,
       "its host is not UTF-8"},
  });
}

// A writer learnt while it was matched is still told apart after it has gone (discovery has
// forgotten it): a worker exits 200 ms after its score.
TEST(SampleGate, WritersLearntStayKnown) {
  FakeWorld world;
  SampleGate gate(world);
  const dds_instance_handle_t gone = 42;
  EXPECT_FALSE(gate.knows(gone));
  gate.learn(gone, {kWorkerGuid, {dds::worker_partition("cab1")}});
  EXPECT_TRUE(gate.knows(gone));
  EXPECT_TRUE(gate.event(event(), from(gone), 0, SampleGate::Clock::now()));
  EXPECT_TRUE(world.refusals.empty());
}

}  // namespace
}  // namespace forklift::server
