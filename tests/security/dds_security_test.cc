// DDS Security between real processes on loopback: a school's CA and identities made by
// scripts/forklift-pki.sh, a sim worker in exam mode, and cabs with the right identity, none,
// another cab's, one from another CA, and a revoked one. Each test has its own DDS
// domain from the allocator (support/ports.h).
#include <csignal>
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>
#include <thread>
#include <unistd.h>

#include "forklift/image/image.h"
#include "forklift/protocol/protocol.h"
#include "support/ports.h"
#include "support/process.h"
#include "support/temp_dir.h"
#include "support/worker.h"

using namespace forklift;
namespace fs = std::filesystem;

namespace {

const std::string kBin = FORKLIFT_BIN_DIR;
// Exams run only on an exam course (data/evaluation/README.md): the workers here run the shipped one.
const std::string kExamCourse = std::string(FORKLIFT_DATA_DIR) + "/scenarios/counterbalance_exam.json";
const std::string kPki = std::string(FORKLIFT_SOURCE_DIR) + "/scripts/forklift-pki.sh";
// A throttle no script would use by chance: its eight bytes are looked for on the wire.
constexpr double kMarkerThrottle = 0.3141592653;

std::string tmp(const std::string& name) { return forklift_test::process_path("security", name); }

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void run_or_fail(const std::string& cmd) { ASSERT_EQ(std::system((cmd + " >/dev/null 2>&1").c_str()), 0) << cmd; }

class SecuredExam : public testing::Test {
 protected:
  // One school CA with cabs cab1 and cab2, and a rogue CA that also issued a "cab.cab1".
  static void SetUpTestSuite() {
    fs::remove_all(school());
    fs::remove_all(rogue());
    run_or_fail(kPki + " init " + school() + " --school 'Test School'");
    run_or_fail(kPki + " add-cab " + school() + " cab1");
    run_or_fail(kPki + " add-cab " + school() + " cab2");
    run_or_fail(kPki + " init " + rogue() + " --school 'Test School'");
    run_or_fail(kPki + " add-cab " + rogue() + " cab1");
    std::ofstream(script()) << std::setprecision(17) << "t,steer,accelerator,brake,lift,tilt,shift\n0,0," << kMarkerThrottle
                            << ",0,0,0,0\n2.5,0,0,1,0,0,0\n600,0,0,1,0,0,0\n";  // braked until the test ends the session
  }
  static std::string school() { return tmp("school"); }
  static std::string rogue() { return tmp("rogue"); }
  static std::string script() { return tmp("drive.csv"); }

  static Process worker(int domain, const std::string& name, const std::string& security_dir, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {kBin + "/forklift-worker", "--cab", "cab1", "--session", "s-" + name, "--mode", "exam",
                                     "--scenario", kExamCourse, "--dds-domain", std::to_string(domain), "--log", tmp(name + ".ctl"),
                                     "--fps", "10"};
    if (!security_dir.empty()) args.insert(args.end(), {"--security", security_dir});
    args.insert(args.end(), extra.begin(), extra.end());
    return Process(args, tmp(name + ".worker"));
  }
  // A cab shut out gives up after `wait_worker` seconds; one let in waits longer on a busy machine.
  static Process cab(int domain, const std::string& name, std::vector<std::string> extra, const std::string& wait_worker = "4") {
    std::vector<std::string> args = {kBin + "/forklift-cab", "--cab", "cab1", "--script", script(), "--no-window",
                                     "--dds-domain", std::to_string(domain), "--wait-worker", wait_worker, "--save-frame", tmp(name + ".png")};
    args.insert(args.end(), extra.begin(), extra.end());
    return Process(args, tmp(name + ".cab"));
  }
  // Control samples the worker applied, from its session log ("i" lines; the first is tick 0's).
  static int applied_inputs(const std::string& name) {
    std::istringstream in(slurp(tmp(name + ".ctl")));
    int n = 0;
    for (std::string line; std::getline(in, line);) n += line.rfind("i ", 0) == 0;
    return n;
  }

