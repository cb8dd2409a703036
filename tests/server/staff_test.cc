// Staff administration over real HTTP: an admin adds, lists, resets,
// deactivates and reactivates accounts, each action in the staff audit log; a deactivated account
// cannot log in and its tokens are refused at once; no one but an admin reaches these endpoints.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support/server.h"

using forklift_test::error_code;
using forklift_test::kAdminPassword;
using forklift_test::Server;
using nlohmann::json;

namespace {

// The actions of the staff audit rows about `user_id`, oldest first.
std::vector<std::string> Actions(const Server& s, const std::string& admin, int64_t user_id) {
  auto [status, rows] = s.call("GET", "/api/users/" + std::to_string(user_id) + "/audit", admin);
  EXPECT_EQ(status, 200) << rows;
  std::vector<std::string> out;
  for (auto it = rows.rbegin(); it != rows.rend(); ++it) out.push_back((*it)["action"].get<std::string>());
  return out;
}

}  // namespace

TEST(Staff, AnAdminAddsDeactivatesReactivatesAndResetsAnExaminer) {
  Server s("staff");
  const std::string admin = s.login("admin", kAdminPassword);
  auto [created, body] = s.call("POST", "/api/users", admin,
                                R"({"username":"erin","password":"erin-pass-1","role":"examiner","full_name":"Erin Examiner"})");
  ASSERT_EQ(created, 201) << body;
  const int64_t erin_id = body["id"].get<int64_t>();
  const std::string erin_path = "/api/users/" + std::to_string(erin_id);

  // Listed by full name, with role and status.
  auto [listed, list] = s.call("GET", "/api/users?role=examiner", admin);
  ASSERT_EQ(listed, 200) << list;
  EXPECT_EQ(list["total"], 1);
  ASSERT_EQ(list["users"].size(), 1u);
  EXPECT_EQ(list["users"][0]["full_name"], "Erin Examiner");
  EXPECT_EQ(list["users"][0]["active"], true);

  // The examiner logs in and works; deactivated, the same token is refused at once, and so is a login.
  const std::string erin = s.login("erin", "erin-pass-1");
  EXPECT_EQ(s.call("GET", "/api/pupils", erin).first, 200);
  auto [deactivated, after] = s.call("POST", erin_path + "/deactivate", admin);
  ASSERT_EQ(deactivated, 200) << after;
  EXPECT_EQ(after["active"], false);
  auto [refused, why] = s.call("GET", "/api/pupils", erin);
  EXPECT_EQ(refused, 401);
  EXPECT_EQ(error_code(why), "account_deactivated") << why;
  auto [login_refused, login_why] = s.call("POST", "/api/login", "", R"({"username":"erin","password":"erin-pass-1"})");
  EXPECT_EQ(login_refused, 403);
  EXPECT_EQ(error_code(login_why), "account_deactivated") << login_why;
  EXPECT_EQ(s.call("GET", "/api/users?active=false", admin).second["total"], 1);
  EXPECT_EQ(s.call("GET", "/api/users?active=true", admin).second["total"], 1);  // the admin

  // Reactivated: a new login works, the token from before stays refused.
  EXPECT_EQ(s.call("POST", erin_path + "/reactivate", admin).second["active"], true);
  EXPECT_EQ(s.call("GET", "/api/pupils", erin).first, 401);
  const std::string erin2 = s.login("erin", "erin-pass-1");
  EXPECT_EQ(s.call("GET", "/api/pupils", erin2).first, 200);

  // A password reset: the old password and the token made with it are refused, the new one works.
  EXPECT_EQ(error_code(s.call("POST", erin_path + "/password", admin, R"({"password":"short"})").second), "bad_request");
  auto [reset, reset_body] = s.call("POST", erin_path + "/password", admin, R"({"password":"erin-new-pass"})");
  ASSERT_EQ(reset, 200) << reset_body;
  EXPECT_EQ(s.call("GET", "/api/pupils", erin2).first, 401);
  EXPECT_EQ(s.call("POST", "/api/login", "", R"({"username":"erin","password":"erin-pass-1"})").first, 401);
  const std::string erin3 = s.login("erin", "erin-new-pass");
  EXPECT_EQ(s.call("GET", "/api/pupils", erin3).first, 200);

  // Every action in the staff audit log, with who made it.
  EXPECT_EQ(Actions(s, admin, erin_id),
            (std::vector<std::string>{"account_created", "account_deactivated", "account_reactivated", "password_reset"}));
  auto [school_status, school_rows] = s.call("GET", "/api/staff-audit", admin);
  ASSERT_EQ(school_status, 200);
  ASSERT_EQ(school_rows.size(), 4u);
  EXPECT_EQ(school_rows[0]["actor"], "admin");
  EXPECT_EQ(school_rows[0]["user_id"], erin_id);
}

