#include "fleetmap/core/printable_text.h"

#include <gtest/gtest.h>

namespace fleetmap {
namespace {

TEST(PrintableTextTest, PlainTextIsKeptAsItIs) {
  EXPECT_EQ(PrintableText("robot-7 é"), "robot-7 é");
}

TEST(PrintableTextTest, ANewlineCannotForgeALogLineNorAnEscapeMoveTheCursor) {
  const std::string hostile = "r1\n[2026-11-28 04:00:00] [info] admin logged in\x1b[2J\r\t\x7f";
  const std::string printed = PrintableText(hostile);
  for (const char c : printed) {
    const auto byte = static_cast<unsigned char>(c);
    EXPECT_FALSE(byte < 0x20 || byte == 0x7f) << "control byte " << int(byte) << " left";
  }
  EXPECT_EQ(printed, "r1\\n[2026-11-28 04:00:00] [info] admin logged in\\x1b[2J\\r\\t\\x7f");
}

TEST(PrintableTextTest, ABackslashIsEscapedSoDistinctInputsStayDistinct) {
  EXPECT_NE(PrintableText("a\\nb"), PrintableText("a\nb"));
  EXPECT_EQ(PrintableText("a\\nb"), "a\\\\nb");
}

}  // namespace
}  // namespace fleetmap
