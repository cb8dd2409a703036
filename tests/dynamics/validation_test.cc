// The training truck behaves as a real one where safety training needs it, and the paper's
// truck, with its slip-speed tyres and free torque, visibly does not: `forklift-sim validate`'s
// checks (sim/dynamics/src/validation.cc), each a closed form or a limit from a file or a standard.
#include <gtest/gtest.h>

#include <map>

#include "forklift/dynamics/validation.h"
#include "test_truck.h"

using namespace forklift;

namespace {

std::string describe(const ValidationCheck& c) {
  return c.name + ": " + std::to_string(c.measured) + " " + c.unit + ", required " + c.required;
}

const std::vector<ValidationCheck>& checks(const TruckParams& t) {
  static std::map<const TruckParams*, std::vector<ValidationCheck>> cache;
  auto it = cache.find(&t);
  if (it == cache.end()) it = cache.emplace(&t, validate_truck(t)).first;
  return it->second;
}

// The checks whose name contains `part`.
std::vector<ValidationCheck> named(const TruckParams& t, const std::string& part) {
  std::vector<ValidationCheck> out;
  for (const ValidationCheck& c : checks(t)) if (c.name.find(part) != std::string::npos) out.push_back(c);
  return out;
}

}  // namespace

TEST(Validation, TheTrainingTruckPassesEveryCheck) {
  const std::vector<ValidationCheck>& all = checks(shipped_truck());
  EXPECT_GE(all.size(), 35u);
  for (const ValidationCheck& c : all) EXPECT_TRUE(c.pass) << describe(c);
}

TEST(Validation, ThePaperTruckFailsWhatItsForceLawsCannotDo) {
  // Section 9's truck: nothing holds it on a grade, it has no top speed or steering rate, and
  // with mu = 0.1 it slides before it tips.
  for (const char* part : {"15 % grade", "top speed at full throttle", "steer rate", "35 deg turn at top speed",
                           "static on a 10 % ramp"}) {
    const std::vector<ValidationCheck> found = named(paper_truck(), part);
    ASSERT_FALSE(found.empty()) << part;
    for (const ValidationCheck& c : found) EXPECT_FALSE(c.pass) << describe(c);
  }
  // Its statics and its tilt table are those of the same class of truck, and pass.
  for (const char* part : {"statics,", ": tilt angle"})
    for (const ValidationCheck& c : named(paper_truck(), part)) EXPECT_TRUE(c.pass) << describe(c);
}
