// .kata model files: FlatBuffers (schemas/model.fbs) <-> kata::metric::Model, with every check a
// model must pass before any of it is used.
#include "metric/model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <sstream>

#include "common/error.hpp"
#include "common/text.hpp"
#include "kata_schemas/model_generated.h"

namespace kata::metric {

namespace {

constexpr uint16_t kModelSchemaVersion = 1;  // what this build writes and the newest it reads
constexpr uint16_t kCalibrationSchemaVersion = 1;
constexpr const char* kLayoutId = "gpd-v1";

// Plausibility bounds of a model's values (see validate_model).
constexpr double kMaxModelValue = 1e15;   // |min|, |max|, |shift|, feature units
constexpr double kMinModelRange = 1e-9;   // a non-zero max - min (its inverse is the gain)
constexpr double kMaxModelGain = 1e9;     // scale (block-balanced)
constexpr double kMaxModelWeight = 1e6;   // |W|

[[noreturn]] void refuse(const std::string& what) { throw Error(ErrorKind::kModel, "model refused: " + what); }

// FNV-1a, 64 bit: a cheap whole-content hash. Not cryptographic; it exists to catch corruption
// (bit flips inside float arrays or strings) that the structural verifier cannot see.
class Fnv64 {
 public:
  void bytes(const void* p, size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h_ = (h_ ^ b[i]) * 0x100000001b3ULL;
  }
  template <typename T>
  void value(T v) { bytes(&v, sizeof v); }
  void text(const std::string& s) {
    value<uint64_t>(s.size());
    bytes(s.data(), s.size());
  }
  void floats(const std::vector<float>& v) {
    value<uint64_t>(v.size());
    bytes(v.data(), v.size() * sizeof(float));
  }
  uint64_t get() const { return h_; }

 private:
  uint64_t h_ = 0xcbf29ce484222325ULL;
};

// The checksum stored in the file: every semantic field in a fixed order (little-endian hosts;
// FlatBuffers itself is little-endian, and kata targets x86-64 / aarch64 little-endian only).
uint64_t checksum(const Model& m) {
  Fnv64 h;
  h.value<uint16_t>(kModelSchemaVersion);
  h.text(m.layout_id);
  h.value<int32_t>(static_cast<int32_t>(m.stencil));
  h.value<int32_t>(static_cast<int32_t>(m.normalisation));
  h.value<int32_t>(gpd::kDims);
  h.value<int32_t>(m.rank);
  h.floats(m.min);
  h.floats(m.max);
  h.floats(m.shift);
  h.floats(m.scale);
  h.floats(m.w);
  h.value<double>(m.delta_star);
  h.text(m.info.date);
  h.text(m.info.data);
  h.text(m.info.parameters);
  h.value<uint64_t>(m.info.evaluation.size());
  for (const auto& [name, value] : m.info.evaluation) {
    h.text(name);
    h.value<double>(value);
  }
  if (m.calibration) {  // absent in files written before the calibration existed
    const ScoreCalibration& c = *m.calibration;
    h.value<double>(c.d50);
    h.value<double>(c.slope);
    for (int p = 0; p < kParts; ++p) h.value<double>(c.part_d50[p]);
    for (int p = 0; p < kParts; ++p) h.value<double>(c.part_slope[p]);
    h.value<double>(c.good_score);
    h.text(c.method);
  }
  return h.get();
}

// First non-finite value in v, or -1.
long first_non_finite(const std::vector<float>& v) {
  for (size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i])) return static_cast<long>(i);
  return -1;
}

