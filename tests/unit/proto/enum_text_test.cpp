#include "gonio/proto/enum_text.hpp"

#include <gtest/gtest.h>

namespace gonio::testenum {
enum class Colour { red, green, blue };
inline constexpr EnumNames<Colour, 3> kColourNames{
    {{Colour::red, "red"}, {Colour::green, "green"}, {Colour::blue, "blue-ish"}}};
constexpr const auto& enum_names(Colour) { return kColourNames; }
}  // namespace gonio::testenum

namespace gonio {
namespace {

using testenum::Colour;

TEST(EnumText, NamesRoundTrip) {
  static_assert(to_text(Colour::green) == "green");
  for (const auto& [v, name] : testenum::kColourNames) {
    EXPECT_EQ(to_text(v), name);
    EXPECT_EQ(from_text<Colour>(name), v);
  }
  EXPECT_EQ(to_text(static_cast<Colour>(7)), "?");
  EXPECT_FALSE(from_text<Colour>("Red").has_value());  // names are exact
}

TEST(EnumText, ParseErrorNamesFieldAndAllowedNames) {
  EXPECT_EQ(parse_enum<Colour>("blue-ish", "paint.colour"), Colour::blue);
  try {
    (void)parse_enum<Colour>("purple", "paint.colour");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::invalid_argument);
    EXPECT_EQ(e.field(), "paint.colour");
    EXPECT_STREQ(e.what(), "paint.colour: 'purple' is not one of: red, green, blue-ish");
  }
}

}  // namespace
}  // namespace gonio