TEST(Staff, OnlyAnAdminReachesTheStaffEndpoints) {
  Server s("staff-roles");
  const std::string admin = s.login("admin", kAdminPassword);
  ASSERT_EQ(s.call("POST", "/api/users", admin, R"({"username":"ines","password":"ines-pass-1","role":"instructor"})").first, 201);
  auto [pupil_status, pupil] = s.call("POST", "/api/pupils", admin, R"({"name":"Ana Pupil","username":"ana","password":"ana-pass-1"})");
  ASSERT_EQ(pupil_status, 201) << pupil;
  auto [erin_status, erin] = s.call("POST", "/api/users", admin, R"({"username":"erin","password":"erin-pass-1","role":"examiner"})");
  ASSERT_EQ(erin_status, 201);
  const std::string erin_path = "/api/users/" + std::to_string(erin["id"].get<int64_t>());

  for (const std::string& token : {s.login("ines", "ines-pass-1"), s.login("ana", "ana-pass-1")}) {
    EXPECT_EQ(s.call("GET", "/api/users", token).first, 403);
    EXPECT_EQ(s.call("POST", "/api/users", token, R"({"username":"x","password":"xxxxxxxx","role":"examiner"})").first, 403);
    EXPECT_EQ(s.call("POST", erin_path + "/password", token, R"({"password":"taken-over"})").first, 403);
    EXPECT_EQ(s.call("POST", erin_path + "/deactivate", token).first, 403);
    EXPECT_EQ(s.call("POST", erin_path + "/reactivate", token).first, 403);
    EXPECT_EQ(s.call("GET", erin_path + "/audit", token).first, 403);
    EXPECT_EQ(s.call("GET", "/api/staff-audit", token).first, 403);
    EXPECT_EQ(s.call("PATCH", erin_path, token, R"({"full_name":"Mallory"})").first, 403);
    EXPECT_EQ(s.call("PATCH", erin_path, token, R"({"language":"es"})").first, 403);  // another's language
  }
  // A member of staff chooses their own language; the administrator anyone's; the next login says it.
  const std::string ines_token = s.login("ines", "ines-pass-1");
  const json ines = s.call("POST", "/api/login", "", R"({"username":"ines","password":"ines-pass-1"})").second;
  EXPECT_EQ(ines["language"], "en");
  const std::string ines_path = "/api/users/" + std::to_string(ines["user_id"].get<int64_t>());
  EXPECT_EQ(s.call("PATCH", ines_path, ines_token, R"({"language":"es"})").second["language"], "es");
  EXPECT_EQ(s.call("PATCH", ines_path, ines_token, R"({"language":"es","full_name":"Ines I"})").first, 403);
  EXPECT_EQ(s.call("POST", "/api/login", "", R"({"username":"ines","password":"ines-pass-1"})").second["language"], "es");
  EXPECT_EQ(s.call("PATCH", erin_path, admin, R"({"language":"es"})").second["language"], "es");
  EXPECT_EQ(s.call("GET", erin_path, admin).second["language"], "es");
  EXPECT_EQ(s.call("PATCH", erin_path, admin, R"({"language":"xx"})").first, 400);
  // Nothing changed: erin still logs in with her password.
  s.login("erin", "erin-pass-1");
}

