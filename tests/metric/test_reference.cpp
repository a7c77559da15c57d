// A teacher reference: bad input is refused with kInvalidArgument.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "common/error.hpp"
#include "fixtures.hpp"
#include "metric/reference.hpp"

namespace kata {
namespace {

TEST(Reference, BadInputIsRefused) {
  const auto metric = test::test_metric();
  std::vector<float> x(test::clip_row("02_01.bvh", 0), test::clip_row("02_01.bvh", 0) + gpd::kDims);
  x[10] = std::nanf("");
  EXPECT_THROW((void)metric::Reference(metric, x.data()), Error);
  EXPECT_THROW((void)metric::Reference(metric, test::clip_row("02_01.bvh", 0), 0, 1.0 / 120), Error);
  EXPECT_THROW((void)metric::Reference(metric, test::clip_row("02_01.bvh", 0), 2, 0.0), Error);
}

}  // namespace
}  // namespace kata
