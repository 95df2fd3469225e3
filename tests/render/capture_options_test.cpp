#include "render/capture_options.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace overlap::render {
namespace {

template <typename Parse>
void expectErrorMentioning(Parse parse, const std::string& text, const std::string& mention) {
  try {
    parse(text);
    ADD_FAILURE() << "\"" << text << "\" was accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find(mention), std::string::npos) << error.what();
  }
}

TEST(ParseImageSize, ReadsWidthByHeight) {
  EXPECT_EQ(parseImageSize("800x600"), (ImageSize{800, 600}));
  EXPECT_EQ(parseImageSize("1x4096"), (ImageSize{1, 4096}));
}

TEST(ParseImageSize, TakesALeadingPlusAsEveryWholeNumberOptionDoes) {
  EXPECT_EQ(parseImageSize("+800x+600"), (ImageSize{800, 600}));
}

TEST(ParseImageSize, RejectsAnythingElseNamingTheBadPart) {
  const auto parse = [](const std::string& text) { parseImageSize(text); };
  expectErrorMentioning(parse, "800", "WIDTHxHEIGHT");
  expectErrorMentioning(parse, "0x600", "width \"0\"");
  expectErrorMentioning(parse, "800x", "height \"\"");
  expectErrorMentioning(parse, "x600", "width \"\"");
  expectErrorMentioning(parse, "-800x600", "width \"-800\"");
  expectErrorMentioning(parse, "++800x600", "width \"++800\"");
  expectErrorMentioning(parse, "+x600", "width \"+\"");
  expectErrorMentioning(parse, "+0x600", "width \"+0\"");
  expectErrorMentioning(parse, "800x600x2", "height \"600x2\"");
  expectErrorMentioning(parse, "800x99999999999", "height \"99999999999\" is out of range");
  expectErrorMentioning(parse, "4294967297x1", "width \"4294967297\" is out of range");
  expectErrorMentioning(parse, "010x010", "width \"010\" is not a positive integer");
  expectErrorMentioning(parse, "10x010", "height \"010\" is not a positive integer");
}

}  // namespace
}  // namespace overlap::render
