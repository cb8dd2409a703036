// The session log's typed records and their one reader, strict and tolerant.
#include <gtest/gtest.h>

#include <stdexcept>

#include "forklift/session/log_records.h"

namespace {

using namespace forklift;

const char* kLog =
    "forklift-control-log 1\n"
    "session s1\n"
    "cab cab 1\n"
    "tick 0x1.0624dd2f1a9fcp-10\n"
    "mode exam\n"
    "i 0 1 0x0p+0 0x0p+0 0x0p+0 0x0p+0 0x0p+0 0x0p+0 0\n"
    "e 12 speed_near_walkway 2\n"
    "w 40 controls_resumed 0\n"
    "score 0x1.68p+6 1 10 time_limit\n"
    "end 50\n";

TEST(LogRecords, TheReaderTypesWhatOtherProgramsRead) {
  const LogFacts f = read_log_facts(kLog, LogReading::kStrict);
  EXPECT_EQ(f.sessions, std::vector<std::string>{"s1"});
  EXPECT_EQ(f.cabs, std::vector<std::string>{"cab 1"});  // a word runs to the end of its line
  EXPECT_EQ(f.modes, std::vector<std::string>{"exam"});
  EXPECT_EQ(f.tick, "0x1.0624dd2f1a9fcp-10");
  ASSERT_EQ(f.events.size(), 2u);
  EXPECT_EQ(f.events[0].tick, 12);
  EXPECT_EQ(f.events[0].kind, "speed_near_walkway");
  EXPECT_EQ(f.events[0].worry_level, 2);
  EXPECT_FALSE(f.events[0].worker);
  EXPECT_TRUE(f.events[1].worker);
  ASSERT_EQ(f.scores.size(), 1u);
  EXPECT_EQ(f.scores[0].mark, 90.0);
  EXPECT_TRUE(f.scores[0].passed);
  EXPECT_EQ(f.scores[0].points, 10);
  EXPECT_EQ(f.scores[0].end_reason, "time_limit");
  EXPECT_TRUE(f.ended);
  EXPECT_TRUE(f.malformed.empty());
}

TEST(LogRecords, AMalformedLineIsRefusedStrictlyAndAFindingTolerantly) {
  const std::string log = std::string(kLog) + "e 60 torn\nscore 0x1p+6 2 0 signal\ne 61 x 1y\n";
  try {
    read_log_facts(log, LogReading::kStrict);
    FAIL() << "a torn line read strictly";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "log line 11 is not 'e <tick> <kind> <worry>'");
  }
  const LogFacts f = read_log_facts(log, LogReading::kTolerant);
  EXPECT_EQ(f.events.size(), 2u);
  EXPECT_EQ(f.scores.size(), 1u);
  ASSERT_EQ(f.malformed.size(), 3u);
  EXPECT_EQ(f.malformed[1], "log line 12 is not 'score <mark> <0|1> <points> <reason>'");
  EXPECT_EQ(f.malformed[2], "log line 13 is not 'e <tick> <kind> <worry>'");
}

TEST(LogRecords, ARecordIsTypedOnlyWhenItHoldsItsGrammar) {
  const auto one = [](const char* line) { return scan_log_records(line).at(0); };
  EXPECT_TRUE(event_record(one("e 1 k 0")));
  EXPECT_FALSE(event_record(one("e 1 k")));
  EXPECT_FALSE(event_record(one("x 1 k 0")));
  EXPECT_FALSE(event_record(one("e 1.5 k 0")));
  EXPECT_TRUE(score_record(one("score 0x0p+0 0 3")));  // a reason is optional
  EXPECT_EQ(score_record(one("score 0x0p+0 0 3"))->end_reason, "");
  EXPECT_FALSE(score_record(one("score zero 0 3 signal")));
  EXPECT_FALSE(score_record(one("score 0x0p+0 yes 3 signal")));
}

}  // namespace
