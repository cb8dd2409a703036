// The texts of data/schema/*.schema.json, built in by CMake (schemas.cc.in).
#pragma once

namespace forklift::schema {
extern const char* const kTruckSchemaText;
extern const char* const kScenarioSchemaText;
}  // namespace forklift::schema