TEST(Staff, TheLastActiveAdminStays) {
  Server s("staff-admins");
  const std::string admin = s.login("admin", kAdminPassword);
  const int64_t admin_id = s.call("GET", "/api/users?role=admin", admin).second["users"][0]["id"].get<int64_t>();
  const std::string admin_path = "/api/users/" + std::to_string(admin_id);
  EXPECT_EQ(error_code(s.call("POST", admin_path + "/deactivate", admin).second), "cannot_deactivate_self");

  auto [made, body] = s.call("POST", "/api/users", admin, R"({"username":"ada","password":"ada-pass-1","role":"admin","full_name":"Ada Admin"})");
  ASSERT_EQ(made, 201);
  const std::string ada_path = "/api/users/" + std::to_string(body["id"].get<int64_t>());
  const std::string ada = s.login("ada", "ada-pass-1");
  // Ada deactivates the first admin, whose token then fails; Ada, the last active admin, is
  // refused as herself (the store's own refusal of the last admin is in store_test.cc).
  EXPECT_EQ(s.call("POST", admin_path + "/deactivate", ada).first, 200);
  EXPECT_EQ(s.call("GET", "/api/users", admin).first, 401);
  EXPECT_EQ(error_code(s.call("POST", ada_path + "/deactivate", ada).second), "cannot_deactivate_self");
  EXPECT_EQ(s.call("GET", "/api/users?role=admin&active=true", ada).second["total"], 1);
}

TEST(Staff, TheListIsPagedSortedByFullNameAndLeavesPupilsOutUnlessAsked) {
  Server s("staff-list");
  const std::string admin = s.login("admin", kAdminPassword);
  const std::string admin_path =
      "/api/users/" + std::to_string(s.call("GET", "/api/users?role=admin", admin).second["users"][0]["id"].get<int64_t>());
  ASSERT_EQ(s.call("PATCH", admin_path, admin, R"({"full_name":"Zoe Admin"})").first, 200);
  for (const auto& [user, name] : std::vector<std::pair<std::string, std::string>>{
           {"carl", "carl Instructor"}, {"bea", "Bea Examiner"}, {"abe", "Abe Instructor"}}) {
    const json b = {{"username", user}, {"password", "long-enough"}, {"role", user == "bea" ? "examiner" : "instructor"},
                    {"full_name", name}};
    ASSERT_EQ(s.call("POST", "/api/users", admin, b.dump()).first, 201);
  }
  ASSERT_EQ(s.call("POST", "/api/pupils", admin, R"({"name":"Ana Pupil","username":"ana","password":"ana-pass-1"})").first, 201);

  auto names = [&](const std::string& query) {
    std::vector<std::string> out;
    const json page = s.call("GET", "/api/users" + query, admin).second;
    for (const auto& u : page["users"]) out.push_back(u["username"]);
    return out;
  };
  EXPECT_EQ(names(""), (std::vector<std::string>{"abe", "bea", "carl", "admin"}));  // capitals read as small letters
  EXPECT_EQ(names("?limit=2&offset=1"), (std::vector<std::string>{"bea", "carl"}));
  EXPECT_EQ(s.call("GET", "/api/users?limit=2&offset=1", admin).second["total"], 4);
  EXPECT_EQ(names("?role=instructor"), (std::vector<std::string>{"abe", "carl"}));
  EXPECT_EQ(names("?include_pupils=true").size(), 5u);
  EXPECT_EQ(names("?role=pupil"), std::vector<std::string>{"ana"});
  EXPECT_EQ(error_code(s.call("GET", "/api/users?limit=1001", admin).second), "bad_request");
  EXPECT_EQ(error_code(s.call("GET", "/api/users?role=janitor", admin).second), "bad_request");
  EXPECT_EQ(error_code(s.call("GET", "/api/users?active=yes", admin).second), "bad_request");
  // The full name's change is audited with its before and after.
  const json rows = s.call("GET", admin_path + "/audit", admin).second;
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0]["action"], "full_name_changed");
  EXPECT_EQ(rows[0]["details"]["after"], "Zoe Admin");
}
