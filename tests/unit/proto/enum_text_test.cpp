#include "gonio/proto/enum_text.hpp"

#include <gtest/gtest.h>

namespace gonio::testenum {
enum class Color { red, green, blue };
inline constexpr EnumNames<Color, 3> kColorNames{
    {{Color::red, "red"}, {Color::green, "green"}, {Color::blue, "blue-ish"}}};
constexpr const auto& enum_names(Color) { return kColorNames; }
}  // namespace gonio::testenum

namespace gonio {
namespace {

using testenum::Color;

TEST(EnumText, NamesRoundTrip) {
  static_assert(to_text(Color::green) == "green");
  for (const auto& [v, name] : testenum::kColorNames) {
    EXPECT_EQ(to_text(v), name);
    EXPECT_EQ(from_text<Color>(name), v);
  }
  EXPECT_EQ(to_text(static_cast<Color>(7)), "?");
  EXPECT_FALSE(from_text<Color>("Red").has_value());  // names are exact
}

TEST(EnumText, ParseErrorNamesFieldAndAllowedNames) {
  EXPECT_EQ(parse_enum<Color>("blue-ish", "paint.colour"), Color::blue);
  try {
    (void)parse_enum<Color>("purple", "paint.colour");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), Errc::invalid_argument);
    EXPECT_EQ(e.field(), "paint.colour");
    EXPECT_STREQ(e.what(), "paint.colour: 'purple' is not one of: red, green, blue-ish");
  }
}

}  // namespace
}  // namespace gonio
