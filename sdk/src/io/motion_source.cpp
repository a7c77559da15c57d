// Landmark arrays and BVH clips behind one reader (see motion_source.hpp).
#include "io/motion_source.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/error.hpp"
#include "common/quote.hpp"
#include "common/text.hpp"
#include "io/bvh.hpp"
#include "io/clip_features.hpp"
#include "io/file.hpp"
#include "io/npy.hpp"
#include "stream/stream.hpp"

namespace kata {

namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// Splits a CSV line into numbers; false when a field is not a number.
bool parse_numbers(const std::string& line, std::vector<double>* out) {
  out->clear();
  std::stringstream ss(line);
  std::string field;
  while (std::getline(ss, field, ',')) {
    const char* b = field.c_str();
    while (*b == ' ' || *b == '\t') ++b;
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(b, &end);
    if (end == b) return false;
    while (*end == ' ' || *end == '\t' || *end == '\r') ++end;
    if (*end != '\0') return false;
    out->push_back(v);
  }
  return !out->empty();
}

void fill_array(MotionSource& m, const std::vector<double>& values, int frames, int channels) {
  const int joints = m.skeleton.joint_count();
  m.frames = frames;
  m.xyz.resize(static_cast<size_t>(frames) * joints * 3);
  if (channels >= 4) m.confidence.resize(static_cast<size_t>(frames) * joints);
  for (size_t f = 0; f < static_cast<size_t>(frames); ++f)
    for (size_t j = 0; j < static_cast<size_t>(joints); ++j) {
      const double* v = values.data() + (f * joints + j) * static_cast<size_t>(channels);
      for (int k = 0; k < 3; ++k) m.xyz[(f * joints + j) * 3 + static_cast<size_t>(k)] = static_cast<float>(v[k]);
      // MediaPipe's five channels: visibility and presence; a joint is as confident as the
      // smaller (std::fmin keeps a NaN in either from hiding: NaN stays missing below).
      if (channels == 4) m.confidence[f * joints + j] = static_cast<float>(v[3]);
      if (channels == 5)
        m.confidence[f * joints + j] = std::isnan(v[3]) || std::isnan(v[4]) ? NAN : static_cast<float>(std::fmin(v[3], v[4]));
    }
}

}  // namespace

namespace {

// A landmark source without frames: the layout's joint list and map, its axes (the frame time
// comes from the frame rate or the timestamps: needs_timing).
MotionSource empty_landmarks(const std::string& name, const std::string& layout_name, UpAxis up) {
  MotionSource m;
  m.path = name;
  m.skeleton = layout_skeleton(layout_name);
  m.layout = resolve_layout(m.skeleton, layout_name);
  if (!m.layout.fixed_axes) m.layout.axes = up;
  return m;
}

// An array without timestamps runs at `fps`.
void set_frame_rate(MotionSource& m, double fps) {
  if (!(fps > 0.0) || !std::isfinite(fps))
    throw Error(ErrorKind::kInvalidArgument, m.path + ": a landmark array without timestamps needs a frame rate > 0 (--fps)");
  m.frame_time = 1.0 / fps;
}

MotionSource array_of_values(const std::vector<double>& values, const std::vector<size_t>& shape, const std::string& name,
                             const std::string& layout_name, UpAxis up) {
  MotionSource m = empty_landmarks(name, layout_name, up);
  const size_t joints = static_cast<size_t>(m.skeleton.joint_count());
  if (shape.size() != 3 || shape[1] != joints || shape[2] < 3 || shape[2] > 5 ||
      shape[0] > static_cast<size_t>(kMaxLandmarkFrames)) {
    std::string got;
    for (size_t d : shape) got += (got.empty() ? "" : ", ") + std::to_string(d);
    if (shape.size() == 1) got += ",";
    std::string hint;
    if (shape.size() == 3 && shape[1] != joints)
      hint = "; it has " + std::to_string(shape[1]) + " joints per frame, layout " + bounded(layout_name) + " has " +
             std::to_string(joints) + " (another --layout?)";
    else if (shape.size() == 2 && shape[1] == static_cast<size_t>(gpd::kDims))
      hint = "; (frames, 1683) is a GPD feature array, not landmarks";
    else if (shape.size() == 3 && (shape[2] < 3 || shape[2] > 5))
      hint = "; the last axis is x y z [confidence | visibility presence]";
    throw Error(ErrorKind::kParse, name + ": shape (" + got + ") is not a landmark array: expected (frames <= " +
                                       std::to_string(kMaxLandmarkFrames) + ", " + std::to_string(joints) +
                                       ", 3, 4 or 5) for layout " + bounded(layout_name) + hint);
  }
  fill_array(m, values, static_cast<int>(shape[0]), static_cast<int>(shape[2]));
  return m;
}

}  // namespace

