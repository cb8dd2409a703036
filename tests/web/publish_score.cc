// forklift-test-score: publishes one fk_Score for a session over DDS, as a sim worker's evaluator
// does at the end of a session, and waits until the server's reader has acknowledged it. The web
// test uses it to mark a scripted session while the driver evaluation does not mark sessions yet.
//
//   forklift-test-score --session s-000001 --mark 86.5 --passed 1 --dds-domain DOMAIN [--count kind=n ...]
#include <CLI/CLI.hpp>
#include <chrono>
#include <iostream>
#include <thread>
#include <vector>

#include "forklift/protocol/protocol.h"

int main(int argc, char** argv) {
  CLI::App app{"forklift-test-score: publish one Score over DDS"};
  std::string session;
  double mark = 0;
  bool passed = false;
  int domain = 0;
  std::vector<std::string> counts;
  app.add_option("--session", session, "session id")->required();
  app.add_option("--mark", mark, "the mark")->required();
  app.add_option("--passed", passed, "1 if passed")->required();
  app.add_option("--dds-domain", domain, "DDS domain id")->required();
  app.add_option("--count", counts, "faults of a kind, kind=n");
  std::string security_dir, identity;
  app.add_option("--security", security_dir, "DDS Security folder (a secured server hears only identities of its school)");
  app.add_option("--identity", identity, "the identity to publish as (a worker's: worker.<cab>)");
  CLI11_PARSE(app, argc, argv);
  try {
    using namespace forklift;
    dds::Participant participant(dds::DomainSettings::resolve(domain, "", security_dir, identity));
    dds::Writer<fk_Score> writer(participant);
    // The server's reader must be matched, else a volatile hand-over could miss it.
    for (int i = 0; i < 200 && writer.matched() == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (writer.matched() == 0) throw std::runtime_error("no server reads scores on this domain");
    std::vector<fk_FaultCount> faults(counts.size());
    for (size_t i = 0; i < counts.size(); ++i) {
      const auto eq = counts[i].find('=');
      if (eq == std::string::npos) throw std::runtime_error("--count wants kind=n: " + counts[i]);
      dds::set_string(faults[i].kind, counts[i].substr(0, eq));
      faults[i].count = static_cast<uint32_t>(std::stoul(counts[i].substr(eq + 1)));
    }
    fk_Score s{};
    dds::set_string(s.session_id, session);
    s.mark = mark;
    s.passed = passed;
    s.counts._length = s.counts._maximum = static_cast<uint32_t>(faults.size());
    s.counts._buffer = faults.empty() ? nullptr : faults.data();
    s.counts._release = false;
    if (!writer.write(s)) throw std::runtime_error("write failed");
    if (dds_wait_for_acks(writer.handle(), DDS_SECS(10)) != DDS_RETCODE_OK) throw std::runtime_error("the server did not acknowledge");
    std::cout << "published score " << mark << (passed ? " (passed)" : " (not passed)") << " for " << session << '\n';
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "forklift-test-score: " << e.what() << '\n';
    return 2;
  }
}
