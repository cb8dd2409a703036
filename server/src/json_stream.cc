#include "json_stream.h"

#include <cmath>
#include <rapidjson/encodings.h>

namespace forklift::server {
namespace {

// Whether s[0, n) is well-formed UTF-8, by RapidJSON's own decoder (a sequence cut short at the
// end meets the NUL after it, which no sequence continues with).
bool is_utf8(const char* s, size_t n) {
  struct Sink {
    void Put(char) {}
  } sink;
  rapidjson::GenericStringStream<rapidjson::UTF8<>> in(s);
  while (in.Tell() < n)
    if (!rapidjson::UTF8<>::Validate(in, sink)) return false;
  return true;
}

}  // namespace

JsonStream& JsonStream::text_value(const char* s, size_t n) {
  if (!is_utf8(s, n)) return raw(nlohmann::json(std::string(s, n)));
  writer_.String(s, static_cast<rapidjson::SizeType>(n));
  return *this;
}

JsonStream& JsonStream::value(double v) {
  if (!std::isfinite(v)) return value(nullptr);
  writer_.Double(v);
  return *this;
}

JsonStream& JsonStream::raw(const nlohmann::json& j) {
  const std::string text = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  writer_.RawValue(text.data(), text.size(), j.is_object() ? rapidjson::kObjectType
                                              : j.is_array() ? rapidjson::kArrayType
                                              : j.is_string() ? rapidjson::kStringType
                                              : rapidjson::kNumberType);
  return *this;
}

}  // namespace forklift::server
