// A PostgreSQL server of a test's (or a bench's) own, from Debian's postgresql package: the
// binaries in /usr/lib/postgresql/15/bin (FORKLIFT_PG_BINDIR to use others), initdb once per folder
// of servers into a template beside them, and each server a copy of it in a folder of its own,
// started with pg_ctl on a port from support/ports.h, listening on 127.0.0.1 and on a socket in
// its folder only, with trust authentication for the user "forklift". As root (this machine and
// CI) the server runs as the "postgres" system user, since initdb and postgres refuse root.
//
// Stopped when the object goes; and a watchdog process, outside this process's tree so that a
// ctest timeout's kill spares it, waits on a pipe for this process to end however it ends (a
// crash, SIGKILL) and then stops the server and removes a temporary folder. Anything that keeps
// the server from starting (missing binaries, no "postgres" user, initdb or pg_ctl failing) throws
// std::runtime_error saying what and how to fix it: a test then fails, never passes unseen.
#pragma once

#include <fcntl.h>
#include <libpq-fe.h>
#include <pwd.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "support/ports.h"

namespace forklift::test {

class PostgresServer {
 public:
  // A server in `dir` (its data in dir/data, its socket and log beside). `keep`: the folder and
  // its databases stay for the next run (a bench's populated store), and commits are synced to
  // disk; else the folder is removed at the end and fsync is off (a test needs no power-cut
  // safety). `settings`: more "name=value" server settings.
  PostgresServer(const std::string& dir, bool keep, std::vector<std::string> settings = {})
      : dir_(std::filesystem::absolute(dir).lexically_normal().string()), keep_(keep) {
    const std::string bin = bindir();
    for (const char* tool : {"initdb", "pg_ctl", "postgres"})
      if (access((bin + "/" + tool).c_str(), X_OK) != 0)
        throw std::runtime_error("PostgreSQL's " + std::string(tool) + " is not at " + bin + "/" + tool +
                                 ": install Debian's postgresql package (scripts/install-deps.sh does), or set "
                                 "FORKLIFT_PG_BINDIR to the folder of its binaries");
    std::filesystem::create_directories(dir_);
    if (keep_) refuse_a_running_server();
    let_server_user_reach(dir_);
    give_to_server_user(dir_);
    start_watchdog();
    if (keep_ && !std::filesystem::exists(data() + "/PG_VERSION")) {
      std::filesystem::remove_all(data());
      initdb(bin, data());
    } else if (!std::filesystem::exists(data() + "/PG_VERSION")) {
      run({"cp", "-a", make_template(bin), data()}, false, "copying the template cluster");
    }
    port_ = free_port();
    std::vector<std::string> start = {bin + "/pg_ctl", "-D", data(), "-l", dir_ + "/server.log", "-w", "-t", "60", "-o"};
    std::string options = "-p " + std::to_string(port_) + " -k " + dir_ + " -c listen_addresses=127.0.0.1";
    if (!keep_) options += " -c fsync=off";
    for (const std::string& s : settings) options += " -c " + s;
    start.push_back(options);
    start.push_back("start");
    const std::string why = run(start, true, "");
    if (!why.empty()) {
      std::ifstream log(dir_ + "/server.log");
      std::stringstream text;
      text << log.rdbuf();
      throw std::runtime_error("pg_ctl start failed in " + dir_ + ": " + why + "\nserver log:\n" + text.str());
    }
    started_ = true;
  }
  ~PostgresServer() {
    // A temporary server's data goes with it: no shutdown checkpoint to wait for.
    if (started_) run({bindir() + "/pg_ctl", "-D", data(), "-m", keep_ ? "fast" : "immediate", "-w", "stop"}, true, "");
    if (!keep_) std::filesystem::remove_all(dir_);
    if (watchdog_fd_ >= 0) close(watchdog_fd_);  // the watchdog finds nothing left to do
  }
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  int port() const { return port_; }
  const std::string& dir() const { return dir_; }