  // A cab that must get nowhere: the worker hears no controls and gives up, the cab sees no worker.
  void expect_shut_out(int domain, const std::string& name, std::vector<std::string> cab_args, int cab_code) {
    Process w = worker(domain, name, school(), {"--start-timeout", "6"});
    Process c = cab(domain, name + "-cab", cab_args);
    EXPECT_EQ(c.wait(30), cab_code) << c.err();
    EXPECT_EQ(w.wait(30), 5) << "the worker must give up for want of controls: " << w.err();
    EXPECT_NE(w.err().find("no controls within"), std::string::npos) << w.err();
    EXPECT_EQ(applied_inputs(name), 0) << "a control sample reached the integrator";
    EXPECT_FALSE(fs::exists(tmp(name + "-cab.png"))) << "the cab received a frame";
  }
};

TEST_F(SecuredExam, EnrolledCabDrivesAndSeesItsFrames) {
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "enrolled", school());  // until signalled, once a frame came
  const std::string saved = tmp("enrolled-cab-frames");
  fs::remove_all(saved);
  Process c = cab(domain, "enrolled-cab", {"--security", school(), "--save-frames", saved, "--save-every", "1"}, "30");
  // Frames render at nice 10: on a busy machine they come when they come.
  EXPECT_GE(forklift_test::wait_for_files(saved, 1, 180), 1u) << w.err() << c.err();
  w.signal(SIGTERM);
  ASSERT_EQ(w.wait(40), 0) << w.err();
  ASSERT_EQ(c.wait(40), 0) << c.err();
  EXPECT_GT(applied_inputs("enrolled"), 0) << "the enrolled cab's controls must reach the worker";
  EXPECT_NE(c.out().find("frames received"), std::string::npos) << c.out();
  EXPECT_TRUE(fs::exists(tmp("enrolled-cab.png")));
}

TEST_F(SecuredExam, CabWithoutIdentityCannotDriveOrWatch) {
  expect_shut_out(forklift::test::free_domain(), "anonymous", {}, 5);
}

TEST_F(SecuredExam, CabWithIdentityFromAnotherCaIsRefused) {
  expect_shut_out(forklift::test::free_domain(), "rogue", {"--security", rogue()}, 5);
}

TEST_F(SecuredExam, CabWithAnotherCabsIdentityCannotDriveThisOne) {
  // cab2's permissions name partition cab.cab2 only: writing cab1's controls is refused outright.
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "impostor", school(), {"--start-timeout", "6"});
  Process c = cab(domain, "impostor-cab", {"--security", school(), "--identity", "cab.cab2"});
  EXPECT_EQ(c.wait(30), 2);
  EXPECT_NE(c.err().find("Not Allowed By Security"), std::string::npos) << c.err();
  EXPECT_EQ(w.wait(30), 5) << w.err();
  EXPECT_EQ(applied_inputs("impostor"), 0);
}

TEST_F(SecuredExam, RevokedCabIsRefusedByTheWorker) {
  // The cab keeps a copy of its folder from before the revocation (no REVOKED mark, old CRL);
  // the worker reads the school's new CRL and refuses the handshake.
  const std::string school_copy = tmp("school-revoked");
  fs::remove_all(school_copy);
  fs::copy(school(), school_copy, fs::copy_options::recursive);
  const std::string cab_copy = tmp("school-cab-side");
  fs::remove_all(cab_copy);
  fs::copy(school(), cab_copy, fs::copy_options::recursive);
  run_or_fail(kPki + " revoke " + school_copy + " cab.cab1");
  EXPECT_EQ(slurp(school_copy + "/crl.pem") == slurp(cab_copy + "/crl.pem"), false) << "the CRL must change";
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "revoked", school_copy, {"--start-timeout", "6"});
  Process c = cab(domain, "revoked-cab", {"--security", cab_copy});
  EXPECT_EQ(c.wait(30), 5) << c.err();
  EXPECT_EQ(w.wait(30), 5) << w.err();
  EXPECT_EQ(applied_inputs("revoked"), 0);
  // And the revoked identity cannot even start from the school's own folder.
  Process again = cab(domain, "revoked-again", {"--security", school_copy});
  EXPECT_EQ(again.wait(30), 2);
  EXPECT_NE(again.err().find("revoked"), std::string::npos) << again.err();
}