std::string show(float v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

void check_model_header(const uint8_t* data, size_t size) {
  if (size < 12) refuse("not a kata model: " + std::to_string(size) + " bytes is too small");
  if (!flatbuffers::BufferHasIdentifier(data, fb::ModelIdentifier(), /*size_prefixed=*/true)) {
    std::string id;
    for (size_t i = 8; i < 12; ++i) {
      char c[8];
      if (data[i] >= 0x20 && data[i] < 0x7f)
        std::snprintf(c, sizeof c, "%c", data[i]);
      else
        std::snprintf(c, sizeof c, "\\x%02x", data[i]);
      id += c;
    }
    refuse("not a kata model: file identifier \"" + id + "\" is not \"KATA\"");
  }
  const uint32_t prefix = flatbuffers::ReadScalar<uint32_t>(data);
  if (static_cast<uint64_t>(prefix) + 4 != size)
    refuse(std::string(prefix + uint64_t{4} > size ? "truncated" : "trailing bytes") + ": the size prefix says " +
           std::to_string(prefix + uint64_t{4}) + " bytes, the buffer has " + std::to_string(size));
}

// The content checks shared by writing and reading: everything but the container.
void validate_model(const Model& m) {
  if (m.layout_id != kLayoutId)
    refuse("layout id \"" + bounded(m.layout_id) + "\" is not \"" + kLayoutId + "\" (this build computes gpd-v1 features)");
  if (m.stencil != gpd::Stencil::kBackward && m.stencil != gpd::Stencil::kCentral)
    refuse("unknown stencil " + std::to_string(static_cast<int>(m.stencil)));
  if (m.normalisation != Normalisation::kMinMaxUnit && m.normalisation != Normalisation::kBlockBalanced)
    refuse("unknown normalisation kind " + std::to_string(static_cast<int>(m.normalisation)));
  if (m.rank <= 0) refuse("rank r = " + std::to_string(m.rank) + " (must be >= 1)");
  if (m.rank > gpd::kDims) refuse("rank r = " + std::to_string(m.rank) + " exceeds the 1683 feature dimensions");
  const size_t dims = gpd::kDims;
  if (m.min.size() != dims) refuse("min has " + std::to_string(m.min.size()) + " values, expected 1683");
  if (m.max.size() != dims) refuse("max has " + std::to_string(m.max.size()) + " values, expected 1683");
  const size_t wsize = dims * static_cast<size_t>(m.rank);
  if (m.w.size() != wsize)
    refuse("W has " + std::to_string(m.w.size()) + " values, expected 1683 x r = 1683 x " + std::to_string(m.rank) +
           " = " + std::to_string(wsize));
  if (m.normalisation == Normalisation::kBlockBalanced) {
    if (m.shift.size() != dims) refuse("shift has " + std::to_string(m.shift.size()) + " values, expected 1683");
    if (m.scale.size() != dims) refuse("scale has " + std::to_string(m.scale.size()) + " values, expected 1683");
  } else if (!m.shift.empty() || !m.scale.empty()) {
    refuse("shift/scale are present but the normalisation is min/max (they would be ignored)");
  }
  const std::pair<const char*, const std::vector<float>*> arrays[] = {
      {"min", &m.min}, {"max", &m.max}, {"shift", &m.shift}, {"scale", &m.scale}, {"W", &m.w}};
  for (const auto& [name, v] : arrays) {
    if (long i = first_non_finite(*v); i >= 0) {
      std::string where = std::string(name) + "[" + std::to_string(i) + "]";
      if (v == &m.w)
        where = "W[" + std::to_string(i % gpd::kDims) + ", " + std::to_string(i / gpd::kDims) + "]";
      refuse("NaN/Inf in " + where + " = " + show((*v)[static_cast<size_t>(i)]));
    }
  }
  for (size_t i = 0; i < dims; ++i)
    if (m.max[i] < m.min[i])
      refuse("max < min at dimension " + std::to_string(i) + " (" + show(m.max[i]) + " < " + show(m.min[i]) + ")");
  for (size_t i = 0; i < m.scale.size(); ++i)
    if (m.scale[i] < 0.0f) refuse("negative scale at dimension " + std::to_string(i));
  // Magnitudes a trained model never comes near (the shipped one: ranges >= 0.04, |W| <= 0.6),
  // bounded so that normalising and projecting any feature vector a stream can emit (features
  // below ~1e26 inside the stream's plausibility range) stays finite in float.
  for (size_t i = 0; i < dims; ++i) {
    const double range = double(m.max[i]) - m.min[i];
    if (std::fabs(m.min[i]) > kMaxModelValue || std::fabs(m.max[i]) > kMaxModelValue)
      refuse("min/max at dimension " + std::to_string(i) + " beyond +-" + show(float(kMaxModelValue)));
    if (m.normalisation == Normalisation::kMinMaxUnit && range > 0.0 && range < kMinModelRange)
      refuse("max - min = " + show(float(range)) + " at dimension " + std::to_string(i) + " is below " +
             show(float(kMinModelRange)) + " (0 or a real range)");
  }
  for (size_t i = 0; i < m.shift.size(); ++i)
    if (std::fabs(m.shift[i]) > kMaxModelValue || m.scale[i] > kMaxModelGain)
      refuse("shift/scale at dimension " + std::to_string(i) + " beyond +-" + show(float(kMaxModelValue)) + " / " +
             show(float(kMaxModelGain)));
  for (size_t i = 0; i < m.w.size(); ++i)
    if (std::fabs(m.w[i]) > kMaxModelWeight)
      refuse("|W[" + std::to_string(i % gpd::kDims) + ", " + std::to_string(i / gpd::kDims) + "]| = " +
             show(std::fabs(m.w[i])) + " exceeds " + show(float(kMaxModelWeight)));
  if (!std::isfinite(m.delta_star) || m.delta_star <= 0.0)
    refuse("delta* = " + std::to_string(m.delta_star) + " (must be finite and > 0)");
  for (const auto& [name, value] : m.info.evaluation)
    if (!std::isfinite(value)) refuse("NaN/Inf in evaluation figure \"" + name + "\"");
  if (m.calibration) validate_calibration(*m.calibration);
}

ScoreCalibration default_calibration(double delta_star) {
  ScoreCalibration c;
  c.d50 = delta_star;
  c.slope = 2.0;
  c.part_d50.fill(delta_star);
  c.part_slope.fill(2.0);
  c.good_score = 75.0;
  c.method = "default: 100 / (1 + (d / delta*)^2)";
  return c;
}

void validate_calibration(const ScoreCalibration& c) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(c.d50)) refuse("calibration d50 = " + std::to_string(c.d50) + " (must be finite and > 0)");
  if (!positive(c.slope)) refuse("calibration slope = " + std::to_string(c.slope) + " (must be finite and > 0)");
  for (int p = 0; p < kParts; ++p) {
    if (!positive(c.part_d50[p]))
      refuse(std::string("calibration d50 of part ") + part_name(p) + " = " + std::to_string(c.part_d50[p]) +
             " (must be finite and > 0)");
    if (!positive(c.part_slope[p]))
      refuse(std::string("calibration slope of part ") + part_name(p) + " = " + std::to_string(c.part_slope[p]) +
             " (must be finite and > 0)");
  }
  if (!(c.good_score >= 0.0 && c.good_score <= 100.0))
    refuse("calibration good score = " + std::to_string(c.good_score) + " (must be in 0..100)");
}