std::string times_path_of(const std::string& npy_path) {
  return (ends_with(npy_path, ".npy") ? npy_path.substr(0, npy_path.size() - 4) : npy_path) + ".times.npy";
}

void set_timestamps(MotionSource& m, const double* raw, size_t count, TimeUnits units) {
  if (count != static_cast<size_t>(m.frames))
    throw Error(ErrorKind::kParse, m.path + ": " + std::to_string(count) + " timestamps for " + std::to_string(m.frames) +
                                       " frames");
  // A file's timestamps are its content: what is wrong with them is a parse error of the file
  // (resolve_time_units says kInvalidArgument, as the C ABI's detection reports it).
  TimeUnits resolved;
  try {
    resolved = resolve_time_units(raw, count, units, m.path);
  } catch (const Error& e) {
    throw Error(ErrorKind::kParse, e.what());
  }
  const double scale = seconds_per_unit(resolved);
  m.times.resize(count);
  for (size_t i = 0; i < count; ++i) m.times[i] = (raw[i] - raw[0]) * scale;
  if (count >= 2) {
    std::vector<double> steps(count - 1);
    for (size_t i = 1; i < count; ++i) steps[i - 1] = m.times[i] - m.times[i - 1];
    std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
    m.frame_time = steps[steps.size() / 2];
  } else {
    m.frame_time = 1.0 / 30.0;  // one frame: no step to measure, and none needed
  }
}

MotionSource load_motion(const std::string& path, const std::string& layout_name, double fps, UpAxis up, int first,
                         TimeUnits units) {
  MotionSource m;
  m.path = path;
  if (ends_with(path, ".bvh")) {
    const BvhClip clip = load_bvh(path);
    m.skeleton = clip.skeleton;
    try {
      m.layout = resolve_layout(m.skeleton, layout_name.empty() ? "cmu" : layout_name);
    } catch (const Error& e) {
      throw Error(e.kind(), bounded(path) + ": " + e.what());
    }
    if (!m.layout.fixed_axes) m.layout.axes = up;
    m.frame_time = clip.frame_time;
    if (first < 0 || first > clip.frame_count())
      throw Error(ErrorKind::kInvalidArgument, path + ": first frame " + std::to_string(first) + " out of range (the clip has " +
                                                   std::to_string(clip.frame_count()) + " frames; --first-frame takes 0.." +
                                                   std::to_string(clip.frame_count()) + ")");
    m.xyz = clip_positions(clip, first);
    m.frames = clip.frame_count() - first;
    return m;
  }
  const LandmarkFormat format = ends_with(path, ".npy")   ? LandmarkFormat::kNpy
                                : ends_with(path, ".csv") ? LandmarkFormat::kCsv
                                                          : LandmarkFormat::kUnknown;
  if (format == LandmarkFormat::kUnknown)
    throw Error(ErrorKind::kInvalidArgument, path + ": unknown file type (.bvh, .npy or .csv)");
  if (layout_name.empty())
    throw Error(ErrorKind::kInvalidArgument, path + ": a landmark array needs --layout (mediapipe, gpd, ...)");
  const std::string bytes = format == LandmarkFormat::kNpy
                                ? std::string()
                                : read_file_bounded(path, kMaxLandmarkCsvBytes, "landmark CSV file");
  if (format == LandmarkFormat::kNpy) {
    std::vector<size_t> shape;
    const std::vector<double> values = read_npy(path, &shape);
    m = array_of_values(values, shape, path, layout_name, up);
    const std::string times_path = times_path_of(path);
    if (std::ifstream(times_path)) {
      std::vector<size_t> times_shape;
      const std::vector<double> raw = read_npy(times_path, &times_shape);
      if (times_shape.size() != 1)
        throw Error(ErrorKind::kParse, times_path + ": timestamps must be a 1-D array (one per frame of " + path + ")");
      set_timestamps(m, raw.data(), raw.size(), units);
    } else {
      set_frame_rate(m, fps);
    }
  } else {
    m = parse_landmarks(bytes, format, path, layout_name, fps, up, units);
  }
  if (first < 0 || first > m.frames)
    throw Error(ErrorKind::kInvalidArgument, path + ": first frame " + std::to_string(first) + " out of range (the array has " +
                                                 std::to_string(m.frames) + " frames; --first-frame takes 0.." +
                                                 std::to_string(m.frames) + ")");
  const size_t joints = static_cast<size_t>(m.skeleton.joint_count());
  m.xyz.erase(m.xyz.begin(), m.xyz.begin() + static_cast<std::ptrdiff_t>(static_cast<size_t>(first) * joints * 3));
  if (!m.confidence.empty())
    m.confidence.erase(m.confidence.begin(), m.confidence.begin() + static_cast<std::ptrdiff_t>(static_cast<size_t>(first) * joints));
  if (!m.times.empty()) {
    m.times.erase(m.times.begin(), m.times.begin() + first);
    const double t0 = m.times.front();  // times stay from the first kept frame
    for (double& t : m.times) t -= t0;
  }
  m.frames -= first;
  if (layout_name == "mediapipe") check_person_in_metres(m);
  return m;
}