  // The libpq URI of database `name` on this server, as forklift-server --db takes it.
  std::string uri(const std::string& name) const {
    return "postgresql://forklift@127.0.0.1:" + std::to_string(port_) + "/" + name;
  }

  // Runs `sql` in database `name`: "" if it worked, else PostgreSQL's message. `rows` gets the
  // first column of each row.
  std::string exec(const std::string& name, const std::string& sql, std::vector<std::string>* rows = nullptr) const {
    std::unique_ptr<PGconn, decltype(&PQfinish)> c(PQconnectdb(uri(name).c_str()), &PQfinish);
    if (PQstatus(c.get()) != CONNECTION_OK) return PQerrorMessage(c.get());
    PQsetNoticeProcessor(c.get(), [](void*, const char*) {}, nullptr);
    std::unique_ptr<PGresult, decltype(&PQclear)> r(PQexec(c.get(), sql.c_str()), &PQclear);
    const ExecStatusType s = PQresultStatus(r.get());
    if (s != PGRES_COMMAND_OK && s != PGRES_TUPLES_OK) return PQresultErrorMessage(r.get());
    for (int i = 0; rows && i < PQntuples(r.get()); ++i) rows->emplace_back(PQgetvalue(r.get(), i, 0));
    return "";
  }

  // A new empty database (UTF-8, "C" collation) named `name`; throws if it cannot be made.
  std::string create_database(const std::string& name) const {
    const std::string why = exec("postgres", "CREATE DATABASE \"" + name + "\"");
    if (!why.empty()) throw std::runtime_error("CREATE DATABASE " + name + ": " + why);
    return uri(name);
  }
  void drop_database(const std::string& name) const { exec("postgres", "DROP DATABASE IF EXISTS \"" + name + "\" WITH (FORCE)"); }

 private:
  static std::string bindir() {
    const char* env = std::getenv("FORKLIFT_PG_BINDIR");
    return env && *env ? env : "/usr/lib/postgresql/15/bin";
  }
  std::string data() const { return dir_ + "/data"; }

  // A kept folder's server that another run started (a bench still going on the same folder) is
  // left alone: this one's watchdog would stop it on the way out.
  void refuse_a_running_server() const {
    std::ifstream pid_file(data() + "/postmaster.pid");
    long pid = 0;
    if (pid_file >> pid && pid > 0 && (kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM))
      throw std::runtime_error("a PostgreSQL server already runs in " + data() + " (process " + std::to_string(pid) +
                               "; another run on the same folder?): wait for it to end, or give this run another folder");
  }

  // As root, the server's files belong to "postgres"; otherwise they are this user's already.
  static const passwd* server_user() {
    if (geteuid() != 0) return nullptr;
    const passwd* pw = getpwnam("postgres");
    if (!pw)
      throw std::runtime_error("running as root, but there is no \"postgres\" user to run PostgreSQL as (initdb refuses "
                               "root): install Debian's postgresql package (scripts/install-deps.sh does)");
    return pw;
  }
  // As root, "postgres" must pass through every folder above the server's: one that others may not
  // enter (a build in `mktemp -d`'s 0700 folder) is given search permission, not read.
  static void let_server_user_reach(const std::string& path) {
    if (!server_user()) return;
    for (std::filesystem::path p = std::filesystem::path(path).parent_path(); !p.empty() && p != p.root_path();
         p = p.parent_path()) {
      struct stat st{};
      if (stat(p.c_str(), &st) == 0 && !(st.st_mode & S_IXOTH) && chmod(p.c_str(), (st.st_mode & 07777) | S_IXOTH) != 0)
        throw std::runtime_error("cannot let the postgres user pass through " + p.string());
    }
  }
  static void give_to_server_user(const std::string& path) {
    if (const passwd* pw = server_user())
      if (chown(path.c_str(), pw->pw_uid, pw->pw_gid) != 0)
        throw std::runtime_error("cannot give " + path + " to the postgres user");
  }

