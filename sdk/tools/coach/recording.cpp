#include "coach/recording.hpp"

#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "common/error.hpp"

namespace kata::coach {
namespace {

// One .npy array in memory (format 1.0, little-endian, C order).
struct Array {
  std::string descr;          // "<f4", "<f8", "<i4", "<i8", "|u1"
  std::vector<size_t> shape;
  std::string bytes;
};

template <class T>
Array make_array(const char* descr, std::vector<size_t> shape, const T* data) {
  size_t n = 1;
  for (size_t s : shape) n *= s;
  return {descr, std::move(shape), std::string(reinterpret_cast<const char*>(data), n * sizeof(T))};
}

std::string npy_bytes(const Array& a) {
  std::string shape = "(";
  for (size_t s : a.shape) shape += std::to_string(s) + ",";
  if (a.shape.size() > 1) shape.pop_back();
  shape += ")";
  std::string header = "{'descr': '" + a.descr + "', 'fortran_order': False, 'shape': " + shape + ", }";
  while ((10 + header.size() + 1) % 64) header += ' ';
  header += '\n';
  std::string out = "\x93NUMPY\x01";
  out += '\0';
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  return out + header + a.bytes;
}

void put16(std::string& s, unsigned v) { s += static_cast<char>(v & 0xff), s += static_cast<char>((v >> 8) & 0xff); }
void put32(std::string& s, uint32_t v) { put16(s, v & 0xffff), put16(s, v >> 16); }
uint32_t get16(const std::string& s, size_t at) {
  return static_cast<uint8_t>(s[at]) | static_cast<uint32_t>(static_cast<uint8_t>(s[at + 1])) << 8;
}
uint32_t get32(const std::string& s, size_t at) { return get16(s, at) | get16(s, at + 2) << 16; }

// A zip of stored (uncompressed) entries: what numpy.savez writes.
std::string zip(const std::vector<std::pair<std::string, std::string>>& files) {
  std::string out, central;
  for (const auto& [name, data] : files) {
    const uint32_t crc = static_cast<uint32_t>(crc32(0L, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(data.size())));
    const uint32_t offset = static_cast<uint32_t>(out.size());
    put32(out, 0x04034b50), put16(out, 20), put16(out, 0), put16(out, 0), put16(out, 0), put16(out, 0x21);
    put32(out, crc), put32(out, static_cast<uint32_t>(data.size())), put32(out, static_cast<uint32_t>(data.size()));
    put16(out, static_cast<unsigned>(name.size())), put16(out, 0);
    out += name + data;
    put32(central, 0x02014b50), put16(central, 20), put16(central, 20), put16(central, 0), put16(central, 0);
    put16(central, 0), put16(central, 0x21), put32(central, crc), put32(central, static_cast<uint32_t>(data.size()));
    put32(central, static_cast<uint32_t>(data.size())), put16(central, static_cast<unsigned>(name.size()));
    put16(central, 0), put16(central, 0), put16(central, 0), put16(central, 0), put32(central, 0), put32(central, offset);
    central += name;
  }
  const uint32_t central_at = static_cast<uint32_t>(out.size());
  out += central;
  put32(out, 0x06054b50), put16(out, 0), put16(out, 0), put16(out, static_cast<unsigned>(files.size()));
  put16(out, static_cast<unsigned>(files.size())), put32(out, static_cast<uint32_t>(central.size())), put32(out, central_at);
  put16(out, 0);
  return out;
}

std::map<std::string, Array> read_npz(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorKind::kIo, path + ": cannot open");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string z = ss.str();
  std::map<std::string, Array> arrays;
  size_t at = 0;
  while (at + 30 <= z.size() && get32(z, at) == 0x04034b50) {
    const uint32_t method = get16(z, at + 8), size = get32(z, at + 18), name_len = get16(z, at + 26),
                   extra = get16(z, at + 28);
    if (at + 30 + name_len + extra + size > z.size()) throw Error(ErrorKind::kParse, path + ": truncated zip entry");
    std::string name = z.substr(at + 30, name_len);
    if (method != 0) throw Error(ErrorKind::kParse, path + ": " + name + " is compressed (only stored entries are read)");
    const std::string npy = z.substr(at + 30 + name_len + extra, size);
    at += 30 + name_len + extra + size;
    if (npy.size() < 10 || npy.compare(0, 6, "\x93NUMPY") != 0) throw Error(ErrorKind::kParse, path + ": " + name + " is not .npy");
    const size_t header_len = npy[6] == 1 ? get16(npy, 8) : get32(npy, 8);
    const size_t data_at = npy[6] == 1 ? 10 + header_len : 12 + header_len;
    if (data_at > npy.size()) throw Error(ErrorKind::kParse, path + ": " + name + ": truncated header");
    const std::string header = npy.substr(data_at - header_len, header_len);
    Array a;
    const size_t d = header.find("'descr': '");
    const size_t s = header.find("'shape': (");
    if (d == std::string::npos || s == std::string::npos || header.find("'fortran_order': False") == std::string::npos)
      throw Error(ErrorKind::kParse, path + ": " + name + ": unsupported .npy header");
    a.descr = header.substr(d + 10, header.find('\'', d + 10) - d - 10);
    std::string dims = header.substr(s + 10, header.find(')', s) - s - 10);
    for (size_t p = 0; p < dims.size();) {
      const size_t comma = dims.find(',', p);
      const std::string item = dims.substr(p, comma == std::string::npos ? std::string::npos : comma - p);
      if (item.find_first_not_of(' ') != std::string::npos) a.shape.push_back(std::stoull(item));
      if (comma == std::string::npos) break;
      p = comma + 1;
    }
    a.bytes = npy.substr(data_at);
    if (name.size() > 4 && name.compare(name.size() - 4, 4, ".npy") == 0) name.resize(name.size() - 4);
    arrays[name] = std::move(a);
  }
  return arrays;
}

template <class T>
std::vector<T> take(std::map<std::string, Array>& arrays, const std::string& path, const std::string& name,
                    const char* descr, std::vector<size_t> shape) {
  const auto it = arrays.find(name);
  if (it == arrays.end()) throw Error(ErrorKind::kParse, path + ": no array '" + name + "'");
  const Array& a = it->second;
  if (a.descr != descr) throw Error(ErrorKind::kParse, path + ": array '" + name + "' is " + a.descr + ", expected " + descr);
  size_t n = 1;
  for (size_t k = 0; k < shape.size(); ++k) {
    if (shape[k] == 0) shape[k] = k < a.shape.size() ? a.shape[k] : 0;  // 0: any length
    n *= shape[k];
  }
  if (a.shape != shape || a.bytes.size() != n * sizeof(T))
    throw Error(ErrorKind::kParse, path + ": array '" + name + "' has an unexpected shape");
  std::vector<T> v(n);
  if (n) std::memcpy(v.data(), a.bytes.data(), n * sizeof(T));
  return v;
}

}  // namespace

