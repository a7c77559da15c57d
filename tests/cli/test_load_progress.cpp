// The long teacher's progress line (sdk/tools/load_progress.hpp): its text, and that it
// is shown only once loading has taken longer than the delay, ending with a newline.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "load_progress.hpp"

namespace kata::tools {
namespace {

TEST(LoadProgress, Line) {
  EXPECT_EQ(load_progress_line("t16.bvh", 31000, 75568), "loading teacher t16.bvh: 41 % (31,000 / 75,568 frames)");
  EXPECT_EQ(load_progress_line("a", 0, 999), "loading teacher a: 0 % (0 / 999 frames)");
  EXPECT_EQ(load_progress_line("a", 1234567, 1234567), "loading teacher a: 100 % (1,234,567 / 1,234,567 frames)");
}

std::string written(std::FILE* f) {
  std::fflush(f);
  std::rewind(f);
  std::string s;
  for (int c; (c = std::fgetc(f)) != EOF;) s += static_cast<char>(c);
  return s;
}

TEST(LoadProgress, QuietUnderASecond) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  double now = 10.0;
  LoadProgress p("t.bvh", f, 1.0, 0.25, [&] { return now; });
  now = 10.3;
  p(1024, 5000);
  now = 10.9;
  p(5000, 5000);
  EXPECT_FALSE(p.shown());
  EXPECT_EQ(written(f), "");
  std::fclose(f);
}

TEST(LoadProgress, ShownPastASecondAndEnded) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  double now = 0.0;
  LoadProgress p("t.bvh", f, 1.0, 0.25, [&] { return now; });
  now = 0.5;
  p(1000, 4000);  // before the delay: nothing
  now = 1.2;
  p(2000, 4000);  // shown
  now = 1.3;
  p(3000, 4000);  // within `every` of the last: skipped
  now = 1.35;
  p(4000, 4000);  // the end: always shown, with a newline
  EXPECT_TRUE(p.shown());
  EXPECT_EQ(written(f), "\rloading teacher t.bvh: 50 % (2,000 / 4,000 frames)"
                        "\rloading teacher t.bvh: 100 % (4,000 / 4,000 frames)\n");
  std::fclose(f);
}

}  // namespace
}  // namespace kata::tools
