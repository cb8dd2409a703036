// The school's lists and its day over real HTTP: pupils, sessions and
// exams a page at a time with the total, filtered and sorted by the server, and as CSV exactly as
// listed; groups with their instructor; cabs booked without double booking, and the day view.
// Sessions and exams are written straight into the server's SQLite file (the store's public
// interface): running real drives for them would make the test slow and say nothing more here.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "forklift/store/store.h"
#include "support/server.h"

using forklift_test::error_code;
using forklift_test::kAdminPassword;
using forklift_test::Server;
using nlohmann::json;
namespace fs = forklift::store;

namespace {

// The body of a GET as text (CSV), with its status.
std::pair<int, std::string> get_text(const Server& s, const std::string& path, const std::string& token) {
  auto r = s.client().Get(path, {{"Authorization", "Bearer " + token}});
  return r ? std::pair(r->status, r->body) : std::pair(0, std::string());
}

// CSV rows as cells (no quoted commas in what these tests write, but for quotes around a cell).
std::vector<std::vector<std::string>> csv_rows(const std::string& text) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::vector<std::string> cells;
    std::istringstream in(line);
    for (std::string c; std::getline(in, c, ',');) cells.push_back(c);
    rows.push_back(cells);
  }
  return rows;
}

int64_t id_of(const json& j) { return j["id"].get<int64_t>(); }

}  // namespace

TEST(Lists, PupilsArePagedSearchedSortedAndExportedAsShown) {
  Server s("lists-pupils");
  const std::string admin = s.login("admin", kAdminPassword);
  for (int i = 0; i < 30; ++i) {
    const std::string n = std::to_string(100 + i);
    const json b = {{"name", "Pupil " + n}, {"email", "p" + n + (i % 3 ? "@depot.example" : "@yard.example")}};
    ASSERT_EQ(s.call("POST", "/api/pupils", admin, b.dump()).first, 201);
  }
  ASSERT_EQ(s.call("POST", "/api/pupils", admin, json{{"name", "=HYPERLINK(\"x\")"}, {"email", "@evil.example"}}.dump()).first, 201);

  auto [st, page] = s.call("GET", "/api/pupils?limit=10&offset=10", admin);
  ASSERT_EQ(st, 200) << page;
  EXPECT_EQ(page["total"], 31);
  EXPECT_EQ(page["limit"], 10);
  EXPECT_EQ(page["offset"], 10);
  ASSERT_EQ(page["pupils"].size(), 10u);
  EXPECT_EQ(page["pupils"][0]["name"], "Pupil 109");  // by name: "=HYPERLINK" sorts first
  EXPECT_FALSE(page["total_is_at_least"].get<bool>());

  // The next page by keyset (after= the last row's id) is the next page by offset.
  auto [first_st, first] = s.call("GET", "/api/pupils?limit=10", admin);
  ASSERT_EQ(first_st, 200) << first;
  ASSERT_TRUE(first.contains("next_after")) << first;
  EXPECT_EQ(first["next_after"], first["pupils"][9]["id"]);
  auto [next_st, next] = s.call("GET", "/api/pupils?limit=10&after=" + std::to_string(first["next_after"].get<int64_t>()), admin);
  ASSERT_EQ(next_st, 200) << next;
  EXPECT_EQ(next["pupils"], page["pupils"]);
  EXPECT_EQ(next["total"], 31);
  auto [last_st, last] = s.call("GET", "/api/pupils?limit=10&offset=30", admin);
  EXPECT_FALSE(last.contains("next_after")) << last;  // no page follows
  EXPECT_EQ(s.call("GET", "/api/pupils?after=" + std::to_string(first["next_after"].get<int64_t>()) + "&sort=group", admin).first, 400);
  EXPECT_EQ(s.call("GET", "/api/pupils?after=999999", admin).first, 404);

  auto [sst, yard] = s.call("GET", "/api/pupils?search=YARD.example&sort=email&order=desc", admin);
  ASSERT_EQ(sst, 200) << yard;
  EXPECT_EQ(yard["total"], 10);
  EXPECT_EQ(yard["pupils"][0]["email"], "p127@yard.example");
  EXPECT_EQ(yard["pupils"][9]["email"], "p100@yard.example");

  // The CSV is the whole filtered list in its order, every page of it: a page's limit and offset
  // do not cut it.
  auto [cst, csv] = get_text(s, "/api/pupils?search=YARD.example&sort=email&order=desc&limit=3&offset=3&format=csv", admin);
  ASSERT_EQ(cst, 200) << csv;
  const auto rows = csv_rows(csv);
  ASSERT_EQ(rows.size(), 11u) << csv;
  EXPECT_EQ(rows[0], (std::vector<std::string>{"id", "name", "email", "group", "instructor", "added"}));
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(rows[i + 1][1], yard["pupils"][i]["name"]) << csv;
    EXPECT_EQ(rows[i + 1][2], yard["pupils"][i]["email"]) << csv;
  }
  // A cell a spreadsheet would run as a formula stays text.
  auto [est, evil] = get_text(s, "/api/pupils?search=evil&format=csv", admin);
  ASSERT_EQ(est, 200);
  EXPECT_NE(evil.find("\"'=HYPERLINK(\"\"x\"\")\",'@evil.example"), std::string::npos) << evil;

  // Bad lists are refused in words.
  auto [bad_sort, why] = s.call("GET", "/api/pupils?sort=password", admin);
  EXPECT_EQ(bad_sort, 400);
  EXPECT_NE(why["error"]["message"].get<std::string>().find("'sort' must be name, email, created_at or group (found password)"), std::string::npos) << why;
  EXPECT_EQ(why["error"]["message"].get<std::string>().find("find_pupils"), std::string::npos) << "no internals: " << why;
  EXPECT_EQ(s.call("GET", "/api/pupils?limit=1001", admin).first, 400);
  EXPECT_EQ(s.call("GET", "/api/pupils?order=sideways", admin).first, 400);
  EXPECT_EQ(s.call("GET", "/api/pupils?format=xml", admin).first, 400);
  EXPECT_EQ(s.call("GET", "/api/pupils?group=abc", admin).first, 400);
}