namespace {

std::vector<float> copy_floats(const flatbuffers::Vector<float>* v) {
  return v ? std::vector<float>(v->begin(), v->end()) : std::vector<float>{};
}
std::string copy_string(const flatbuffers::String* s) { return s ? s->str() : std::string{}; }

}  // namespace

std::vector<uint8_t> serialize_model(const Model& model) {
  validate_model(model);
  flatbuffers::FlatBufferBuilder b(model.w.size() * sizeof(float) + 4 * gpd::kDims * sizeof(float) + 4096);
  std::vector<flatbuffers::Offset<fb::Figure>> figures;
  for (const auto& [name, value] : model.info.evaluation)
    figures.push_back(fb::CreateFigure(b, kModelSchemaVersion, b.CreateString(name), value));
  // Each buffer object is created in its own statement: the order of function arguments is
  // unspecified (GCC evaluates them right to left, clang left to right), and the byte layout must
  // not depend on the compiler (parse_model requires the canonical layout). This is GCC's order,
  // the one every released file was written in.
  auto figure_vector = b.CreateVector(figures);
  auto parameters = b.CreateString(model.info.parameters);
  auto data = b.CreateString(model.info.data);
  auto date = b.CreateString(model.info.date);
  auto info = fb::CreateTrainingInfo(b, kModelSchemaVersion, date, data, parameters, figure_vector);
  auto layout = b.CreateString(model.layout_id);
  auto mn = b.CreateVector(model.min);
  auto mx = b.CreateVector(model.max);
  flatbuffers::Offset<flatbuffers::Vector<float>> shift, scale;
  if (!model.shift.empty()) shift = b.CreateVector(model.shift);
  if (!model.scale.empty()) scale = b.CreateVector(model.scale);
  auto w = b.CreateVector(model.w);
  flatbuffers::Offset<fb::ScoreCalibration> calibration;
  if (model.calibration) {
    const ScoreCalibration& c = *model.calibration;
    auto part_d50 = b.CreateVector(c.part_d50.data(), c.part_d50.size());
    auto part_slope = b.CreateVector(c.part_slope.data(), c.part_slope.size());
    calibration = fb::CreateScoreCalibration(b, kCalibrationSchemaVersion, c.d50, c.slope, part_d50, part_slope,
                                             c.good_score, b.CreateString(c.method));
  }
  auto root = fb::CreateModel(b, kModelSchemaVersion, layout, static_cast<fb::Stencil>(model.stencil),
                              static_cast<fb::Normalisation>(model.normalisation), gpd::kDims,
                              static_cast<uint32_t>(model.rank), mn, mx, shift, scale, w, model.delta_star, info,
                              checksum(model), calibration);
  fb::FinishSizePrefixedModelBuffer(b, root);
  return std::vector<uint8_t>(b.GetBufferPointer(), b.GetBufferPointer() + b.GetSize());
}

