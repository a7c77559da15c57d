// The progress line of a long teacher's loading: `kata coach` and `kata serve` say how
// far a teacher's features and projections are when that takes longer than a second, so a
// 20-minute routine's few seconds of loading is not a silent stall. Short teachers print nothing.
#pragma once

#include <chrono>
#include <cstdio>
#include <functional>
#include <string>

namespace kata::tools {

// "loading teacher NAME: 41 % (31,000 / 75,568 frames)": thousands separated by commas.
inline std::string load_progress_line(const std::string& name, int done, int frames) {
  auto grouped = [](int v) {
    std::string digits = std::to_string(v < 0 ? 0 : v), out;
    for (size_t i = 0; i < digits.size(); ++i) {
      if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
      out += digits[i];
    }
    return out;
  };
  const int percent = frames > 0 ? static_cast<int>(100LL * done / frames) : 100;
  return "loading teacher " + name + ": " + std::to_string(percent) + " % (" + grouped(done) + " / " +
         grouped(frames) + " frames)";
}

// Called with (frames done, frames) as loading goes (pipeline::Teacher::from_positions's progress).
// Once `delay` has passed since construction it writes the line to `out`, rewritten in place ('\r')
// at most every `every`, and ends it with a newline when done reaches frames; before `delay`
// nothing. The clock is a parameter so the tests need not sleep.
class LoadProgress {
 public:
  using Clock = std::function<double()>;  // seconds, monotonic
  static double steady_seconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  }
  explicit LoadProgress(std::string name, std::FILE* out = stderr, double delay = 1.0, double every = 0.25,
                        Clock clock = steady_seconds)
      : name_(std::move(name)), out_(out), delay_(delay), every_(every), clock_(std::move(clock)),
        start_(clock_()) {}

  void operator()(int done, int frames) {
    const double now = clock_();
    const bool last = done >= frames;
    if (now - start_ < delay_ && !shown_) return;
    if (!last && shown_ && now - last_shown_ < every_) return;
    std::fprintf(out_, "\r%s%s", load_progress_line(name_, done, frames).c_str(), last ? "\n" : "");
    std::fflush(out_);
    shown_ = true;
    last_shown_ = now;
  }
  bool shown() const { return shown_; }

 private:
  std::string name_;
  std::FILE* out_;
  double delay_, every_;
  Clock clock_;
  double start_;
  bool shown_ = false;
  double last_shown_ = 0.0;
};

}  // namespace kata::tools