void write_recording(const LessonData& d, const std::string& path) {
  const size_t F = static_cast<size_t>(d.pushed), J = static_cast<size_t>(d.joints), G = static_cast<size_t>(d.ghost_joints);
  std::vector<double> time(F);
  std::vector<uint8_t> state(F), has_ghost(F);
  std::vector<float> score(F), distance(F), parts(F * metric::kParts), part_scores(F * metric::kParts);
  std::vector<int32_t> fix(F), matched(F);
  std::vector<int64_t> latency(F);
  std::vector<double> matched_time(F);
  for (size_t i = 0; i < F; ++i) {
    const FrameRecord& r = d.frames[i];
    matched_time[i] = r.matched_time;
    time[i] = r.time, state[i] = static_cast<uint8_t>(r.state), has_ghost[i] = r.has_ghost;
    score[i] = r.score, distance[i] = r.distance, fix[i] = r.part_to_fix, matched[i] = r.matched;
    latency[i] = r.latency_ns;
    std::copy(r.parts, r.parts + metric::kParts, parts.begin() + static_cast<ptrdiff_t>(i * metric::kParts));
    std::copy(r.part_scores, r.part_scores + metric::kParts, part_scores.begin() + static_cast<ptrdiff_t>(i * metric::kParts));
  }
  const std::vector<int32_t> parents(d.joint_parents.begin(), d.joint_parents.end());
  const std::vector<int32_t> joint_part(d.joint_part.begin(), d.joint_part.end());
  const std::vector<int32_t> sources(d.ghost_sources.begin(), d.ghost_sources.end());
  const int32_t hips[2] = {d.left_hip, d.right_hip};
  const double numbers[9] = {d.frame_time, d.delta_star, d.settings.speed, d.settings.window,
                             static_cast<double>(d.settings.first_frame), static_cast<double>(d.teacher_frames),
                             static_cast<double>(d.student_frames), d.d50, d.good_score};
  std::string text = d.settings.model + "\n" + d.settings.teacher + "\n" + d.settings.student + "\n" + d.settings.preset + "\n";
  for (const std::string& n : d.joint_names) text += n + "\n";
  const size_t K = static_cast<size_t>(metric::kParts);
  const int32_t practice[3] = {d.settings.teacher_start, d.settings.loop_first, d.settings.loop_last};
  const std::vector<std::pair<std::string, Array>> arrays = {
      {"positions", make_array("<f4", {F, J, 3}, d.positions.data())},
      {"time", make_array("<f8", {F}, time.data())},
      {"state", make_array("|u1", {F}, state.data())},
      {"score", make_array("<f4", {F}, score.data())},
      {"distance", make_array("<f4", {F}, distance.data())},
      {"parts", make_array("<f4", {F, K}, parts.data())},
      {"part_scores", make_array("<f4", {F, K}, part_scores.data())},
      {"part_to_fix", make_array("<i4", {F}, fix.data())},
      {"matched", make_array("<i4", {F}, matched.data())},
      {"latency_ns", make_array("<i8", {F}, latency.data())},
      {"ghosts", make_array("<f4", {F, G, 3}, d.ghosts.data())},
      {"has_ghost", make_array("|u1", {F}, has_ghost.data())},
      {"joint_parents", make_array("<i4", {J}, parents.data())},
      {"joint_part", make_array("<i4", {J}, joint_part.data())},
      {"ghost_sources", make_array("<i4", {G}, sources.data())},
      {"hips", make_array("<i4", {2}, hips)},
      {"numbers", make_array("<f8", {9}, numbers)},
      {"text", make_array("|u1", {text.size()}, reinterpret_cast<const uint8_t*>(text.data()))},
      // Added with the practice modes (issue 21); a recording without them reads as before.
      {"matched_time", make_array("<f8", {F}, matched_time.data())},
      {"practice", make_array("<i4", {3}, practice)},
  };
  std::vector<std::pair<std::string, std::string>> files;
  for (const auto& [name, a] : arrays) files.emplace_back(name + ".npy", npy_bytes(a));
  const std::string bytes = zip(files);
  std::ofstream out(path, std::ios::binary);
  if (!out) throw Error(ErrorKind::kIo, path + ": cannot open for writing");
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out.flush()) throw Error(ErrorKind::kIo, path + ": write failed");
}