  // Runs `args` (as the server's user if `as_server`) in this server's folder and waits. "" if it
  // exited 0; else its output. With `what`, a failure throws naming it instead.
  std::string run(std::vector<std::string> args, bool as_server, const std::string& what) const {
    if (as_server && server_user()) args.insert(args.begin(), {"/usr/sbin/runuser", "-u", "postgres", "--"});
    const std::string out = dir_ + "/command.out";
    std::vector<char*> argv;  // made before fork(): the child of a threaded process should not allocate
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const pid_t pid = fork();
    if (pid < 0) throw std::runtime_error("fork failed");
    if (pid == 0) {
      const int fd = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0666);
      dup2(fd, 1);
      dup2(fd, 2);
      const int null = open("/dev/null", O_RDONLY);
      dup2(null, 0);
      if (chdir(dir_.c_str()) != 0) _exit(126);
      execvp(argv[0], argv.data());
      _exit(127);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return "";
    std::ifstream in(out);
    std::stringstream text;
    text << args[0] << " exited " << (WIFEXITED(status) ? WEXITSTATUS(status) : -1) << ": " << in.rdbuf();
    if (!what.empty()) throw std::runtime_error(what + " failed: " + text.str());
    return text.str();
  }

  // A new cluster in `data`, whose superuser is "forklift", trusted on this server's own addresses.
  void initdb(const std::string& bin, const std::string& data) const {
    run({bin + "/initdb", "-D", data, "-U", "forklift", "-A", "trust", "-E", "UTF8", "--locale=C.UTF-8", "-N",
         "--no-instructions"},
        true, "initdb");
  }

  // The cluster initdb made once for every server in this folder's parent, under a lock so that
  // parallel tests make it once; copied, it saves each server initdb's seconds.
  std::string make_template(const std::string& bin) const {
    const std::string parent = std::filesystem::path(dir_).parent_path().string();
    const std::string tmpl = parent + "/postgresql-template";
    const int lock = open((parent + "/postgresql-template.lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
    if (lock < 0 || flock(lock, LOCK_EX) != 0) throw std::runtime_error("cannot lock " + parent + "/postgresql-template.lock");
    try {
      if (!std::filesystem::exists(tmpl + "/PG_VERSION")) {
        std::filesystem::remove_all(tmpl);
        const std::string made = dir_ + "/initdb";
        initdb(bin, made);
        std::filesystem::rename(made, tmpl);
      }
    } catch (...) {
      close(lock);
      throw;
    }
    close(lock);
    return tmpl;
  }

  // A process outside this one's tree (forked twice, its own session) that waits until this
  // process's end closes the pipe, then stops the server at once and, unless kept, removes the
  // folder.
  void start_watchdog() {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error("pipe failed");
    const std::string script =
        "read _; pid=$(head -n 1 \"$1/data/postmaster.pid\" 2>/dev/null); "
        "if [ -n \"$pid\" ] && kill -QUIT \"$pid\" 2>/dev/null; then "
        "i=0; while kill -0 \"$pid\" 2>/dev/null && [ $i -lt 300 ]; do sleep 0.1; i=$((i+1)); done; "
        "kill -KILL \"$pid\" 2>/dev/null; fi; [ \"$2\" = keep ] || rm -rf \"$1\"";
    const pid_t child = fork();
    if (child < 0) throw std::runtime_error("fork failed");
    if (child == 0) {
      setsid();
      if (fork() != 0) _exit(0);
      dup2(fds[0], 0);
      const int null = open("/dev/null", O_WRONLY);
      dup2(null, 1);
      dup2(null, 2);
      execl("/bin/sh", "sh", "-c", script.c_str(), "forklift-postgres-watchdog", dir_.c_str(),
            keep_ ? "keep" : "remove", static_cast<char*>(nullptr));
      _exit(127);
    }
    waitpid(child, nullptr, 0);
    close(fds[0]);
    watchdog_fd_ = fds[1];
  }

  std::string dir_;
  bool keep_;
  int port_ = 0;
  bool started_ = false;
  int watchdog_fd_ = -1;
};

}  // namespace forklift::test