TEST(Lists, GroupsHaveTheirInstructorWhoSeesTheirPupilsFirstAndEveryChangeIsAudited) {
  Server s("lists-groups");
  const std::string admin = s.login("admin", kAdminPassword);
  ASSERT_EQ(s.call("POST", "/api/users", admin,
                   R"({"username":"ines","password":"ines-pass-1","role":"instructor","full_name":"Ines Instructor"})")
                .first,
            201);
  const std::string ines = s.login("ines", "ines-pass-1");
  const int64_t ines_id = s.call("GET", "/api/users?role=instructor", admin).second["users"][0]["id"];
  const json ann = s.call("POST", "/api/pupils", admin, R"({"name":"Ann"})").second;
  const json zoe = s.call("POST", "/api/pupils", admin, R"({"name":"Zoe"})").second;

  auto [gst, group] = s.call("POST", "/api/groups", ines, json{{"name", "Morning course"}, {"instructor_id", ines_id}}.dump());
  ASSERT_EQ(gst, 201) << group;
  EXPECT_EQ(group["instructor"]["name"], "Ines Instructor");
  const std::string gpath = "/api/groups/" + std::to_string(id_of(group));
  EXPECT_EQ(error_code(s.call("POST", "/api/groups", admin, R"({"name":"MORNING course"})").second), "group_exists");
  EXPECT_EQ(s.call("POST", "/api/groups", admin, R"({"name":"X","colour":"red"})").first, 400);
  EXPECT_EQ(s.call("POST", "/api/groups", admin, R"({"name":"X","instructor_id":999})").first, 400);
  auto [rst, renamed] = s.call("PATCH", gpath, admin, R"({"name":"Morning course A"})");
  ASSERT_EQ(rst, 200) << renamed;
  EXPECT_EQ(renamed["name"], "Morning course A");

  // Zoe moves into Ines's group: Ines sees her first, before Ann, whom the name would put first.
  const std::string zoe_group = "/api/pupils/" + std::to_string(id_of(zoe)) + "/group";
  auto [mst, moved] = s.call("PUT", zoe_group, ines, json{{"group_id", id_of(group)}}.dump());
  ASSERT_EQ(mst, 200) << moved;
  EXPECT_EQ(moved["group_id"], id_of(group));
  EXPECT_EQ(s.call("GET", "/api/pupils", ines).second["pupils"][0]["name"], "Zoe");
  EXPECT_EQ(s.call("GET", "/api/pupils?mine_first=false", ines).second["pupils"][0]["name"], "Ann");
  EXPECT_EQ(s.call("GET", "/api/pupils", admin).second["pupils"][0]["name"], "Ann");
  const json mine = s.call("GET", "/api/pupils?instructor=" + std::to_string(ines_id), admin).second;
  EXPECT_EQ(mine["total"], 1);
  EXPECT_EQ(mine["pupils"][0]["group"], "Morning course A");
  EXPECT_EQ(s.call("GET", "/api/pupils?group=" + std::to_string(id_of(group)), admin).second["total"], 1);
  EXPECT_EQ(s.call("GET", "/api/pupils?group=0", admin).second["pupils"][0]["name"], "Ann");  // in no group
  const json groups = s.call("GET", "/api/groups", admin).second;
  ASSERT_EQ(groups["groups"].size(), 1u);
  EXPECT_EQ(groups["groups"][0]["pupils"], 1);

  // Audited: the move in Zoe's record, the group in the staff audit log under its instructor.
  const json rows = s.call("GET", "/api/pupils/" + std::to_string(id_of(zoe)) + "/audit", admin).second;
  ASSERT_FALSE(rows.empty());
  EXPECT_EQ(rows[0]["action"], "group_changed");
  EXPECT_EQ(rows[0]["details"]["after"], "Morning course A");
  std::set<std::string> staff_actions;
  for (const json& r : s.call("GET", "/api/users/" + std::to_string(ines_id) + "/audit", admin).second)
    staff_actions.insert(r["action"].get<std::string>());
  EXPECT_TRUE(staff_actions.count("group_created") && staff_actions.count("group_changed"));

  // Out of the group again; a pupil cannot move anyone.
  EXPECT_EQ(s.call("PUT", zoe_group, admin, R"({"group_id":null})").second["group_id"], nullptr);
  EXPECT_EQ(s.call("PUT", zoe_group, admin, R"({"group_id":12345})").first, 404);
  EXPECT_EQ(s.call("PUT", zoe_group, admin, "{}").first, 400);
}