LessonData read_recording(const std::string& path) {
  auto arrays = read_npz(path);
  LessonData d;
  const std::vector<double> numbers = take<double>(arrays, path, "numbers", "<f8", {9});
  d.frame_time = numbers[0], d.delta_star = numbers[1], d.settings.speed = numbers[2], d.settings.window = numbers[3];
  d.d50 = numbers[7], d.good_score = numbers[8];
  for (double v : numbers)
    if (!std::isfinite(v)) throw Error(ErrorKind::kParse, path + ": array 'numbers' holds a non-finite value");
  if (!(d.frame_time > 0.0)) throw Error(ErrorKind::kParse, path + ": frame_time (numbers[0]) must be > 0");
  d.settings.first_frame = static_cast<int>(numbers[4]), d.teacher_frames = static_cast<int>(numbers[5]);
  const std::vector<int32_t> parents = take<int32_t>(arrays, path, "joint_parents", "<i4", {0});
  const std::vector<int32_t> sources = take<int32_t>(arrays, path, "ghost_sources", "<i4", {0});
  const size_t J = parents.size(), G = sources.size();
  const std::vector<double> time = take<double>(arrays, path, "time", "<f8", {0});
  const size_t F = time.size();
  d.joints = static_cast<int>(J), d.ghost_joints = static_cast<int>(G);
  d.pushed = d.student_frames = static_cast<int>(F);
  d.joint_parents.assign(parents.begin(), parents.end());
  d.ghost_sources.assign(sources.begin(), sources.end());
  const std::vector<int32_t> joint_part = take<int32_t>(arrays, path, "joint_part", "<i4", {J});
  d.joint_part.assign(joint_part.begin(), joint_part.end());
  const std::vector<int32_t> hips = take<int32_t>(arrays, path, "hips", "<i4", {2});
  d.left_hip = hips[0], d.right_hip = hips[1];
  for (size_t j = 0; j < J; ++j)
    if (parents[j] >= static_cast<int32_t>(j) || (j > 0 && parents[j] < 0) || joint_part[j] < 0 || joint_part[j] >= metric::kParts)
      throw Error(ErrorKind::kParse, path + ": joint_parents / joint_part is not a skeleton");
  for (int32_t s : sources)
    if (s < 0 || static_cast<size_t>(s) >= J) throw Error(ErrorKind::kParse, path + ": ghost_sources out of range");
  if (d.left_hip >= static_cast<int>(J) || d.right_hip >= static_cast<int>(J)) throw Error(ErrorKind::kParse, path + ": hips out of range");
  d.positions = take<float>(arrays, path, "positions", "<f4", {F, J, 3});
  d.ghosts = take<float>(arrays, path, "ghosts", "<f4", {F, G, 3});
  const auto state = take<uint8_t>(arrays, path, "state", "|u1", {F});
  const auto has_ghost = take<uint8_t>(arrays, path, "has_ghost", "|u1", {F});
  const auto score = take<float>(arrays, path, "score", "<f4", {F});
  const auto distance = take<float>(arrays, path, "distance", "<f4", {F});
  const auto parts = take<float>(arrays, path, "parts", "<f4", {F, static_cast<size_t>(metric::kParts)});
  const auto part_scores = take<float>(arrays, path, "part_scores", "<f4", {F, static_cast<size_t>(metric::kParts)});
  const auto fix = take<int32_t>(arrays, path, "part_to_fix", "<i4", {F});
  const auto matched = take<int32_t>(arrays, path, "matched", "<i4", {F});
  const auto latency = take<int64_t>(arrays, path, "latency_ns", "<i8", {F});
  // Optional (recordings from before issue 21 have neither): where the student was in the routine,
  // and the practice section (teacher_start, loop_first, loop_last; -1: unset).
  const auto matched_time =
      arrays.count("matched_time") ? take<double>(arrays, path, "matched_time", "<f8", {F}) : std::vector<double>(F, -1.0);
  if (arrays.count("practice")) {
    const auto practice = take<int32_t>(arrays, path, "practice", "<i4", {3});
    d.settings.teacher_start = practice[0], d.settings.loop_first = practice[1], d.settings.loop_last = practice[2];
  }
  const auto text_bytes = take<uint8_t>(arrays, path, "text", "|u1", {0});
  std::vector<std::string> lines;
  std::string line;
  for (uint8_t c : text_bytes) {
    if (c == '\n') lines.push_back(line), line.clear();
    else line += static_cast<char>(c);
  }
  if (lines.size() != 4 + J) throw Error(ErrorKind::kParse, path + ": 'text' does not hold 4 settings and the joint names");
  d.settings.model = lines[0], d.settings.teacher = lines[1], d.settings.student = lines[2], d.settings.preset = lines[3];
  d.joint_names.assign(lines.begin() + 4, lines.end());
  d.frames.resize(F);
  for (size_t i = 0; i < F; ++i) {
    FrameRecord& r = d.frames[i];
    if (state[i] > 3 || fix[i] < -1 || fix[i] >= metric::kParts)
      throw Error(ErrorKind::kParse, path + ": frame " + std::to_string(i) + ": state or part_to_fix out of range");
    r.frame = static_cast<int64_t>(i), r.time = time[i], r.state = static_cast<FrameState>(state[i]);
    r.score = score[i], r.distance = distance[i], r.part_to_fix = fix[i], r.matched = matched[i];
    r.latency_ns = latency[i], r.has_ghost = has_ghost[i] != 0 && G > 0;
    if (!std::isfinite(matched_time[i])) throw Error(ErrorKind::kParse, path + ": frame " + std::to_string(i) + ": matched_time is not finite");
    r.matched_time = matched_time[i];
    std::copy(parts.begin() + static_cast<ptrdiff_t>(i * metric::kParts),
              parts.begin() + static_cast<ptrdiff_t>((i + 1) * metric::kParts), r.parts);
    std::copy(part_scores.begin() + static_cast<ptrdiff_t>(i * metric::kParts),
              part_scores.begin() + static_cast<ptrdiff_t>((i + 1) * metric::kParts), r.part_scores);
  }
  return d;
}