void check_person_in_metres(const MotionSource& m) {
  // MediaPipe Pose: 0 nose, 27/28 ankles; its world landmarks are metres with y down.
  constexpr int kNose = 0, kLeftAnkle = 27, kRightAnkle = 28;
  const int joints = m.skeleton.joint_count();
  if (joints <= kRightAnkle) return;
  std::vector<double> size, drop;  // per frame: nose to the ankles' midpoint; nose y - ankles' y
  for (int f = 0; f < m.frames; ++f) {
    const float* p = m.xyz.data() + static_cast<size_t>(f) * static_cast<size_t>(joints) * 3;
    const float* c = m.confidence.empty() ? nullptr : m.confidence.data() + static_cast<size_t>(f) * joints;
    bool seen = true;
    for (int j : {kNose, kLeftAnkle, kRightAnkle}) {
      for (int k = 0; k < 3; ++k) seen = seen && std::isfinite(p[3 * j + k]);
      seen = seen && (!c || c[j] >= 0.5f);
    }
    if (!seen) continue;
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double d = 0.5 * (double(p[3 * kLeftAnkle + k]) + p[3 * kRightAnkle + k]) - p[3 * kNose + k];
      d2 += d * d;
    }
    size.push_back(std::sqrt(d2));
    drop.push_back(double(p[3 * kNose + 1]) - 0.5 * (double(p[3 * kLeftAnkle + 1]) + p[3 * kRightAnkle + 1]));
  }
  if (size.empty()) return;
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double body = median(size), head_below = median(drop);
  char figure[64];
  std::snprintf(figure, sizeof figure, "%.4g", body);
  if (!(body <= kMaxPersonMetres))
    throw Error(ErrorKind::kInvalidArgument,
                bounded(m.path) + ": the body measures " + figure +
                    " from the nose to the ankles (the median over the frames that show them): not a person in "
                    "metres, which the mediapipe layout reads. Pixel coordinates (the image landmarks times the "
                    "image's width and height)? Give MediaPipe's world landmarks (pose_world_landmarks, metres)");
  if (head_below > 0.5 * body) {
    std::snprintf(figure, sizeof figure, "%.3g", head_below);
    throw Error(ErrorKind::kInvalidArgument,
                bounded(m.path) + ": the body is upside down: the nose is " + figure +
                    " m below the ankles (the median over the frames that show them) in MediaPipe's axes, x right, "
                    "y down, z away from the camera. The landmarks look y-up: negate y and z (MediaPipe's world "
                    "landmarks have y down)");
  }
}

MotionSource landmarks_from_values(const std::vector<double>& values, const std::vector<size_t>& shape,
                                   const std::string& name, const std::string& layout_name, double fps, UpAxis up) {
  MotionSource m = array_of_values(values, shape, name, layout_name, up);
  set_frame_rate(m, fps);
  return m;
}

