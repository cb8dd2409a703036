#include "forklift/script/script.h"

#include <cctype>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace forklift {

std::vector<ScriptRow> read_script(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open script " + path);
  std::vector<ScriptRow> rows;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty() || line[0] == '#' || std::isalpha(static_cast<unsigned char>(line[0]))) continue;  // comment, header
    std::vector<double> v;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) {
      char* end = nullptr;
      const double d = std::strtod(cell.c_str(), &end);  // accepts nan and inf on purpose
      while (end && (*end == ' ' || *end == '\r')) ++end;
      if (end == cell.c_str() || (end && *end)) throw std::runtime_error(path + ":" + std::to_string(n) + ": '" + cell + "' is not a number");
      v.push_back(d);
    }
    if (v.size() < 7 || v.size() > 9)
      throw std::runtime_error(path + ":" + std::to_string(n) + ": expected 7 to 9 columns (t, steer, accelerator, brake, lift, tilt, shift[, parking[, horn]])");
    if (v.size() >= 8 && v[7] != 0 && v[7] != 1)
      throw std::runtime_error(path + ":" + std::to_string(n) + ": the parking brake column is 0 or 1");
    if (v.size() == 9 && v[8] != 0 && v[8] != 1)
      throw std::runtime_error(path + ":" + std::to_string(n) + ": the horn column is 0 or 1");
    if (!rows.empty() && !(v[0] >= rows.back().t)) throw std::runtime_error(path + ":" + std::to_string(n) + ": time goes backwards");
    rows.push_back({v[0], v[1], v[2], v[3], v[4], v[5], v[6], v.size() >= 8 && v[7] == 1, v.size() == 9 && v[8] == 1});
  }
  if (rows.empty()) throw std::runtime_error(path + ": no rows");
  return rows;
}

}  // namespace forklift
