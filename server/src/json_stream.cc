#include "json_stream.h"

#include <cmath>

#include "forklift/protocol/protocol.h"

namespace forklift::server {

JsonStream& JsonStream::text_value(std::string_view s) {
  if (!dds::valid_utf8(s)) return raw(nlohmann::json(std::string(s)));
  writer_.String(s.data(), static_cast<rapidjson::SizeType>(s.size()));
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
