// A full disk and a read-only disk under a running forklift-server's SQLite database: every write
// answers 503 storage_unavailable with the reason in words, never 500; /api/health says so; the
// database stays whole (PRAGMA integrity_check) with nothing half-written; and writes succeed
// again once there is room, or once the disk is writable again. The disks are real: a 2 MiB
// tmpfs, and an ext4 image on a loop device that the kernel turns read-only under the server, as
// it does a failing disk (root cannot write it either). They need root and mount(8): without them
// the tests skip, saying why.
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support/server.h"

using forklift_test::error_code;
using forklift_test::kAdminPassword;
using forklift_test::Server;
using nlohmann::json;

namespace {

// Runs `command` through the shell: "" if it exited 0, else what it printed and its status.
std::string Shell(const std::string& command) {
  std::string out;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (!p) return "cannot run " + command;
  char buf[512];
  while (fgets(buf, sizeof buf, p)) out += buf;
  const int status = pclose(p);
  return status == 0 ? "" : command + " failed (" + std::to_string(status) + "): " + out;
}

// A file system mounted on `dir` while the object lives: unmounted when it goes, however the
// test ends (declare it before the Server, so that the server has stopped by then).
class Mount {
 public:
  // `source`: mount(8)'s arguments before the folder ("-t tmpfs -o size=2m tmpfs"). Null, with
  // `why`, if it cannot be mounted.
  static std::unique_ptr<Mount> make(const std::string& source, const std::string& dir, std::string* why) {
    std::filesystem::create_directories(dir);
    if (const std::string e = Shell("mount " + source + " " + dir); !e.empty()) {
      *why = "cannot mount a file system for the database (root and mount(8) are needed): " + e;
      return nullptr;
    }
    return std::unique_ptr<Mount>(new Mount(dir));
  }
  ~Mount() {
    if (!Shell("umount " + dir_).empty()) Shell("umount -l " + dir_);  // never left mounted
  }
  Mount(const Mount&) = delete;
  Mount& operator=(const Mount&) = delete;
  const std::string& dir() const { return dir_; }

 private:
  explicit Mount(std::string dir) : dir_(std::move(dir)) {}
  std::string dir_;
};

// The first column of `sql`'s rows, read from the database file on a connection of its own.
std::vector<std::string> Rows(const std::string& db, const std::string& sql) {
  std::vector<std::string> rows;
  sqlite3* c = nullptr;
  sqlite3_stmt* st = nullptr;
  if (sqlite3_open_v2(db.c_str(), &c, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK &&
      sqlite3_prepare_v2(c, sql.c_str(), -1, &st, nullptr) == SQLITE_OK) {
    while (sqlite3_step(st) == SQLITE_ROW) rows.emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(st, 0)));
  } else {
    rows.push_back(std::string("error: ") + sqlite3_errmsg(c));
  }
  sqlite3_finalize(st);
  sqlite3_close(c);
  return rows;
}

// A new pupil, with an email long enough that a few of them need new pages.
std::pair<int, json> AddPupil(const Server& s, const std::string& token, int i) {
  return s.call("POST", "/api/pupils", token,
                json{{"name", "Pupil " + std::to_string(i)}, {"email", std::string(8000, 'e') + "@example.org"}}.dump());
}

// Writes until one is refused for want of storage, each answered 201 or 503 and never anything
// else: the count of 201s (each a pupil stored), and the refusal.
std::pair<int, json> WriteUntilRefused(const Server& s, const std::string& token, int first) {
  int created = 0;
  for (int i = first; i < first + 500; ++i) {
    auto [status, body] = AddPupil(s, token, i);
    if (status == 503) return {created, body};
    EXPECT_EQ(status, 201) << body;
    if (status != 201) break;
    ++created;
  }
  ADD_FAILURE() << "no write was refused";
  return {created, nullptr};
}

// The refusal is 503 storage_unavailable with the reason in words.
void ExpectStorageRefusal(const json& refusal, const std::string& reason_says) {
  EXPECT_EQ(error_code(refusal), "storage_unavailable") << refusal;
  ASSERT_TRUE(refusal.is_object() && refusal.contains("error")) << refusal;
  EXPECT_NE(refusal["error"].value("reason", "").find(reason_says), std::string::npos) << refusal;
  EXPECT_NE(refusal["error"].value("message", "").find("Nothing of this request was written"), std::string::npos) << refusal;
}

// The database is whole, and holds as many pupils (and pupil_created audit rows) as were answered 201.
void ExpectWholeWith(const std::string& db, int pupils) {
  EXPECT_EQ(Rows(db, "PRAGMA integrity_check"), std::vector<std::string>{"ok"});
  EXPECT_EQ(Rows(db, "SELECT COUNT(*) FROM pupils"), std::vector<std::string>{std::to_string(pupils)});
  EXPECT_EQ(Rows(db, "SELECT COUNT(*) FROM audit_log WHERE action = 'pupil_created'"), std::vector<std::string>{std::to_string(pupils)});
}

}  // namespace

