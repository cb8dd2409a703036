// What the school's lists share: a page of a list from the request's limit
// and offset, its sort key and order, a date or a range of dates, an id in the query, and the
// whole filtered list as CSV, in the order shown, streamed, safe to open in a spreadsheet.
#pragma once

#include <httplib.h>

#include <cstdint>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "api.h"
#include "forklift/store/store.h"

namespace forklift::server {

// The most rows a page of a list has (the API's documented limit; more is a 400).
constexpr int kMaxListLimit = 1000;

struct PageRequest {
  int limit = 100, offset = 0;
};
// limit (1-1000, default 100) and offset (default 0), else 400.
PageRequest page_request(const httplib::Request& req);

// The sort key (`sort`, default `dflt`; the store refuses a key not in its list) and whether it
// is descending (`order` asc or desc, default `dflt_descending`), else 400.
std::pair<std::string, bool> sort_request(const httplib::Request& req, const std::string& dflt, bool dflt_descending);

// The time range a list asks for: `date` (YYYY-MM-DD: that UTC day) or `from` and `to` (dates or
// ISO-8601 UTC times; `to` exclusive, a date meaning the day after it ends); empty: open. 400 for
// anything else.
std::pair<std::string, std::string> date_range(const httplib::Request& req);

// Whether `text` is a date (YYYY-MM-DD) or an ISO-8601 UTC time (YYYY-MM-DDTHH:MM[:SS]Z).
bool is_iso_date_or_time(const std::string& text);
// `text` (a date or time as is_iso_date_or_time takes it) as YYYY-MM-DDTHH:MM:SSZ, else 400 naming `key`.
std::string iso_time_param(const std::string& text, const char* key);
// `iso` (YYYY-MM-DDTHH:MM:SSZ) `minutes` later, in the same form.
std::string add_minutes(const std::string& iso, int minutes);
// The UTC day after `date` (YYYY-MM-DD).
std::string next_day(const std::string& date);

// A whole-number id in the query, if given, else 400.
std::optional<int64_t> query_id(const httplib::Request& req, const char* key);

// Whether the list is asked for as CSV (`format=csv`); any other format but json is a 400.
bool wants_csv(const httplib::Request& req);

// One CSV cell: quoted when it holds a comma, quote or line break; a cell that a spreadsheet
// would read as a formula (starting with = + - @, a tab or a carriage return) is prefixed with '
// so that it stays text (CSV injection).
std::string csv_cell(const std::string& text);
// A number with `decimals` decimals ("" for none): marks to 1 decimal.
std::string csv_number(std::optional<double> v, int decimals = 1);
// A CSV document from its header and rows, cells as csv_cell makes them.
std::string csv_table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);
// Sends `csv` as a download named `filename`.
void send_csv(httplib::Response& res, const std::string& filename, const std::string& csv);

// The rows of a list from `offset`, at most `limit` of them (fewer: the list ends there), as
// CSV cells. Called on the request's own thread (its ctx.db() is the request's), as the client
// reads, after the handler has returned: it may hold nothing of the handler's by reference.
using CsvRows = std::function<std::vector<std::vector<std::string>>(int offset, int limit)>;
// How many rows a CSV download reads from the store at a time.
constexpr int kCsvBatchRows = 500;
// Sends the whole list `rows` gives as a CSV download named `filename`: the header, then
// kCsvBatchRows rows at a time, chunked as the client reads them, so that a list of any length
// never sits whole in memory. A failure mid-way (the store) ends the download short, logged.
void stream_csv(httplib::Response& res, const std::string& filename, std::vector<std::string> header, CsvRows rows);

// `find()` (a store's list call), its kInvalid (an unknown sort key, outcome or result) a 400 in
// words without the store's call name.
template <class F>
auto listed(F&& find) {
  try {
    return find();
  } catch (const store::StoreError& e) {
    if (e.kind() != store::StoreError::kInvalid) throw;
    const std::string what = e.what();
    const auto colon = what.find(": ");
    throw ApiError(400, "bad_request", colon == std::string::npos ? what : what.substr(colon + 2));
  }
}

// The staff a list names, each read once per request: by full name, else username.
class People {
 public:
  explicit People(store::AccountStore& db) : db_(db) {}
  std::string name(std::optional<int64_t> user_id);
  // {"id", "username", "name"} as person_json, or null.
  nlohmann::json json(std::optional<int64_t> user_id);

 private:
  const std::optional<store::User>& user(int64_t id);
  store::AccountStore& db_;
  std::map<int64_t, std::optional<store::User>> seen_;
};

// A session's debrief notes, oldest first: [{"id", "at", "text", "author": people.json}].
nlohmann::json session_notes_json(store::Store& db, People& people, const std::string& session_public_id);
// The same of notes read already (a pupil's history's, of one session).
nlohmann::json session_notes_json(People& people, const std::vector<const store::SessionNote*>& notes);

}  // namespace forklift::server