Model parse_model(const uint8_t* data, size_t size) {
  if (size == 0) refuse("not a kata model: the buffer is empty");
  if (size > kMaxModelBytes)
    refuse(std::to_string(size) + " bytes exceeds the " + std::to_string(kMaxModelBytes) + "-byte model limit");
  if (!data) refuse("null buffer");
  // FlatBuffers reads scalars in place and checks alignment only relative to the buffer start:
  // a buffer from a caller (e.g. a memory-mapped or embedded blob) at an odd address is copied
  // to an aligned one first, so float/double reads stay aligned.
  if (reinterpret_cast<uintptr_t>(data) % alignof(double) != 0) {
    const std::vector<uint8_t> aligned(data, data + size);  // std::allocator: aligned for double
    return parse_model(aligned.data(), aligned.size());
  }
  // A .kata buffer is size-prefixed: a 4-byte length, the root offset, then the identifier. The
  // prefix makes any truncation (even of trailing padding) or appended garbage detectable.
  check_model_header(data, size);
  // Every offset, vector length and string is checked against the buffer bounds before any
  // accessor runs: a corrupt buffer stops here (or at the content checks and checksum below).
  flatbuffers::Verifier verifier(data, size, /*max_depth=*/16, /*max_tables=*/100000);
  if (!fb::VerifySizePrefixedModelBuffer(verifier))
    refuse("the FlatBuffers verifier rejects the buffer (" + std::to_string(size) + " bytes): corrupt");
  const fb::Model* root = fb::GetSizePrefixedModel(data);
  if (root->schema_version() > kModelSchemaVersion || root->schema_version() == 0)
    refuse("schema version " + std::to_string(root->schema_version()) + " (this build reads 1)");
  if (!root->layout_id()) refuse("no layout id");
  Model m;
  m.layout_id = root->layout_id()->str();
  if (m.layout_id != kLayoutId)  // checked before the sizes: another layout explains other sizes
    refuse("layout id \"" + bounded(m.layout_id) + "\" is not \"" + kLayoutId + "\" (this build computes gpd-v1 features)");
  if (root->dims() != static_cast<uint32_t>(gpd::kDims))
    refuse("dims = " + std::to_string(root->dims()) + ", expected 1683 (gpd-v1)");
  if (root->rank() == 0) refuse("rank r = 0 (must be >= 1)");
  if (root->rank() > static_cast<uint32_t>(gpd::kDims))
    refuse("rank r = " + std::to_string(root->rank()) + " exceeds the 1683 feature dimensions");
  m.rank = static_cast<int>(root->rank());
  m.stencil = static_cast<gpd::Stencil>(root->stencil());
  m.normalisation = static_cast<Normalisation>(root->normalisation());
  m.min = copy_floats(root->min());
  m.max = copy_floats(root->max());
  m.shift = copy_floats(root->shift());
  m.scale = copy_floats(root->scale());
  m.w = copy_floats(root->w());
  m.delta_star = root->delta_star();
  if (const fb::TrainingInfo* info = root->info()) {
    m.info.date = copy_string(info->date());
    m.info.data = copy_string(info->data());
    m.info.parameters = copy_string(info->parameters());
    if (info->evaluation())
      for (const fb::Figure* f : *info->evaluation()) m.info.evaluation.emplace_back(copy_string(f->name()), f->value());
  }
  if (const fb::ScoreCalibration* c = root->calibration()) {
    // Like the model's own version: a newer calibration layout is refused, not guessed at.
    if (c->schema_version() == 0 || c->schema_version() > kCalibrationSchemaVersion)
      refuse("calibration schema version " + std::to_string(c->schema_version()) + " (this build reads 1)");
    {
      ScoreCalibration cal;
      cal.d50 = c->d50();
      cal.slope = c->slope();
      if (!c->part_d50() || c->part_d50()->size() != kParts || !c->part_slope() || c->part_slope()->size() != kParts)
        refuse("calibration: part_d50 and part_slope must hold 5 values each");
      for (int p = 0; p < kParts; ++p) {
        cal.part_d50[p] = c->part_d50()->Get(static_cast<flatbuffers::uoffset_t>(p));
        cal.part_slope[p] = c->part_slope()->Get(static_cast<flatbuffers::uoffset_t>(p));
      }
      cal.good_score = c->good_score();
      cal.method = copy_string(c->method());
      m.calibration = cal;
    }
  }
  validate_model(m);
  if (checksum(m) != root->checksum()) refuse("checksum mismatch: the content is corrupt (a changed bit or byte)");
  // The checksum covers every value; the bytes around them (alignment padding, string
  // terminators, vtable entries of defaulted fields, the size fields of vtables) carry none, so a
  // flipped bit there leaves the content intact. The writer is deterministic, so a file of this
  // build's schema version must be byte for byte what serialize_model makes of its content:
  // that covers every byte of the file (a single-bit flip anywhere is refused).
  if (root->schema_version() == kModelSchemaVersion) {
    const std::vector<uint8_t> canonical = serialize_model(m);
    if (canonical.size() != size || std::memcmp(canonical.data(), data, size) != 0) {
      size_t at = 0;
      while (at < size && at < canonical.size() && canonical[at] == data[at]) ++at;
      refuse("byte " + std::to_string(at) +
             " differs from the canonical layout of the same content (a changed bit outside the values: padding, "
             "terminators or table metadata)");
    }
  }
  return m;
}

}  // namespace kata::metric
