// Landmark arrays and BVH clips behind one reader (see motion_source.hpp).
#include "io/motion_source.hpp"

#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/error.hpp"
#include "io/bvh.hpp"
#include "io/clip_features.hpp"
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

MotionSource load_motion(const std::string& path, const std::string& layout_name, double fps, UpAxis up, int first) {
  MotionSource m;
  m.path = path;
  if (ends_with(path, ".bvh")) {
    const BvhClip clip = load_bvh(path);
    m.skeleton = clip.skeleton;
    m.layout = resolve_layout(m.skeleton, layout_name.empty() ? "cmu" : layout_name);
    if (!m.layout.fixed_axes) m.layout.axes = up;
    m.frame_time = clip.frame_time;
    if (first < 0 || first > clip.frame_count())
      throw Error(ErrorKind::kInvalidArgument, path + ": first frame out of range");
    m.xyz = clip_positions(clip, first);
    m.frames = clip.frame_count() - first;
    return m;
  }
  if (layout_name.empty())
    throw Error(ErrorKind::kInvalidArgument, path + ": a landmark array needs --layout (mediapipe, gpd, ...)");
  if (!(fps > 0.0)) throw Error(ErrorKind::kInvalidArgument, path + ": a landmark array needs --fps (> 0)");
  m.skeleton = layout_skeleton(layout_name);
  m.layout = resolve_layout(m.skeleton, layout_name);
  if (!m.layout.fixed_axes) m.layout.axes = up;
  m.frame_time = 1.0 / fps;
  const int joints = m.skeleton.joint_count();
  if (ends_with(path, ".npy")) {
    std::vector<size_t> shape;
    const std::vector<double> values = read_npy(path, &shape);
    if (shape.size() != 3 || shape[1] != static_cast<size_t>(joints) || (shape[2] != 3 && shape[2] != 4))
      throw Error(ErrorKind::kParse, path + ": expected shape (frames, " + std::to_string(joints) +
                                         ", 3 or 4) for layout " + layout_name);
    fill_array(m, values, static_cast<int>(shape[0]), static_cast<int>(shape[2]));
  } else if (ends_with(path, ".csv")) {
    std::ifstream in(path);
    if (!in) throw Error(ErrorKind::kIo, path + ": cannot open");
    std::string line;
    std::vector<double> row, values;
    int channels = 0, frames = 0, line_no = 0;
    while (std::getline(in, line)) {
      ++line_no;
      if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
      if (!parse_numbers(line, &row)) {
        if (frames == 0 && channels == 0) continue;  // the header
        throw Error(ErrorKind::kParse, path + ":" + std::to_string(line_no) + ": a field is not a number");
      }
      const int c = static_cast<int>(row.size()) == 3 * joints ? 3 : static_cast<int>(row.size()) == 4 * joints ? 4 : 0;
      if (c == 0 || (channels != 0 && c != channels))
        throw Error(ErrorKind::kParse, path + ":" + std::to_string(line_no) + ": " + std::to_string(row.size()) +
                                           " numbers, expected " + std::to_string(3 * joints) + " or " +
                                           std::to_string(4 * joints) + " (layout " + layout_name + ")");
      channels = c;
      values.insert(values.end(), row.begin(), row.end());
      ++frames;
    }
    if (frames == 0) throw Error(ErrorKind::kParse, path + ": no frames");
    fill_array(m, values, frames, channels);
  } else {
    throw Error(ErrorKind::kInvalidArgument, path + ": unknown file type (.bvh, .npy or .csv)");
  }
  if (first < 0 || first > m.frames) throw Error(ErrorKind::kInvalidArgument, path + ": first frame out of range");
  m.xyz.erase(m.xyz.begin(), m.xyz.begin() + static_cast<std::ptrdiff_t>(first) * joints * 3);
  if (!m.confidence.empty())
    m.confidence.erase(m.confidence.begin(), m.confidence.begin() + static_cast<std::ptrdiff_t>(first) * joints);
  m.frames -= first;
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
  for (int f = 0; f < m.frames; ++f) {
    const float* conf = m.confidence.empty() ? nullptr : m.confidence.data() + static_cast<size_t>(f) * n;
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
