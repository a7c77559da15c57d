// Landmark arrays and BVH clips behind one reader (see motion_source.hpp).
#include "io/motion_source.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/error.hpp"
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
  if (channels == 4) m.confidence.resize(static_cast<size_t>(frames) * joints);
  for (size_t f = 0; f < static_cast<size_t>(frames); ++f)
    for (size_t j = 0; j < static_cast<size_t>(joints); ++j) {
      const double* v = values.data() + (f * joints + j) * static_cast<size_t>(channels);
      for (int k = 0; k < 3; ++k) m.xyz[(f * joints + j) * 3 + static_cast<size_t>(k)] = static_cast<float>(v[k]);
      if (channels == 4) m.confidence[f * joints + j] = static_cast<float>(v[3]);
    }
}

}  // namespace

namespace {

// A landmark source without frames: the layout's joint list and map, its axes, the frame time.
MotionSource empty_landmarks(const std::string& name, const std::string& layout_name, double fps, UpAxis up) {
  if (!(fps > 0.0) || !std::isfinite(fps))
    throw Error(ErrorKind::kInvalidArgument, name + ": a landmark array needs a frame rate > 0");
  MotionSource m;
  m.path = name;
  m.skeleton = layout_skeleton(layout_name);
  m.layout = resolve_layout(m.skeleton, layout_name);
  if (!m.layout.fixed_axes) m.layout.axes = up;
  m.frame_time = 1.0 / fps;
  return m;
}

}  // namespace

MotionSource load_motion(const std::string& path, const std::string& layout_name, double fps, UpAxis up, int first) {
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
      throw Error(ErrorKind::kInvalidArgument, path + ": first frame out of range");
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
  if (!(fps > 0.0)) throw Error(ErrorKind::kInvalidArgument, path + ": a landmark array needs --fps (> 0)");
  const std::string bytes = format == LandmarkFormat::kNpy
                                ? std::string()
                                : read_file_bounded(path, kMaxLandmarkCsvBytes, "landmark CSV file");
  if (format == LandmarkFormat::kNpy) {
    std::vector<size_t> shape;
    const std::vector<double> values = read_npy(path, &shape);
    m = landmarks_from_values(values, shape, path, layout_name, fps, up);
  } else {
    m = parse_landmarks(bytes, format, path, layout_name, fps, up);
  }
  if (first < 0 || first > m.frames) throw Error(ErrorKind::kInvalidArgument, path + ": first frame out of range");
  const size_t joints = static_cast<size_t>(m.skeleton.joint_count());
  m.xyz.erase(m.xyz.begin(), m.xyz.begin() + static_cast<std::ptrdiff_t>(static_cast<size_t>(first) * joints * 3));
  if (!m.confidence.empty())
    m.confidence.erase(m.confidence.begin(), m.confidence.begin() + static_cast<std::ptrdiff_t>(static_cast<size_t>(first) * joints));
  m.frames -= first;
  return m;
}

MotionSource landmarks_from_values(const std::vector<double>& values, const std::vector<size_t>& shape,
                                   const std::string& name, const std::string& layout_name, double fps, UpAxis up) {
  MotionSource m = empty_landmarks(name, layout_name, fps, up);
  const size_t joints = static_cast<size_t>(m.skeleton.joint_count());
  if (shape.size() != 3 || shape[1] != joints || (shape[2] != 3 && shape[2] != 4) ||
      shape[0] > static_cast<size_t>(kMaxLandmarkFrames))
    throw Error(ErrorKind::kParse, name + ": expected shape (frames <= " + std::to_string(kMaxLandmarkFrames) + ", " +
                                       std::to_string(joints) + ", 3 or 4) for layout " + bounded(layout_name));
  fill_array(m, values, static_cast<int>(shape[0]), static_cast<int>(shape[2]));
  return m;
}

MotionSource parse_landmarks(const std::string& bytes, LandmarkFormat format, const std::string& name,
                             const std::string& layout_name, double fps, UpAxis up) {
  if (format == LandmarkFormat::kNpy) {
    std::vector<size_t> shape;
    const std::vector<double> values = parse_npy(bytes, name, &shape);
    return landmarks_from_values(values, shape, name, layout_name, fps, up);
  }
  MotionSource m = empty_landmarks(name, layout_name, fps, up);
  const int joints = m.skeleton.joint_count();
  std::vector<double> row, values;
  int channels = 0, frames = 0, line_no = 0;
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
    const int c = static_cast<int>(row.size()) == 3 * joints ? 3 : static_cast<int>(row.size()) == 4 * joints ? 4 : 0;
    if (c == 0 || (channels != 0 && c != channels))
      throw Error(ErrorKind::kParse, name + ":" + std::to_string(line_no) + ": " + std::to_string(row.size()) +
                                         " numbers, expected " + std::to_string(3 * joints) + " or " +
                                         std::to_string(4 * joints) + " (layout " + bounded(layout_name) + ")");
    if (frames >= kMaxLandmarkFrames)
      throw Error(ErrorKind::kParse, name + ":" + std::to_string(line_no) + ": more than " +
                                         std::to_string(kMaxLandmarkFrames) + " frames");
    channels = c;
    values.insert(values.end(), row.begin(), row.end());
    ++frames;
  }
  if (frames == 0) throw Error(ErrorKind::kParse, name + ": no frames");
  fill_array(m, values, frames, channels);
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
    const Status s = stream.push(f * m.frame_time, m.xyz.data() + static_cast<size_t>(f) * n * 3, conf, n);
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
