// For tests of exam records on a real server: its SQLite file changed as someone with the disk
// would change it (the triggers that keep exams as written dropped first, as they would be), and a
// theory exam passed at a supervised station.
#pragma once

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "support/api_client.h"

namespace forklift_test {

// Runs SQL on the database file; the rows' text, or "ERROR: ..." when SQLite refuses it.
inline std::string sql(const std::string& db, const std::string& statement) {
  sqlite3* h = nullptr;
  sqlite3_open(db.c_str(), &h);
  sqlite3_busy_timeout(h, 5000);
  char* err = nullptr;
  std::string out;
  sqlite3_exec(h, statement.c_str(), [](void* o, int n, char** v, char**) {
    for (int i = 0; i < n; ++i) *static_cast<std::string*>(o) += v[i] ? v[i] : "";
    return 0;
  }, &out, &err);
  const std::string error = err ? err : "";
  sqlite3_free(err);
  sqlite3_close(h);
  return error.empty() ? out : "ERROR: " + error;
}

// Drops the triggers that keep finished exams as written (the store's kept_*), as someone editing
// the file behind the server's back would: what they change must then be found by the evidence.
inline std::string drop_keeping_triggers(const std::string& db) {
  std::string drops;
  sqlite3* h = nullptr;
  sqlite3_open(db.c_str(), &h);
  sqlite3_busy_timeout(h, 5000);
  sqlite3_exec(h, "SELECT name FROM sqlite_master WHERE type = 'trigger' AND name LIKE 'kept\\_%' ESCAPE '\\'",
               [](void* o, int, char** v, char**) {
                 *static_cast<std::string*>(o) += std::string("DROP TRIGGER ") + v[0] + "; ";
                 return 0;
               },
               &drops, nullptr);
  sqlite3_close(h);
  return sql(db, drops);
}

// A passed theory exam for `pupil`, handed out and in at a supervised station by `staff`, who
// supervises it: every question answered with the right choice's place on this paper.
inline void pass_theory(const ApiClient& s, const std::string& staff, int64_t pupil) {
  using nlohmann::json;
  auto [st, a] = s.call("POST", "/api/theory/attempts", staff, json{{"pupil_id", pupil}}.dump());
  ASSERT_EQ(st, 201) << a;
  std::ifstream in(std::string(FORKLIFT_DATA_DIR) + "/theory/questions.json");
  const json bank = json::parse(in);
  json answers = json::object();
  for (const json& q : a["questions"])
    for (const json& b : bank["questions"])
      if (b["id"] == q["id"])
        for (size_t k = 0; k < q["choices"].size(); ++k)
          if (q["choices"][k] == b["choices"][b["answer"].get<size_t>()]) answers[q["id"].get<std::string>()] = k;
  auto [st2, r] = s.call("POST", "/api/theory/attempts/" + std::to_string(a["id"].get<int64_t>()) + "/answers", staff,
                         json{{"answers", answers}}.dump());
  ASSERT_EQ(st2, 200) << r;
  ASSERT_TRUE(r["result"]["passed"].get<bool>()) << r;
}

}  // namespace forklift_test
