// Units of the timestamps a landmark source gives. MediaPipe reports milliseconds, mocap files and
// kata seconds; a millisecond file read as seconds has frames 33 "seconds" apart and kinetics near
// zero, so the units are either stated or inferred from the steps between frames, and refused
// when the steps fit neither.
#pragma once

#include <cstddef>
#include <string>

namespace kata {

enum class TimeUnits { kAuto = 0, kSeconds = 1, kMilliseconds = 2 };

// Plausible steps between frames, seconds: 1000 Hz .. 2 Hz. The ranges of the two units do not
// overlap (seconds 0.001..0.5, milliseconds 1..500 as raw numbers), so a plausible step names
// its unit.
constexpr double kMinPlausibleStep = 0.001;
constexpr double kMaxPlausibleStep = 0.5;
// Stated seconds (--time-units s) also take slower steps, up to 0.2 Hz: a slow webcam page's.
constexpr double kMaxStatedStep = 5.0;

// "s", "ms" or "auto" -> the units; throws kata::Error(kInvalidArgument) otherwise.
TimeUnits parse_time_units(const std::string& text);
const char* time_units_name(TimeUnits units);
// Seconds per unit (1 or 0.001); kAuto has none (0).
double seconds_per_unit(TimeUnits units);

// The units of `count` timestamps (count >= 2, increasing) from the median step between them:
// `stated` when it is kSeconds or kMilliseconds, unless the step is plausible in the other unit
// only (seconds stated: steps up to kMaxStatedStep count as plausible in seconds); the unit the
// step fits when `stated` is kAuto. Throws kata::Error(kInvalidArgument)
// starting with `name` (the file) when kAuto's step is plausible for neither unit, when a stated
// unit's step fits the other unit only (the message names it), or when the timestamps do not
// increase, or when they are frame numbers (0 or 1, then every step exactly 1; three or more).
// Fewer than two timestamps: `stated`, or seconds.
TimeUnits resolve_time_units(const double* times, size_t count, TimeUnits stated, const std::string& name);

}  // namespace kata
