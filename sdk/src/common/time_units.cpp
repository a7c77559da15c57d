#include "common/time_units.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "common/error.hpp"

namespace kata {

TimeUnits parse_time_units(const std::string& text) {
  if (text == "s") return TimeUnits::kSeconds;
  if (text == "ms") return TimeUnits::kMilliseconds;
  if (text == "auto" || text.empty()) return TimeUnits::kAuto;
  throw Error(ErrorKind::kInvalidArgument, "time units must be s, ms or auto (got '" + text.substr(0, 16) + "')");
}

const char* time_units_name(TimeUnits units) {
  switch (units) {
    case TimeUnits::kSeconds: return "s";
    case TimeUnits::kMilliseconds: return "ms";
    case TimeUnits::kAuto: break;
  }
  return "auto";
}

double seconds_per_unit(TimeUnits units) {
  return units == TimeUnits::kSeconds ? 1.0 : units == TimeUnits::kMilliseconds ? 1e-3 : 0.0;
}

namespace {

bool plausible(double step_seconds) { return step_seconds >= kMinPlausibleStep && step_seconds <= kMaxPlausibleStep; }

}  // namespace

TimeUnits resolve_time_units(const double* times, size_t count, TimeUnits stated, const std::string& name) {
  if (count < 2) return stated == TimeUnits::kAuto ? TimeUnits::kSeconds : stated;
  // Offline (a file's timestamps): one allocation for the median is fine here.
  std::vector<double> steps(count - 1);
  for (size_t i = 1; i < count; ++i) {
    if (!std::isfinite(times[i]) || !std::isfinite(times[i - 1]) || !(times[i] > times[i - 1]))
      throw Error(ErrorKind::kInvalidArgument, name + ": timestamp " + std::to_string(i) + " does not increase");
    steps[i - 1] = times[i] - times[i - 1];
  }
  // 0, 1, 2, ... (or 1, 2, 3, ...): frame numbers, which read as a 1000 Hz recording in milliseconds
  // (every result calibrating) or a 1 Hz one in seconds. Whatever the units stated.
  if (count >= 3 && (times[0] == 0.0 || times[0] == 1.0) &&
      std::all_of(steps.begin(), steps.end(), [](double d) { return d == 1.0; }))
    throw Error(ErrorKind::kInvalidArgument,
                name + ": the timestamps are " + std::to_string(static_cast<int>(times[0])) + ", " +
                    std::to_string(static_cast<int>(times[0]) + 1) + ", " +
                    std::to_string(static_cast<int>(times[0]) + 2) +
                    ", ... (every step exactly 1): frame numbers, not times; give each frame's time (seconds or "
                    "milliseconds), or the frame rate of a recording without times (--fps)");
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  const double step = steps[steps.size() / 2];
  const bool as_seconds = plausible(step), as_ms = plausible(step * 1e-3);
  char figure[96];
  std::snprintf(figure, sizeof figure, "the median step between frames is %.6g", step);
  if (stated == TimeUnits::kAuto) {
    if (as_seconds) return TimeUnits::kSeconds;
    if (as_ms) return TimeUnits::kMilliseconds;
    throw Error(ErrorKind::kInvalidArgument,
                name + ": ambiguous time units: " + figure + ", a plausible frame step (2..1000 Hz) in neither seconds "
                       "(0.001..0.5) nor milliseconds (1..500); give --time-units s|ms after checking the timestamps");
  }
  // A stated unit is taken unless the step fits the other one only (then the statement is the
  // likely slip). Stated seconds take steps up to kMaxStatedStep: a webcam page running MediaPipe
  // without a GPU makes about a frame a second (the coach's recordings), which auto would read as
  // milliseconds.
  const bool fits_other = stated == TimeUnits::kSeconds ? as_ms && !(step >= kMinPlausibleStep && step <= kMaxStatedStep)
                                                        : as_seconds && !as_ms;
  if (!fits_other) return stated;
  throw Error(ErrorKind::kInvalidArgument, name + ": timestamps in " + (stated == TimeUnits::kSeconds ? "seconds" : "milliseconds") +
                                               ": " + figure + ", not a plausible frame step (2..1000 Hz)" +
                                               (stated == TimeUnits::kSeconds ? "; it fits milliseconds (--time-units ms)"
                                                                              : "; it fits seconds (--time-units s)"));
}

}  // namespace kata