TEST(Lists, SessionsAndExamsAreFilteredSortedAndExportedAsShown) {
  Server s("lists-sessions");
  const std::string admin = s.login("admin", kAdminPassword);
  ASSERT_EQ(s.call("POST", "/api/users", admin,
                   R"({"username":"ines","password":"ines-pass-1","role":"instructor","full_name":"Ines Instructor"})")
                .first,
            201);
  const int64_t ines = s.call("GET", "/api/users?role=instructor", admin).second["users"][0]["id"];
  const int64_t ann = id_of(s.call("POST", "/api/pupils", admin, R"({"name":"Ann Archer","email":"ann@depot.example"})").second);
  const int64_t bob = id_of(s.call("POST", "/api/pupils", admin, R"({"name":"Bob Baker"})").second);

  // A day of sessions and a theory and a practical exam, written as the server would have.
  std::vector<std::string> day;
  {
    auto db = fs::Store::open_sqlite(s.db);
    auto ended = [&](int64_t pupil, const std::string& cab, const std::string& at, std::optional<int64_t> by,
                     const std::string& reason, std::optional<double> mark, bool passed = true) {
      const std::string id = db->create_session(pupil, cab, "manoeuvre_4", forklift::Mode::kTraining, std::nullopt, at, by).public_id;
      if (mark) db->set_score({id, *mark, passed, {}}, at);
      db->set_session_state(id, forklift::SessionPhase::kEnded, reason, at);
      return id;
    };
    day.push_back(ended(ann, "cab1", "2026-11-23T08:00:00Z", ines, "task_complete", 82.456));
    day.push_back(ended(bob, "cab2", "2026-11-23T09:00:00Z", std::nullopt, "time_limit", std::nullopt));
    day.push_back(ended(bob, "cab1", "2026-11-23T10:00:00Z", ines, "task_complete", 40, false));
    ended(ann, "cab1", "2026-11-24T08:00:00Z", ines, "task_complete", 90);
    fs::ExamRecord theory;
    theory.pupil_id = ann;
    theory.kind = forklift::ExamKind::kTheory;
    theory.score = 0.875;
    theory.passed = true;
    theory.taken_at = "2026-11-23T11:00:00Z";
    db->add_exam(theory);
    theory.pupil_id = bob;
    theory.score = 0.5;
    theory.passed = false;
    db->add_exam(theory);
  }

  auto [st, cab1] = s.call("GET", "/api/sessions?date=2026-11-23&cab=cab1", admin);
  ASSERT_EQ(st, 200) << cab1;
  EXPECT_EQ(cab1["total"], 2);
  ASSERT_EQ(cab1["sessions"].size(), 2u);
  EXPECT_EQ(cab1["sessions"][0]["id"], day[2]);  // newest first
  EXPECT_EQ(cab1["sessions"][0]["pupil_name"], "Bob Baker");
  EXPECT_EQ(cab1["sessions"][0]["started_by"]["name"], "Ines Instructor");
  EXPECT_EQ(cab1["sessions"][1]["id"], day[0]);
  EXPECT_EQ(s.call("GET", "/api/sessions?date=2026-11-23", admin).second["total"], 3);
  EXPECT_EQ(s.call("GET", "/api/sessions?from=2026-11-23&to=2026-11-24", admin).second["total"], 4);  // to: the whole day
  EXPECT_EQ(s.call("GET", "/api/sessions?instructor=" + std::to_string(ines), admin).second["total"], 3);
  EXPECT_EQ(s.call("GET", "/api/sessions?result=passed&date=2026-11-23", admin).second["sessions"][0]["id"], day[0]);
  EXPECT_EQ(s.call("GET", "/api/sessions?outcome=timed_out", admin).second["sessions"][0]["id"], day[1]);
  EXPECT_EQ(s.call("GET", "/api/sessions?search=depot", admin).second["total"], 2);
  // The next page by keyset (after= the last row's id) is the next page by offset.
  const json first_page = s.call("GET", "/api/sessions?limit=2", admin).second;
  ASSERT_TRUE(first_page.contains("next_after")) << first_page;
  EXPECT_EQ(first_page["next_after"], first_page["sessions"][1]["id"]);
  EXPECT_EQ(s.call("GET", "/api/sessions?limit=2&after=" + first_page["next_after"].get<std::string>(), admin).second["sessions"],
            s.call("GET", "/api/sessions?limit=2&offset=2", admin).second["sessions"]);
  EXPECT_EQ(s.call("GET", "/api/sessions?after=s-999999", admin).first, 404);
  EXPECT_EQ(s.call("GET", "/api/sessions?sort=cab&after=" + first_page["next_after"].get<std::string>(), admin).first, 400);
  EXPECT_EQ(s.call("GET", "/api/sessions?pupil=" + std::to_string(bob) + "&sort=created_at&order=asc", admin).second["sessions"][0]["id"],
            day[1]);
  for (const char* bad : {"date=23/11/2026", "date=2026-02-30", "outcome=won", "result=maybe", "sort=secret", "mode=racing",
                          "from=yesterday", "limit=0"}) {
    auto [code, why] = s.call("GET", std::string("/api/sessions?") + bad, admin);
    EXPECT_EQ(code, 400) << bad << ": " << why;
    EXPECT_EQ(error_code(why), "bad_request") << bad;
  }

  // The CSV of the filtered list: its rows, with names, marks to one decimal.
  auto [cst, csv] = get_text(s, "/api/sessions?date=2026-11-23&cab=cab1&format=csv", admin);
  ASSERT_EQ(cst, 200) << csv;
  const auto rows = csv_rows(csv);
  ASSERT_EQ(rows.size(), 3u) << csv;
  EXPECT_EQ(rows[0][0], "session");
  EXPECT_EQ(rows[1][0], day[2]);
  EXPECT_EQ(rows[2][0], day[0]);
  EXPECT_EQ(rows[2][2], "Ann Archer");
  EXPECT_EQ(rows[2][6], "Ines Instructor");
  EXPECT_EQ(rows[2][8], "82.5");
  EXPECT_EQ(rows[2][9], "yes");
  EXPECT_EQ(s.call("GET", "/api/sessions?sort=secret&format=csv", admin).first, 400) << "a CSV's filter is checked before it streams";

  // Exams: theory scores as a percentage in their own column, apart from practical marks.
  auto [est, exams] = s.call("GET", "/api/exams?kind=theory&sort=score&order=desc", admin);
  ASSERT_EQ(est, 200) << exams;
  EXPECT_EQ(exams["total"], 2);
  EXPECT_EQ(exams["exams"][0]["pupil_name"], "Ann Archer");
  EXPECT_EQ(s.call("GET", "/api/exams?result=not_passed", admin).second["exams"][0]["pupil_name"], "Bob Baker");
  auto [xst, xcsv] = get_text(s, "/api/exams?kind=theory&sort=score&order=desc&format=csv", admin);
  ASSERT_EQ(xst, 200);
  const auto xrows = csv_rows(xcsv);
  ASSERT_EQ(xrows.size(), 3u) << xcsv;
  EXPECT_EQ(xrows[0][5], "practical_mark");
  EXPECT_EQ(xrows[0][6], "theory_percent");
  EXPECT_EQ(xrows[1][5], "");
  EXPECT_EQ(xrows[1][6], "87.5");
  EXPECT_EQ(s.call("GET", "/api/exams?kind=oral", admin).first, 400);
  const json first_exam = s.call("GET", "/api/exams?limit=1", admin).second;
  ASSERT_TRUE(first_exam.contains("next_after")) << first_exam;
  EXPECT_EQ(s.call("GET", "/api/exams?limit=1&after=" + std::to_string(first_exam["next_after"].get<int64_t>()), admin).second["exams"],
            s.call("GET", "/api/exams?limit=1&offset=1", admin).second["exams"]);
  EXPECT_EQ(s.call("GET", "/api/exams?after=999999", admin).first, 404);

  // Pupils have no school lists.
  ASSERT_EQ(s.call("POST", "/api/users", admin,
                   json{{"username", "ann"}, {"password", "ann-pass-1"}, {"role", "pupil"}, {"pupil_id", ann}}.dump())
                .first,
            201);
  const std::string pupil = s.login("ann", "ann-pass-1");
  EXPECT_EQ(s.call("GET", "/api/sessions", pupil).first, 403);
  EXPECT_EQ(s.call("GET", "/api/exams", pupil).first, 403);
}