TEST(Storage, AFullDiskAnswers503WithTheReasonAndWritesResumeOnceThereIsRoom) {
  std::string why;
  const auto disk = Mount::make("-t tmpfs -o size=2m tmpfs", testing::TempDir() + "/storage-full-disk", &why);
  if (!disk) GTEST_SKIP() << why;
  const std::string db = disk->dir() + "/forklift.db";
  Server s("storage-full", Server::Database{db});
  const std::string admin = s.login("admin", kAdminPassword);
  ASSERT_EQ(AddPupil(s, admin, 0).first, 201);
  int pupils = 1;

  {  // the rest of the disk taken by another file
    std::ofstream filler(disk->dir() + "/filler", std::ios::binary);
    const std::string block(64 * 1024, 'x');
    while (filler.write(block.data(), static_cast<std::streamsize>(block.size())) && filler.flush()) {
    }
  }
  const auto [created, refusal] = WriteUntilRefused(s, admin, 1);
  pupils += created;
  ExpectStorageRefusal(refusal, "full");
  auto [hst, health] = s.call("GET", "/api/health");
  EXPECT_EQ(hst, 503) << health;
  EXPECT_EQ(health["status"], "storage_unavailable") << health;
  EXPECT_NE(health.value("reason", "").find("full"), std::string::npos) << health;
  EXPECT_EQ(s.call("GET", "/api/pupils", admin).first, 200);  // reads go on
  ExpectWholeWith(db, pupils);

  // With room again, health says so before anyone writes (its own small write succeeds), and writes go on.
  std::filesystem::remove(disk->dir() + "/filler");
  EXPECT_EQ(s.call("GET", "/api/health").first, 200);
  auto [st, body] = AddPupil(s, admin, 1000);
  EXPECT_EQ(st, 201) << body;
  pupils += st == 201;
  EXPECT_EQ(s.login("admin", kAdminPassword).empty(), false);
  ExpectWholeWith(db, pupils);
}

// The kernel turns the disk read-only under the running server (ext4's errors=remount-ro, set off
// through its trigger_fs_error switch), as it does when a disk fails: a tmpfs cannot be remounted
// read-only while the server holds its database open for writing (mount(8): "busy"), and neither
// can such an ext4 until it is unmounted, so the school's way back is the test's: stop the server,
// check the disk (e2fsck), mount it again and start the server.
TEST(Storage, ADiskTurnedReadOnlyAnswers503WithTheReasonAndWritesResumeOnceItIsWritable) {
  const std::string image = testing::TempDir() + "/storage-ro.img", dir = testing::TempDir() + "/storage-ro-disk";
  std::filesystem::remove(image);
  if (const std::string e = Shell("truncate -s 16M " + image + " && mkfs.ext4 -q -F " + image); !e.empty()) GTEST_SKIP() << e;
  std::string why;
  auto disk = Mount::make("-o loop,errors=remount-ro " + image, dir, &why);
  if (!disk) GTEST_SKIP() << why;
  std::string device;
  {
    std::ifstream mounts("/proc/mounts");
    for (std::string src, at, rest; mounts >> src >> at && std::getline(mounts, rest);)
      if (at == std::filesystem::canonical(dir).string()) device = std::filesystem::path(src).filename().string();
  }
  const std::string trigger = "/sys/fs/ext4/" + device + "/trigger_fs_error";
  if (device.empty() || !std::filesystem::exists(trigger)) GTEST_SKIP() << "this kernel has no " << trigger << " to fail the disk with";

  const std::string db = dir + "/forklift.db";
  auto s = std::make_unique<Server>("storage-ro", Server::Database{db});
  const std::string admin = s->login("admin", kAdminPassword);
  ASSERT_EQ(AddPupil(*s, admin, 0).first, 201);
  int pupils = 1;

  std::ofstream(trigger) << "forklift storage test: the disk fails" << std::flush;
  auto [st, refusal] = AddPupil(*s, admin, 1);
  EXPECT_EQ(st, 503) << refusal;
  ExpectStorageRefusal(refusal, "");
  auto [hst, health] = s->call("GET", "/api/health");
  EXPECT_EQ(hst, 503) << health;
  EXPECT_NE(health.value("reason", "").find("read-only"), std::string::npos) << health;
  EXPECT_EQ(s->call("GET", "/api/pupils", admin).first, 200);  // reads go on
  EXPECT_NE(Shell("touch " + dir + "/root-writes").find("Read-only file system"), std::string::npos);  // not root either

  // The way back: the server stopped, the disk checked and mounted again, the server started.
  s->proc->signal(SIGTERM);
  EXPECT_EQ(s->proc->wait(20), 0) << s->proc->err();
  disk.reset();
  Shell("e2fsck -fy " + image);  // exits 1 when it corrected the error the kernel noted
  disk = Mount::make("-o loop,errors=remount-ro " + image, dir, &why);
  ASSERT_TRUE(disk) << why;
  ExpectWholeWith(db, pupils);
  s->start({"--log-dir", s->dir + "/logs"});
  const std::string again = s->login("admin", kAdminPassword);
  auto [st2, body] = AddPupil(*s, again, 2);
  EXPECT_EQ(st2, 201) << body;
  pupils += st2 == 201;
  EXPECT_EQ(s->call("GET", "/api/health").first, 200);
  s.reset();  // stopped before the disk goes
  ExpectWholeWith(db, pupils);
}
