#include <gtest/gtest.h>

#include <cstdint>
#include <string>

#include "fleetmap/core/printable_text.h"

namespace fleetmap {
namespace {

std::string MarkupEscaped(std::string_view text) {
  std::string out = "kept:";
  AppendMarkupEscaped(out, text);
  return out;
}

TEST(MarkupEscapeTest, TheFiveSpecialCharactersBecomeReferences) {
  EXPECT_EQ(MarkupEscaped("<r&d> \"two\" 'one'"),
            "kept:&lt;r&amp;d&gt; &quot;two&quot; &#39;one&#39;");
  EXPECT_EQ(MarkupEscaped("&amp;"), "kept:&amp;amp;");  // escaped again, read back as written
}

TEST(MarkupEscapeTest, ControlsXmlForbidsBecomeSpacesAndTheRestIsCopied) {
  EXPECT_EQ(MarkupEscaped("bell\a\x01here"), "kept:bell  here");
  EXPECT_EQ(MarkupEscaped("tab\tline\ncr\r"), "kept:tab\tline\ncr\r");
  EXPECT_EQ(MarkupEscaped("caf\xc3\xa9 \x7f"), "kept:caf\xc3\xa9 \x7f");
}

TEST(BytesTextTest, ExactBelowAKibibyteThenOneDecimalInBinaryUnits) {
  EXPECT_EQ(BytesText(0), "0 B");
  EXPECT_EQ(BytesText(1023), "1023 B");
  EXPECT_EQ(BytesText(1024), "1.0 KiB");
  EXPECT_EQ(BytesText(1536), "1.5 KiB");
  EXPECT_EQ(BytesText(std::uint64_t{5'400'000}), "5.1 MiB");
  EXPECT_EQ(BytesText(std::uint64_t{1} << 30), "1.0 GiB");
  EXPECT_EQ(BytesText(std::uint64_t{3} << 40), "3.0 TiB");
  EXPECT_EQ(BytesText(std::uint64_t{2048} << 40), "2048.0 TiB");
}

}  // namespace
}  // namespace fleetmap
