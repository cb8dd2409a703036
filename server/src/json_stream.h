// JSON written as a stream into one string (RapidJSON's Writer), for the answers read most often
// (a pupil's history): no document of nodes to build, copy and free before the text exists,
// which cost two thirds of such a request. Parts built as a document elsewhere go in with raw().
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include <rapidjson/stringbuffer.h>
#include <rapidjson/writer.h>

namespace forklift::server {

class JsonStream {
 public:
  JsonStream() : writer_(buffer_) {}
  JsonStream& begin_object() { writer_.StartObject(); return *this; }
  JsonStream& end_object() { writer_.EndObject(); return *this; }
  JsonStream& begin_array() { writer_.StartArray(); return *this; }
  JsonStream& end_array() { writer_.EndArray(); return *this; }
  JsonStream& key(const char* k) { writer_.Key(k); return *this; }

  // Text that is not UTF-8 (a reason quoted from the wire, say) goes out with U+FFFD in place of
  // the bad bytes, as send_json() writes it, never as an invalid document.
  JsonStream& value(const std::string& s) { return text_value(s); }
  JsonStream& value(const char* s) { return text_value(s); }
  JsonStream& value(bool b) { writer_.Bool(b); return *this; }
  JsonStream& value(int v) { writer_.Int(v); return *this; }
  JsonStream& value(int64_t v) { writer_.Int64(v); return *this; }
  JsonStream& value(double v);  // not finite: null, as nlohmann writes it
  JsonStream& value(std::nullptr_t) { writer_.Null(); return *this; }
  template <class T>
  JsonStream& value(const std::optional<T>& v) { return v ? value(*v) : value(nullptr); }
  // A part built as a document (a rare or small one): its text, in place.
  JsonStream& raw(const nlohmann::json& j);
  template <class T>
  JsonStream& field(const char* k, const T& v) { key(k); return value(v); }

  std::string text() const { return std::string(buffer_.GetString(), buffer_.GetSize()); }

 private:
  JsonStream& text_value(std::string_view s);
  rapidjson::StringBuffer buffer_;
  rapidjson::Writer<rapidjson::StringBuffer> writer_;
};

}  // namespace forklift::server