// An exam worker grants no training aid whatever its cab asks: TruckState.aids is 0, and the
// frame of a cab asking for the mirror, the see-through mast and the chase camera is the plain
// driver's view, told apart from a training worker's frame with its mirror.
TEST_F(SecuredExam, AnExamWorkerGrantsNoAidWhateverTheCabAsks) {
  struct Seen {
    std::vector<uint8_t> frame;
    int aids = -1;
  };
  auto session = [&](const std::string& name, const std::string& mode, bool ask_everything) {
    const int domain = forklift::test::free_domain();
    Process w({kBin + "/forklift-worker", "--cab", "cab1", "--session", "s-" + name, "--mode", mode, "--security", school(),
               "--scenario", kExamCourse, "--dds-domain", std::to_string(domain), "--log", tmp(name + ".ctl"), "--frame-size",
               "320x240", "--duration", "60"},
              tmp(name + ".worker"));
    // The cab, enrolled: cab1's identity, its own partition.
    dds::Participant p(dds::DomainSettings::resolve(domain, "", school(), "cab.cab1"));
    dds::Writer<fk_Controls> controls(p, dds::cab_partition("cab1"));
    dds::Reader<fk_TruckState> states(p, dds::cab_partition("cab1"));
    dds::Reader<fk_Frame> frames(p, dds::cab_partition("cab1"));
    for (int i = 0; i < 2000 && controls.matched() == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    EXPECT_GT(controls.matched(), 0u) << w.err();
    fk_Controls c{};
    dds::set_string(c.cab_id, "cab1");
    c.frames_wanted = true;
    c.rear_view = true;
    c.see_through_mast = ask_everything;
    c.camera = ask_everything ? 1 : 0;
    Seen seen;
    // 1.5 s, and on until a frame has come (the renderer loads on the first one), at most 30 s.
    for (uint32_t seq = 1; seq <= 75 || (seen.frame.empty() && seq <= 1500); ++seq) {
      c.seq = seq;
      controls.write(c);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      states.take_each([&](const fk_TruckState& t) { seen.aids = t.aids; });
      frames.take_each([&](const fk_Frame& f) { seen.frame.assign(f.pixels._buffer, f.pixels._buffer + f.pixels._length); });
    }
    w.signal(SIGTERM);
    EXPECT_EQ(w.wait(30), 0) << w.err();
    return seen;
  };
  const Seen exam = session("aids-exam", "exam", true);
  const Seen training = session("aids-training", "training", false);
  EXPECT_EQ(exam.aids, 0);
  EXPECT_EQ(training.aids, 15);  // rear view, see-through mast, chase camera and fork camera
  ASSERT_EQ(exam.frame.size(), 320u * 240 * 3);
  ASSERT_EQ(training.frame.size(), exam.frame.size());
  auto mean_diff = [&](int y0, int y1, int x0, int x1) {
    double sum = 0;
    long n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x)
        for (int k = 0; k < 3; ++k, ++n)
          sum += std::abs(int(exam.frame[(y * 320 + x) * 3 + k]) - int(training.frame[(y * 320 + x) * 3 + k]));
    return sum / n;
  };
  EXPECT_GT(mean_diff(10, 45, 120, 200), 10.0) << "the exam frame has no mirror where the training frame has one";
  EXPECT_LT(mean_diff(80, 240, 0, 320), 1.0) << "and is otherwise the driver's plain view: no chase camera, no see-through mast";
}

TEST_F(SecuredExam, ExamModeRefusesToStartWithoutSecurity) {
  const int domain = forklift::test::free_domain();
  Process w = worker(domain, "unsecured", "");
  EXPECT_EQ(w.wait(20), 2);
  EXPECT_NE(w.err().find("exam mode needs DDS Security"), std::string::npos) << w.err();
  // Training on loopback may run without it.
  Process t = Process({kBin + "/forklift-worker", "--cab", "cab1", "--session", "s-training", "--mode", "training",
                       "--dds-domain", std::to_string(domain), "--log", tmp("training.ctl"), "--start-timeout", "1"},
                      tmp("training.worker"));
  EXPECT_EQ(t.wait(20), 5) << "training starts and waits for a cab: " << t.err();
}

// An exam runs only on an exam course: the paper's manoeuvres, the training scenarios and a bare
// floor are refused as bad input (exit 2), saying why, before the session starts.
TEST_F(SecuredExam, ExamModeRefusesAScenarioThatIsNotAnExamCourse) {
  const int domain = forklift::test::free_domain();
  for (const std::string& scenario : {std::string(FORKLIFT_DATA_DIR) + "/manoeuvres/manoeuvre_1.json",
                                      std::string(FORKLIFT_DATA_DIR) + "/scenarios/first_drive_yard.json", std::string()}) {
    std::vector<std::string> args = {kBin + "/forklift-worker", "--cab", "cab1", "--session", "s-not-a-course", "--mode", "exam",
                                     "--security", school(), "--dds-domain", std::to_string(domain), "--log", tmp("not-a-course.ctl")};
    if (!scenario.empty()) args.insert(args.end(), {"--scenario", scenario});
    Process w(args, tmp("not-a-course.worker"));
    EXPECT_EQ(w.wait(30), 2) << scenario << ": " << w.err();
    EXPECT_NE(w.err().find("is not an exam course"), std::string::npos) << w.err();
    EXPECT_EQ(slurp(tmp("not-a-course.ctl")), "") << "no session ran";
  }
}

// Byte windows of a frame the cab received: 32 pixels across an edge in the picture (two colours
// at least), so that they cannot turn up in ciphertext or headers by chance.
std::vector<std::string> frame_windows(const std::string& png) {
  const Image img = read_png(png);
  std::vector<std::string> out;
  constexpr int kPixels = 32;
  for (int y = img.height / 10; y < img.height; y += img.height / 10) {
    int taken = 0;
    for (int x = 0; x + kPixels <= img.width && taken < 3; x += 4) {
      const std::string w(reinterpret_cast<const char*>(img.pixel(x, y)), kPixels * 3);
      std::set<std::string> colours;
      for (int i = 0; i < kPixels; ++i) colours.insert(w.substr(i * 3, 3));
      if (colours.size() >= 2 && std::set<char>(w.begin(), w.end()).size() >= 4) {
        out.push_back(w);
        ++taken;
        x += kPixels;
      }
    }
  }
  return out;
}

