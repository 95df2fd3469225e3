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

TEST(ParseImageSize, RejectsAnythingElseNamingTheBadPart) {
  const auto parse = [](const std::string& text) { parseImageSize(text); };
  expectErrorMentioning(parse, "800", "WIDTHxHEIGHT");
  expectErrorMentioning(parse, "0x600", "width \"0\"");
  expectErrorMentioning(parse, "800x", "height \"\"");
  expectErrorMentioning(parse, "x600", "width \"\"");
  expectErrorMentioning(parse, "-800x600", "width \"-800\"");
  expectErrorMentioning(parse, "+800x600", "width \"+800\"");
  expectErrorMentioning(parse, "800x600x2", "height \"600x2\"");
  expectErrorMentioning(parse, "800x99999999999", "height \"99999999999\"");
}

TEST(ParseFrameList, ReadsFramesInAscendingOrder) {
  EXPECT_EQ(parseFrameList("0,512,1024,2047"), (std::vector<int>{0, 512, 1024, 2047}));
  EXPECT_EQ(parseFrameList(" 30, 2 ,7"), (std::vector<int>{2, 7, 30}));
  EXPECT_EQ(parseFrameList("5"), (std::vector<int>{5}));
}

TEST(ParseFrameList, RejectsAnythingElseNamingTheBadPart) {
  const auto parse = [](const std::string& text) { parseFrameList(text); };
  expectErrorMentioning(parse, "", "\"\" is not a frame number");
  expectErrorMentioning(parse, "1,,2", "\"\" is not a frame number");
  expectErrorMentioning(parse, "1,2,", "\"\" is not a frame number");
  expectErrorMentioning(parse, "1,a", "\"a\" is not a frame number");
  expectErrorMentioning(parse, "-1", "\"-1\" is not a frame number");
  expectErrorMentioning(parse, "3.5", "\"3.5\" is not a frame number");
  expectErrorMentioning(parse, "4,9,4", "frame 4 is listed twice");
}

}  // namespace
}  // namespace overlap::render