void write_results_csv(const LessonData& d, const std::string& path) {
  std::FILE* out = std::fopen(path.c_str(), "w");
  if (!out) throw Error(ErrorKind::kIo, path + ": cannot open for writing");
  std::fprintf(out, "frame,time,state,score,distance");
  for (int p = 0; p < metric::kParts; ++p) std::fprintf(out, ",%s", metric::part_name(p));
  for (int p = 0; p < metric::kParts; ++p) std::fprintf(out, ",%s_score", metric::part_name(p));
  std::fprintf(out, ",part_to_fix,matched_teacher_frame,matched_teacher_time\n");
  for (size_t i = 0; i < static_cast<size_t>(d.pushed); ++i) {
    const FrameRecord& r = d.frames[i];
    std::fprintf(out, "%lld,%.6f,%d,%.9g,%.9g", static_cast<long long>(r.frame), r.time, static_cast<int>(r.state), r.score,
                 r.distance);
    for (float p : r.parts) std::fprintf(out, ",%.9g", p);
    for (float p : r.part_scores) std::fprintf(out, ",%.9g", p);
    std::fprintf(out, ",%d,%d,%.6f\n", r.part_to_fix, r.matched, r.matched_time);
  }
  const bool ok = std::fflush(out) == 0 && !std::ferror(out);
  std::fclose(out);
  if (!ok) throw Error(ErrorKind::kIo, path + ": write failed");
}

}  // namespace kata::coach
