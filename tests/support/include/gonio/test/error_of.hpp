// error_of(f): the gonio::Error that f throws, for tests that check its code and message.
// Throwing nothing is a test failure; the Error returned then has code internal.
#pragma once

#include <gtest/gtest.h>

#include "gonio/proto/error.hpp"

namespace gonio::test {

template <typename F>
Error error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "no gonio::Error was thrown";
  return Error(Errc::internal, "no error thrown");
}

}  // namespace gonio::test
