// The plumbing of the school's lists: paging, sorting, dates, CSV (lists.h).
#include "lists.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <regex>

#include <spdlog/spdlog.h>

#include "api.h"
#include "forklift/units/decimals.h"

namespace forklift::server {

PageRequest page_request(const httplib::Request& req) {
  PageRequest p;
  p.limit = query_int(req, "limit", 100, 1 << 30);
  p.offset = query_int(req, "offset", 0, 1 << 30);
  if (p.limit < 1 || p.limit > kMaxListLimit)
    throw ApiError(400, "bad_request", "'limit' must be from 1 to " + std::to_string(kMaxListLimit));
  return p;
}

std::pair<std::string, bool> sort_request(const httplib::Request& req, const std::string& dflt, bool dflt_descending) {
  std::string key = req.has_param("sort") ? req.get_param_value("sort") : dflt;
  bool descending = dflt_descending;
  if (req.has_param("order")) {
    const std::string o = req.get_param_value("order");
    if (o != "asc" && o != "desc") throw ApiError(400, "bad_request", "'order' must be asc or desc");
    descending = o == "desc";
  }
  if (key.empty() || key.size() > 32) throw ApiError(400, "bad_request", "'sort' names no column of this list");
  return {key, descending};
}

bool is_iso_date_or_time(const std::string& text) {
  static const std::regex re(R"(\d{4}-\d{2}-\d{2}(T\d{2}:\d{2}(:\d{2})?Z)?)");
  if (!std::regex_match(text, re)) return false;
  std::tm tm{};
  tm.tm_year = std::stoi(text.substr(0, 4)) - 1900;
  tm.tm_mon = std::stoi(text.substr(5, 2)) - 1;
  tm.tm_mday = std::stoi(text.substr(8, 2));
  std::tm check = tm;
  timegm(&check);  // normalises an impossible date (Feb 30) into another
  if (check.tm_mday != tm.tm_mday || check.tm_mon != tm.tm_mon || tm.tm_mon > 11) return false;
  if (text.size() > 10 && (std::stoi(text.substr(11, 2)) > 23 || std::stoi(text.substr(14, 2)) > 59)) return false;
  if (text.size() > 17 && std::stoi(text.substr(17, 2)) > 59) return false;
  return true;
}

std::string iso_time_param(const std::string& text, const char* key) {
  if (!is_iso_date_or_time(text))
    throw ApiError(400, "bad_request", std::string("'") + key + "' must be a date (2026-11-23) or a UTC time (2026-11-23T10:30:00Z)");
  if (text.size() == 10) return text + "T00:00:00Z";
  if (text.size() == 17) return text.substr(0, 16) + ":00Z";
  return text;
}

std::string add_minutes(const std::string& iso, int minutes) {
  std::tm tm{};
  tm.tm_year = std::stoi(iso.substr(0, 4)) - 1900;
  tm.tm_mon = std::stoi(iso.substr(5, 2)) - 1;
  tm.tm_mday = std::stoi(iso.substr(8, 2));
  tm.tm_hour = std::stoi(iso.substr(11, 2));
  tm.tm_min = std::stoi(iso.substr(14, 2)) + minutes;
  tm.tm_sec = std::stoi(iso.substr(17, 2));
  return store::iso8601_of(timegm(&tm));
}

std::string next_day(const std::string& date) { return add_minutes(date + "T00:00:00Z", 24 * 60).substr(0, 10); }

std::pair<std::string, std::string> date_range(const httplib::Request& req) {
  if (req.has_param("date")) {
    const std::string d = req.get_param_value("date");
    if (d.size() != 10 || !is_iso_date_or_time(d)) throw ApiError(400, "bad_request", "'date' must be a date such as 2026-11-23");
    if (req.has_param("from") || req.has_param("to")) throw ApiError(400, "bad_request", "give either 'date' or 'from' and 'to'");
    return {d + "T00:00:00Z", next_day(d) + "T00:00:00Z"};
  }
  std::string from, to;
  if (req.has_param("from")) from = iso_time_param(req.get_param_value("from"), "from");
  if (req.has_param("to")) {
    const std::string t = req.get_param_value("to");
    to = t.size() == 10 && is_iso_date_or_time(t) ? next_day(t) + "T00:00:00Z" : iso_time_param(t, "to");
  }
  return {from, to};
}

std::optional<int64_t> query_id(const httplib::Request& req, const char* key) {
  if (!req.has_param(key)) return std::nullopt;
  const std::string v = req.get_param_value(key);
  if (v.empty() || v.size() > 18 || v.find_first_not_of("0123456789") != std::string::npos)
    throw ApiError(400, "bad_request", std::string("'") + key + "' must be an id (a whole number)");
  return std::stoll(v);
}

bool wants_csv(const httplib::Request& req) {
  if (!req.has_param("format")) return false;
  const std::string f = req.get_param_value("format");
  if (f != "csv" && f != "json") throw ApiError(400, "bad_request", "'format' must be json or csv");
  return f == "csv";
}

std::string csv_cell(const std::string& text) {
  std::string s = text;
  if (!s.empty() && (s[0] == '=' || s[0] == '+' || s[0] == '-' || s[0] == '@' || s[0] == '\t' || s[0] == '\r')) s = "'" + s;
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::string csv_number(std::optional<double> v, int decimals) {
  if (!v || !std::isfinite(*v)) return "";
  return fixed_decimals(*v, decimals);
}

namespace {
void csv_line(std::string& out, const std::vector<std::string>& cells) {
  for (size_t i = 0; i < cells.size(); ++i) {
    if (i) out += ',';
    out += csv_cell(cells[i]);
  }
  out += "\r\n";
}
}  // namespace

std::string csv_table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows) {
  std::string out;
  csv_line(out, header);
  for (const auto& r : rows) csv_line(out, r);
  return out;
}

void send_csv(httplib::Response& res, const std::string& filename, const std::string& csv) {
  res.set_header("Content-Disposition", "attachment; filename=\"" + filename + "\"");
  res.set_content(csv, "text/csv; charset=utf-8");
}

void stream_csv(httplib::Response& res, const std::string& filename, std::vector<std::string> header, CsvRows rows) {
  res.set_header("Content-Disposition", "attachment; filename=\"" + filename + "\"");
  auto sent = std::make_shared<int>(-1);  // the rows sent; -1: not even the header
  res.set_chunked_content_provider(
      "text/csv; charset=utf-8", [filename, header = std::move(header), rows = std::move(rows), sent](size_t, httplib::DataSink& sink) {
        try {
          std::string out;
          if (*sent < 0) {
            csv_line(out, header);
            *sent = 0;
          }
          const std::vector<std::vector<std::string>> batch = rows(*sent, kCsvBatchRows);
          for (const auto& r : batch) csv_line(out, r);
          *sent += int(batch.size());
          if (!sink.write(out.data(), out.size())) return false;
          if (int(batch.size()) < kCsvBatchRows) sink.done();
          return true;
        } catch (const std::exception& e) {
          spdlog::error("{}: the download stopped after {} rows: {}", filename, std::max(0, *sent), e.what());
          return false;
        }
      });
}

nlohmann::json session_notes_json(store::Store& db, People& people, const std::string& session_public_id) {
  const std::vector<store::SessionNote> notes = db.list_session_notes(session_public_id);
  std::vector<const store::SessionNote*> each;
  for (const auto& n : notes) each.push_back(&n);
  return session_notes_json(people, each);
}

nlohmann::json session_notes_json(People& people, const std::vector<const store::SessionNote*>& notes) {
  nlohmann::json out = nlohmann::json::array();
  for (const store::SessionNote* n : notes)
    out.push_back({{"id", n->id}, {"at", n->at}, {"text", n->text}, {"author", people.json(n->author_id)}});
  return out;
}

const std::optional<store::User>& People::user(int64_t id) {
  auto it = seen_.find(id);
  if (it == seen_.end()) it = seen_.emplace(id, db_.get_user(id)).first;
  return it->second;
}

std::string People::name(std::optional<int64_t> user_id) {
  if (!user_id) return "";
  const auto& u = user(*user_id);
  if (!u) return "";
  return u->full_name.empty() ? u->username : u->full_name;
}

nlohmann::json People::json(std::optional<int64_t> user_id) {
  if (!user_id) return nullptr;
  const auto& u = user(*user_id);
  if (!u) return {{"id", *user_id}, {"username", nullptr}, {"name", nullptr}};
  return {{"id", u->id}, {"username", u->username}, {"name", name(user_id)}};
}

}  // namespace forklift::server
