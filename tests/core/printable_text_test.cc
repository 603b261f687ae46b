#include "fleetmap/core/printable_text.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <random>
#include <string>

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

TEST(PrintableTextTest, C1ControlsAndBidiOverridesAreShownEscaped) {
  // U+0085 NEXT LINE, U+009B (a terminal's CSI), U+202E RIGHT-TO-LEFT OVERRIDE, U+2028.
  EXPECT_EQ(PrintableText("a\u0085b\u009b[2Jc\u202ed\u2028e"),
            "a\\u0085b\\u009b[2Jc\\u202ed\\u2028e");
  EXPECT_EQ(PrintableText("\xff\xc3"), "\\xff\\xc3");  // not UTF-8: bytes shown
}

TEST(Utf8TextTest, ACapFallingInsideACharacterCutsBeforeIt) {
  const std::string text = "ab\u00e9\u20ac";  // 2 + 2 + 3 bytes
  EXPECT_EQ(ReceivedText(text, 3), "ab");
  EXPECT_EQ(ReceivedText(text, 4), "ab\u00e9");
  EXPECT_EQ(ReceivedText(text, 6), "ab\u00e9");
  EXPECT_EQ(ReceivedText(text, 7), text);
  EXPECT_EQ(ReceivedText("ab\xe2\x82", 10), "ab\ufffd");
}

TEST(Utf8TextTest, OnlyWellFormedSequencesAreValid) {
  EXPECT_TRUE(IsValidUtf8("plain \u00e9 \U0001F600"));
  for (const char* bad : {"\xc0\xaf", "\xed\xa0\x80", "\xf4\x90\x80\x80", "\x80", "\xe2\x82"}) {
    EXPECT_FALSE(IsValidUtf8(bad)) << bad;
    EXPECT_TRUE(IsValidUtf8(ValidUtf8(bad)));
  }
}

TEST(Utf8TextTest, JsonOfInvalidUtf8IsWrittenNotThrown) {
  nlohmann::json json = {{"last_error", std::string("cut \xe2\x82")}};
  EXPECT_THROW((void)json.dump(), nlohmann::json::type_error);
  const std::string text = JsonText(json);
  EXPECT_EQ(nlohmann::json::parse(text)["last_error"], "cut \ufffd");
  // Hidden characters are escaped, and the JSON means the same.
  const nlohmann::json hidden = {{"name", "a\u202eb\u0085"}};
  EXPECT_EQ(JsonText(hidden), R"({"name":"a\u202eb\u0085"})");
  EXPECT_EQ(nlohmann::json::parse(JsonText(hidden)), hidden);
}

// Random bytes in, from many seeds: every output is valid UTF-8 and one line, and the
// receiver's cut never exceeds its cap.
TEST(Utf8TextTest, EveryOutputOfRandomBytesIsValidAndOneLine) {
  std::mt19937 random(20261202);
  // Bytes drawn so that multi-byte leads, continuations and hidden characters are common.
  const std::string pool[] = {
      "\xc2\x85", "\xc2\x9b", "\xe2\x80\xae", "\xe2\x80\xa8", "\xc3\xa9", "\xf0\x9f\x98\x80",
      "\n",       "\r",       "\\",           "\"",           "<",        "&"};
  for (int round = 0; round < 2000; ++round) {
    std::string input;
    const int length = static_cast<int>(random() % 64);
    for (int i = 0; i < length; ++i) {
      if (random() % 3 == 0) {
        input += pool[random() % std::size(pool)];
      } else {
        input += static_cast<char>(random() % 256);
      }
    }
    const std::size_t cap = random() % 70;
    const std::string received = ReceivedText(input, cap);
    ASSERT_TRUE(IsValidUtf8(received));
    ASSERT_LE(received.size(), cap);
    const std::string printed = PrintableText(input);
    ASSERT_TRUE(IsValidUtf8(printed));
    for (const char c : printed) {
      const auto byte = static_cast<unsigned char>(c);
      ASSERT_FALSE(byte < 0x20 || byte == 0x7f);
    }
    ASSERT_EQ(printed.find("\xe2\x80\xae"), std::string::npos);
    ASSERT_EQ(printed.find("\xc2\x85"), std::string::npos);
    const std::string json = JsonText(nlohmann::json{{"field", input}});
    ASSERT_TRUE(IsValidUtf8(json));
    ASSERT_EQ(json.find('\n'), std::string::npos);
    ASSERT_EQ(json.find("\xe2\x80\xae"), std::string::npos);
    ASSERT_EQ(nlohmann::json::parse(json)["field"], ValidUtf8(input));
  }
}

}  // namespace
}  // namespace fleetmap
