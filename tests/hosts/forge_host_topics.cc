// forklift-test-forge: a peer on the school's network that claims to be a worker host or a
// server, for the hosts tests. It writes one forged sample of a host topic in a host's partition,
// again and again for --seconds (so that a reader discovered late still takes it), with the DDS
// settings it is given: none (a machine without an identity) or an identity of the school's.
//
//   forklift-test-forge status  --host-id evil --capacity 100
//   forklift-test-forge report  --host-id h1 --session s-4 --cab c1 --state exited --log FILE [--sign-as worker.c1]
//   forklift-test-forge request --host-id h1 --session s-4 --cab c1 --action kill|start
#include <CLI/CLI.hpp>

#include <chrono>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>

#include "forklift/protocol/protocol.h"
#include "forklift/security/evidence.h"

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void set_octets(dds_sequence_octet& seq, std::string& bytes) {
  seq._buffer = reinterpret_cast<uint8_t*>(bytes.data());
  seq._length = seq._maximum = static_cast<uint32_t>(bytes.size());
  seq._release = false;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"forklift-test-forge: writes a forged worker-host sample (tests only)"};
  app.option_defaults()->always_capture_default();
  app.set_version_flag("--version", "test");
  std::optional<int> domain;
  std::string security, identity, host_id, session = "s-1", cab = "c1", state = "exited", action = "kill", log_file, sign_as;
  int capacity = 100;
  double seconds = 3;
  app.add_option("--dds-domain", domain, "DDS domain id (default FORKLIFT_DDS_DOMAIN or 0)");
  app.add_option("--security", security, "a DDS Security folder (none: a peer without an identity)");
  app.add_option("--identity", identity, "the identity to claim with it");
  app.add_option("--seconds", seconds, "how long to keep writing, s")->check(CLI::Range(0.1, 60.0));
  app.require_subcommand(1);
  app.fallthrough();  // --seconds and the DDS options may follow the subcommand
  auto* status = app.add_subcommand("status", "a host's status (fk_HostStatus)");
  auto* report = app.add_subcommand("report", "a host's report on a session's worker (fk_WorkerReport)");
  auto* request = app.add_subcommand("request", "a server's request to a host (fk_WorkerRequest)");
  for (CLI::App* sub : {status, report, request}) sub->add_option("--host-id", host_id, "the host's id; its partition is host.<id>");
  status->add_option("--capacity", capacity, "workers it claims to take");
  for (CLI::App* sub : {report, request}) {
    sub->add_option("--session", session, "the session");
    sub->add_option("--cab", cab, "the cab");
  }
  report->add_option("--state", state, "starting, running, exited or refused");
  report->add_option("--log", log_file, "the session log it ships (exited)");
  report->add_option("--sign-as", sign_as, "sign that log with this identity of --security (else unsigned)");
  request->add_option("--action", action, "start, abort or kill");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    forklift::dds::Participant participant(
        forklift::dds::DomainSettings::resolve(domain, "", security, security.empty() ? "" : identity));
    const std::string partition = forklift::dds::host_partition(host_id);
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    auto repeat = [&](auto& writer, const auto& sample) {
      int written = 0;
      while (std::chrono::steady_clock::now() < until) {
        if (writer.matched() > 0) {
          writer.write(sample);
          ++written;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
      }
      std::cout << "wrote " << written << " sample(s) in partition " << partition << " to " << writer.matched()
                << " matched reader(s)\n";
    };
    if (*status) {
      forklift::dds::Writer<fk_HostStatus> w(participant, partition);
      fk_HostStatus s{};
      forklift::dds::set_string(s.host_id, host_id);
      forklift::dds::set_string(s.state, "ready");
      s.capacity = static_cast<uint16_t>(capacity);
      s.cores = 64;
      repeat(w, s);
    } else if (*report) {
      forklift::dds::Writer<fk_WorkerReport> w(participant, partition);
      auto r = std::make_unique<fk_WorkerReport>();
      forklift::dds::set_string(r->session_id, session);
      forklift::dds::set_string(r->host_id, host_id);
      forklift::dds::set_string(r->cab_id, cab);
      forklift::dds::set_string(r->state, state);
      std::string log = log_file.empty() ? "" : slurp(log_file), signature;
      if (!sign_as.empty()) {
        const forklift::dds::SecurityFiles id{security, sign_as};
        signature = forklift::security::sign_exam_log(session, cab, log, id.private_key(), id.certificate()).dump();
      }
      set_octets(r->control_log, log);
      set_octets(r->signature, signature);
      repeat(w, *r);
    } else {
      forklift::dds::Writer<fk_WorkerRequest> w(participant, partition);
      auto r = std::make_unique<fk_WorkerRequest>();
      forklift::dds::set_string(r->session_id, session);
      forklift::dds::set_string(r->host_id, host_id);
      forklift::dds::set_string(r->cab_id, cab);
      forklift::dds::set_string(r->action, action);
      forklift::dds::set_string(r->mode, "training");
      forklift::dds::set_string(r->scenario_json, "{}");
      repeat(w, *r);
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "forklift-test-forge: " << e.what() << "\n";
    return 1;
  }
}