size_t count(const std::string& haystack, const std::string& needle) {
  size_t n = 0;
  for (size_t at = haystack.find(needle); at != std::string::npos; at = haystack.find(needle, at + 1)) ++n;
  return n;
}

struct Capture {
  size_t throttle_hits = 0;
  size_t frame_windows_found = 0, frame_windows = 0;
};

// One exam session (secured or not) with tcpdump on the loopback interface, on the domain's ports.
Capture capture_session(int domain, const std::string& name, const std::string& security_dir) {
  const std::string pcap = tmp(name + ".pcap");
  fs::remove(pcap);
  const int base = 7400 + 250 * domain;  // Cyclone's port mapping: every port of this domain
  Process dump({"/usr/bin/env", "tcpdump", "-i", "lo", "-U", "-w", pcap, "udp portrange " + std::to_string(base) + "-" + std::to_string(base + 249)},
               tmp(name + ".tcpdump"));
  for (int i = 0; i < 100 && !fs::exists(pcap); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  std::vector<std::string> sec = security_dir.empty() ? std::vector<std::string>{} : std::vector<std::string>{"--security", security_dir};
  std::vector<std::string> wargs = {kBin + "/forklift-worker", "--cab", "cab1", "--session", "s-" + name, "--mode",
                                    security_dir.empty() ? "training" : "exam", "--scenario", kExamCourse, "--dds-domain", std::to_string(domain),
                                    "--log", tmp(name + ".ctl"), "--fps", "10"};  // until signalled, once frames came
  wargs.insert(wargs.end(), sec.begin(), sec.end());
  Process w(wargs, tmp(name + ".worker"));
  const std::string saved = tmp(name + "-frames");
  fs::remove_all(saved);
  std::vector<std::string> cargs = {kBin + "/forklift-cab", "--cab", "cab1", "--script", tmp("drive.csv"), "--no-window",
                                    "--dds-domain", std::to_string(domain), "--save-frame", tmp(name + ".png"), "--save-frames", saved,
                                    "--save-every", "1", "--wait-worker", "30"};
  cargs.insert(cargs.end(), sec.begin(), sec.end());
  Process c(cargs, tmp(name + ".cab"));
  // The script's throttle is on the wire in its first seconds; frames render at nice 10 and come
  // when a busy machine leaves room for them.
  EXPECT_GE(forklift_test::wait_for_files(saved, 3, 180), 3u) << w.err() << c.err();
  w.signal(SIGTERM);
  EXPECT_EQ(w.wait(40), 0) << w.err();
  EXPECT_EQ(c.wait(40), 0) << c.err();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  dump.signal(SIGINT);
  EXPECT_EQ(dump.wait(10), 0) << "tcpdump: " << dump.err();
  const std::string wire = slurp(pcap);
  fs::remove(pcap);  // tens of MB
  Capture out;
  double marker = kMarkerThrottle;
  out.throttle_hits = count(wire, std::string(reinterpret_cast<const char*>(&marker), sizeof marker));
  for (const std::string& window : frame_windows(tmp(name + ".png"))) {
    ++out.frame_windows;
    out.frame_windows_found += wire.find(window) != std::string::npos;
  }
  return out;
}

TEST_F(SecuredExam, LoopbackCaptureShowsNoFrameOrControlPayloads) {
  // The same session in clear first: proof that the capture would see the payloads.
  const Capture clear = capture_session(forklift::test::free_domain(), "clear", "");
  ASSERT_GT(clear.throttle_hits, 0u) << "the capture must see controls in clear without security";
  ASSERT_GT(clear.frame_windows, 4u);
  ASSERT_GT(clear.frame_windows_found, clear.frame_windows / 2) << "the capture must see frame pixels in clear";
  const Capture secured = capture_session(forklift::test::free_domain(), "secured", school());
  std::printf("clear: %zu throttle samples, %zu/%zu frame windows on the wire; secured: %zu, %zu/%zu\n", clear.throttle_hits,
              clear.frame_windows_found, clear.frame_windows, secured.throttle_hits, secured.frame_windows_found, secured.frame_windows);
  EXPECT_EQ(secured.throttle_hits, 0u) << "a control sample crossed loopback in clear";
  ASSERT_GT(secured.frame_windows, 4u) << "the secured cab received no frame";
  EXPECT_EQ(secured.frame_windows_found, 0u) << "frame pixels crossed loopback in clear";
}

}  // namespace
