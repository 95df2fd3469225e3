#include "gpu/base/checksum.h"

#include <gtest/gtest.h>

#include <array>
#include <string_view>

namespace overlap {
namespace {

TEST(Fnv1a, MatchesTheReferenceValues) {
  EXPECT_EQ(fnv1a(std::span<const char>()), kFnv1aOffsetBasis);
  constexpr std::string_view kA = "a";
  EXPECT_EQ(fnv1a(std::span<const char>(kA)), 0xaf63dc4c8601ec8cull);
  constexpr std::string_view kFoobar = "foobar";
  EXPECT_EQ(fnv1a(std::span<const char>(kFoobar)), 0x85944171f73967e8ull);
}

TEST(Fnv1a, ChainingEqualsHashingTheConcatenation) {
  constexpr std::array<char, 6> kWhole = {'f', 'o', 'o', 'b', 'a', 'r'};
  const std::span<const char> whole(kWhole);
  EXPECT_EQ(fnv1a(whole.subspan(3), fnv1a(whole.first(3))), fnv1a(whole));
}

}  // namespace
}  // namespace overlap