TEST(Lists, ACabIsBookedOnceAtATimeAndTheDayShowsBookingsAndSessions) {
  Server s("lists-bookings");
  const std::string admin = s.login("admin", kAdminPassword);
  const int64_t ann = id_of(s.call("POST", "/api/pupils", admin, R"({"name":"Ann"})").second);
  const int64_t bob = id_of(s.call("POST", "/api/pupils", admin, R"({"name":"Bob"})").second);
  auto book = [&](int64_t pupil, const std::string& cab, const std::string& at, int minutes) {
    return s.call("POST", "/api/bookings", admin,
                  json{{"pupil_id", pupil}, {"cab_id", cab}, {"starts_at", at}, {"duration_min", minutes}, {"scenario", "manoeuvre_4"}}
                      .dump());
  };
  auto [st, first] = book(ann, "cab1", "2026-11-23T09:00:00Z", 60);
  ASSERT_EQ(st, 201) << first;
  EXPECT_EQ(first["ends_at"], "2026-11-23T10:00:00Z");
  EXPECT_EQ(first["pupil"]["name"], "Ann");
  auto [clash, why] = book(bob, "cab1", "2026-11-23T09:30:00Z", 60);
  EXPECT_EQ(clash, 409);
  EXPECT_EQ(error_code(why), "cab_booked") << why;
  EXPECT_EQ(book(bob, "cab1", "2026-11-23T10:00:00Z", 30).first, 201);  // back to back
  EXPECT_EQ(book(bob, "cab2", "2026-11-23T09:30:00Z", 60).first, 201);  // another cab
  EXPECT_EQ(book(bob, "cab3", "2026-11-23T09:30:00Z", 0).first, 400);
  EXPECT_EQ(book(bob, "cab3", "tomorrow", 30).first, 400);
  EXPECT_EQ(book(bob, "cab 3", "2026-11-23T09:30:00Z", 30).first, 400);
  EXPECT_EQ(s.call("POST", "/api/bookings", admin,
                   json{{"pupil_id", bob}, {"cab_id", "cab3"}, {"starts_at", "2026-11-23T09:00:00Z"}, {"duration_min", 30},
                        {"scenario", "no_such_course"}}.dump())
                .first,
            404);

  {
    auto db = fs::Store::open_sqlite(s.db);
    const std::string id = db->create_session(ann, "cab4", "manoeuvre_4", forklift::Mode::kTraining, std::nullopt, "2026-11-23T13:00:00Z").public_id;
    db->set_session_state(id, forklift::SessionPhase::kEnded, "task_complete", "2026-11-23T13:10:00Z");
  }
  auto [dst, d] = s.call("GET", "/api/day?date=2026-11-23", admin);
  ASSERT_EQ(dst, 200) << d;
  EXPECT_EQ(d["bookings"].size(), 3u);
  EXPECT_EQ(d["sessions"].size(), 1u);
  EXPECT_EQ(d["cabs"], (json{"cab1", "cab2", "cab4"}));
  EXPECT_EQ(s.call("GET", "/api/bookings?date=2026-11-24", admin).second["total"], 0);

  // Cancelled: gone from the day, and in Ann's record; so is the booking.
  const std::string path = "/api/bookings/" + std::to_string(id_of(first));
  EXPECT_EQ(s.call("DELETE", path, admin).first, 200);
  EXPECT_EQ(s.call("DELETE", path, admin).first, 404);
  EXPECT_EQ(s.call("GET", "/api/bookings?date=2026-11-23", admin).second["total"], 2);
  std::vector<std::string> actions;
  for (const json& r : s.call("GET", "/api/pupils/" + std::to_string(ann) + "/audit", admin).second)
    actions.push_back(r["action"]);
  ASSERT_GE(actions.size(), 2u);
  EXPECT_EQ(actions[0], "booking_cancelled");
  EXPECT_EQ(actions[1], "session_booked");

  // A booked session started from the day: the booking names its session.
  auto [bst, now_booked] = book(ann, "cab9", "2026-11-23T15:00:00Z", 30);
  ASSERT_EQ(bst, 201) << now_booked;
  auto [sst, started] = s.call("POST", "/api/bookings/" + std::to_string(id_of(now_booked)) + "/start", admin,
                               R"({"time_limit_s": 1})");
  ASSERT_EQ(sst, 201) << started;
  EXPECT_EQ(started["cab_id"], "cab9");
  EXPECT_EQ(started["pupil_id"], ann);
  json booked_now;
  const json listed = s.call("GET", "/api/bookings?date=2026-11-23", admin).second;
  for (const json& b : listed["bookings"])
    if (b["id"] == now_booked["id"]) booked_now = b;
  EXPECT_EQ(booked_now["session"], started["id"]) << listed;
  EXPECT_EQ(error_code(s.call("POST", "/api/bookings/" + std::to_string(id_of(now_booked)) + "/start", admin).second),
            "booking_started");
  s.call("POST", "/api/sessions/" + started["id"].get<std::string>() + "/abort", admin);
}