MotionSource parse_landmarks(const std::string& bytes, LandmarkFormat format, const std::string& name,
                             const std::string& layout_name, double fps, UpAxis up, TimeUnits units) {
  if (format == LandmarkFormat::kNpy) {
    std::vector<size_t> shape;
    const std::vector<double> values = parse_npy(bytes, name, &shape);
    return landmarks_from_values(values, shape, name, layout_name, fps, up);
  }
  MotionSource m = empty_landmarks(name, layout_name, up);
  const int joints = m.skeleton.joint_count();
  std::vector<double> row, values, times;
  int channels = 0, frames = 0, line_no = 0;
  bool timed = false;  // a leading timestamp column (decided by the first row's count)
  size_t start = 0;
  while (start < bytes.size()) {
    size_t end = bytes.find('\n', start);
    if (end == std::string::npos) end = bytes.size();
    const std::string line = bytes.substr(start, end - start);
    start = end + 1;
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    if (!parse_numbers(line, &row)) {
      if (frames == 0 && channels == 0) continue;  // the header (any lines before the first row)
      throw Error(ErrorKind::kParse, name + ":" + std::to_string(line_no) + ": a field is not a number");
    }
    // joints x 3, 4 or 5 numbers, or one more: a timestamp first.
    int c = 0;
    bool t = false;
    for (int k = 3; k <= 5 && c == 0; ++k) {
      if (static_cast<int>(row.size()) == k * joints) c = k;
      else if (static_cast<int>(row.size()) == k * joints + 1) c = k, t = true;
    }
    if (c == 0 || (channels != 0 && (c != channels || t != timed)))
      throw Error(ErrorKind::kParse, name + ":" + std::to_string(line_no) + ": " + std::to_string(row.size()) +
                                         " numbers, expected " + std::to_string(3 * joints) + ", " +
                                         std::to_string(4 * joints) + " or " + std::to_string(5 * joints) +
                                         " (layout " + bounded(layout_name) + "), optionally after a timestamp, as on "
                                         "the first row");
    if (frames >= kMaxLandmarkFrames)
      throw Error(ErrorKind::kParse, name + ":" + std::to_string(line_no) + ": more than " +
                                         std::to_string(kMaxLandmarkFrames) + " frames");
    channels = c, timed = t;
    if (timed) times.push_back(row[0]);
    values.insert(values.end(), row.begin() + (timed ? 1 : 0), row.end());
    ++frames;
  }
  if (frames == 0) throw Error(ErrorKind::kParse, name + ": no frames");
  fill_array(m, values, frames, channels);
  if (timed) set_timestamps(m, times.data(), times.size(), units);
  else set_frame_rate(m, fps);
  return m;
}

std::vector<float> motion_features(const MotionSource& m, gpd::Stencil stencil, std::vector<int>* frame_of_row,
                                   int* lost) {
  StreamConfig config;
  config.map = m.layout.map;
  config.input_joints = m.skeleton.joint_count();
  config.stencil = stencil;
  config.up_axis = m.layout.axes;
  config.smoothing = m.layout.smooth;
  if (m.skeleton.has_rest_pose) config.body_height = rest_body_height(m.skeleton, m.layout.map);
  Stream stream(config);
  const int n = m.skeleton.joint_count();
  std::vector<float> out;
  frame_of_row->clear();
  *lost = 0;
  std::vector<int> source_of_accepted;  // accepted frame k -> source frame (lost frames are not accepted)
  int64_t copied = 0;                   // emitted vectors are accepted frames 0, 1, ... in order
  auto collect = [&] {
    for (; copied < stream.emitted_count(); ++copied) {
      const float* v = stream.vector_of(copied);
      out.insert(out.end(), v, v + gpd::kDims);
      frame_of_row->push_back(source_of_accepted[static_cast<size_t>(copied)]);
    }
  };
  const std::vector<float> all_good(static_cast<size_t>(n), 1.0f);  // arrays without confidences
  for (int f = 0; f < m.frames; ++f) {
    const float* conf = m.confidence.empty() ? all_good.data() : m.confidence.data() + static_cast<size_t>(f) * n;
    const Status s = stream.push(m.time_of(f), m.xyz.data() + static_cast<size_t>(f) * n * 3, conf, n);
    if (s == Status::kTrackingLost) {
      ++*lost;
    } else if (s != Status::kOk) {
      throw Error(ErrorKind::kInvalidArgument, m.path + ": frame " + std::to_string(f) + ": " + stream.last_error());
    } else {
      source_of_accepted.push_back(f);
    }
    collect();
  }
  stream.flush();
  collect();
  return out;
}

}  // namespace kata
