// BVH reader, writer and forward kinematics.
//
// Conventions (documented here because BVH has no formal standard):
// - Rotation channels are in degrees and compose in the order listed: "Zrotation Yrotation
//   Xrotation" gives R = Rz * Ry * Rx acting on column vectors (the child's offset).
// - Position channels REPLACE the joint's OFFSET on their axis: local translation = OFFSET with
//   each axis that has a position channel overwritten by the channel value. This is what
//   Blender's importer does (import_bvh.py: Matrix.Translation(bvh_loc - rest_head_local) as a
//   pose delta on top of the rest offset, so the final translation is exactly the channel), and
//   what the data needs: Bandai Namco files give every joint 6 channels whose position values
//   equal its OFFSET (adding them would double every bone). For CMU the root OFFSET is 0, so
//   both conventions agree there.
// - world(j) = world(parent) * T(local translation) * R(channels).
#include "io/bvh.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <future>
#include <iterator>
#include <memory>
#include <string_view>
#include <unordered_map>
#include <utility>

#include <Eigen/Geometry>

#include "common/error.hpp"
#include "common/text.hpp"
#include "io/file.hpp"
#include "metric/loading.hpp"

namespace kata {
namespace {

// Past this many joints world_positions keeps its scratch rotations in a thread-local buffer
// instead of on the stack (the stack buffer is 256 * 72 bytes = 18 KiB).
constexpr int kStackJoints = 256;

// Separators inside a line ('\n' is handled apart, it counts lines). '\r' makes CRLF files work.
bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// ASCII case-insensitive equality: keywords and channel names are matched leniently.
bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

// [b, e) as a plain decimal ("-12.345678": optional '-', digits with at most one '.', at least
// one digit), when it has at most 19 digits, a mantissa of at most 2^53 and at most 22 after
// the point: then the mantissa and 10^k are exact doubles and one IEEE division rounds their
// quotient correctly (Clinger's fast path), so the value is from_chars' bit for bit. False for
// anything else (exponents, more digits, not a number), which goes to from_chars. Why: the
// motion rows of a long teacher are millions of such numbers (7.9 million at 11 minutes), read
// on the thread everything after waits for: 19 ns a value here against 27 for from_chars
// (libstdc++ 12, the CMU rows, median of 12 passes over 492,864 values).
bool plain_decimal(const char* b, const char* e, double* out) {
  static constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                      1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  const char* p = b;
  const bool negative = p != e && *p == '-';
  if (negative) ++p;
  uint64_t m = 0;
  int digits = 0;
  const char* integer = p;
  for (; p != e && static_cast<unsigned>(*p - '0') < 10u; ++p, ++digits) m = m * 10 + static_cast<unsigned>(*p - '0');
  const bool has_integer = p != integer;
  long fraction = 0;
  if (p != e && *p == '.') {
    const char* f = ++p;
    for (; p != e && static_cast<unsigned>(*p - '0') < 10u; ++p, ++digits) m = m * 10 + static_cast<unsigned>(*p - '0');
    fraction = p - f;
  }
  if (p != e || (!has_integer && fraction == 0) || digits > 19 || m > (uint64_t{1} << 53) || fraction > 22) return false;
  const double v = static_cast<double>(m) / kPow10[fraction];
  *out = negative ? -v : v;
  return true;
}

// Parses a whole token as a finite double. Accepts a leading '+', which from_chars does not.
bool to_double(std::string_view tok, double* out) {
  const char* b = tok.data();
  const char* e = tok.data() + tok.size();
  if (b != e && *b == '+') {
    ++b;
    if (b != e && (*b == '+' || *b == '-')) return false;  // "++1", "+-1"
  }
  if (b == e) return false;
  if (plain_decimal(b, e, out)) return true;
  const auto r = std::from_chars(b, e, *out);
  return r.ec == std::errc() && r.ptr == e && std::isfinite(*out);
}

// The channel a CHANNELS entry names; false for anything else.
bool channel_from_name(std::string_view s, Channel* c) {
  static constexpr std::pair<const char*, Channel> kNames[] = {
      {"Xposition", Channel::kXpos}, {"Yposition", Channel::kYpos}, {"Zposition", Channel::kZpos},
      {"Xrotation", Channel::kXrot}, {"Yrotation", Channel::kYrot}, {"Zrotation", Channel::kZrot}};
  for (const auto& [name, ch] : kNames) {
    if (iequals(s, name)) {
      *c = ch;
      return true;
    }
  }
  return false;
}

// The canonical BVH spelling of a channel, for the writer.
const char* channel_name(Channel c) {
  switch (c) {
    case Channel::kXpos: return "Xposition";
    case Channel::kYpos: return "Yposition";
    case Channel::kZpos: return "Zposition";
    case Channel::kXrot: return "Xrotation";
    case Channel::kYrot: return "Yrotation";
    case Channel::kZrot: return "Zrotation";
  }
  return "?";
}

// One whitespace-separated word of the text and the 1-based line it is on.
struct Token {
  std::string_view text;  // empty at end of input
  int line = 0;
};

// The whole parse, over text in memory; every error names `name` and a 1-based line.
class Parser {
 public:
  Parser(std::string_view text, const std::string& name) : s_(text), path_(name), name_(bounded(name)) {}

  BvhClip run() {
    BvhClip clip;
    clip.path = path_;
    // A UTF-8 byte-order mark is not part of the format.
    if (s_.substr(0, 3) == "\xEF\xBB\xBF") pos_ = 3;
    Token t = next();
    if (!iequals(t.text, "HIERARCHY")) fail(t, "expected HIERARCHY, got " + describe(t));
    t = next();
    if (!iequals(t.text, "ROOT")) fail(t, "expected ROOT, got " + describe(t));
    parse_hierarchy(clip, t);
    parse_motion(clip);
    clip.skeleton.has_rest_pose = true;
    return clip;
  }

 private:
  // One open '{' block: a joint, or an End Site hanging from `joint`.
  struct Block {
    bool end_site;
    int joint;      // the joint itself, or the End Site's parent joint
    int open_line;  // line of the JOINT/ROOT/End keyword
    bool has_offset = false;
    bool has_channels = false;
  };

  // Throws kParse "name:line: what".
  [[noreturn]] void fail(int line, const std::string& what) const {
    throw Error(ErrorKind::kParse, name_ + ":" + std::to_string(line) + ": " + what);
  }
  [[noreturn]] void fail(const Token& t, const std::string& what) const { fail(t.line, what); }
  // A token quoted for a message (cut short: a binary file may have megabyte-long "words").
  static std::string describe(const Token& t) {
    if (t.text.empty()) return "end of file";
    if (t.text.size() > 40) return "'" + std::string(t.text.substr(0, 40)) + "...'";
    return "'" + std::string(t.text) + "'";
  }

  // Next whitespace-separated token; counts newlines as it goes.
  Token next() {
    while (pos_ < s_.size() && (is_blank(s_[pos_]) || s_[pos_] == '\n')) {
      if (s_[pos_] == '\n') ++line_;
      ++pos_;
    }
    Token t;
    const size_t b = pos_;
    while (pos_ < s_.size() && !is_blank(s_[pos_]) && s_[pos_] != '\n') ++pos_;
    t.text = s_.substr(b, pos_ - b);
    // At the end of the text, blame the last line that had something on it.
    if (!t.text.empty()) last_token_line_ = line_;
    t.line = t.text.empty() ? last_token_line_ : line_;
    return t;
  }
  // True when another token follows on the current line.
  bool more_on_line() const {
    size_t p = pos_;
    while (p < s_.size() && is_blank(s_[p])) ++p;
    return p < s_.size() && s_[p] != '\n';
  }

  // The next token as a finite number; `what` names it in messages.
  double number(const char* what) {
    const Token t = next();
    double v = 0.0;
    if (t.text.empty()) fail(t, std::string("unexpected end of file, expected ") + what);
    if (!to_double(t.text, &v)) fail(t, std::string("non-numeric value ") + describe(t) + " for " + what);
    return v;
  }

  // The '{' that must follow ROOT/JOINT name or End Site.
  void expect_open_brace(const std::string& owner) {
    const Token t = next();
    if (t.text != "{") fail(t, "expected '{' after " + owner + ", got " + describe(t));
  }

  // Appends a joint (pre-order, so parents precede children) and returns its index.
  int add_joint(BvhClip& clip, const Token& name, int parent) {
    if (name.text.empty() || name.text == "{" || name.text == "}") fail(name, "missing joint name");
    const std::string n(name.text);
    if (!index_.emplace(n, static_cast<int>(clip.skeleton.names.size())).second) {
      fail(name, "duplicate joint name '" + bounded(n) + "'");
    }
    clip.skeleton.names.push_back(n);
    clip.skeleton.parents.push_back(parent);
    clip.skeleton.offsets.emplace_back(Eigen::Vector3d::Zero());
    clip.channels.emplace_back();
    clip.channel_offset.push_back(0);
    return static_cast<int>(clip.skeleton.names.size()) - 1;
  }

  // Everything from the ROOT name to its closing brace; fills skeleton, channels, End Sites.
  void parse_hierarchy(BvhClip& clip, const Token& root_kw) {
    std::vector<Block> stack;
    const Token root_name = next();
    add_joint(clip, root_name, -1);
    expect_open_brace("ROOT " + std::string(root_name.text));
    stack.push_back({false, 0, root_kw.line});
    // Iterative, so a maliciously deep file cannot overflow the call stack.
    while (!stack.empty()) {
      const Token t = next();
      Block& top = stack.back();
      if (t.text.empty()) {
        fail(t, "unexpected end of file: unbalanced braces, the block opened at line " +
                    std::to_string(top.open_line) + " is never closed");
      } else if (iequals(t.text, "OFFSET")) {
        if (top.has_offset) fail(t, "second OFFSET in one block");
        Eigen::Vector3d off;
        for (int k = 0; k < 3; ++k) off[k] = number("OFFSET");
        if (more_on_line()) fail(t, "OFFSET takes 3 values, the line has more");
        top.has_offset = true;
        if (top.end_site) {
          clip.end_site_offset.back() = off;
        } else {
          clip.skeleton.offsets[static_cast<size_t>(top.joint)] = off;
        }
      } else if (iequals(t.text, "CHANNELS")) {
        if (top.end_site) fail(t, "an End Site has no CHANNELS");
        if (top.has_channels) fail(t, "second CHANNELS in one joint");
        top.has_channels = true;
        parse_channels(clip, top.joint, t);
      } else if (iequals(t.text, "JOINT")) {
        if (top.end_site) fail(t, "JOINT inside an End Site");
        const Token name = next();
        const int j = add_joint(clip, name, top.joint);
        expect_open_brace("JOINT " + std::string(name.text));
        stack.push_back({false, j, t.line});
      } else if (iequals(t.text, "End")) {
        if (top.end_site) fail(t, "End Site inside an End Site");
        const Token site = next();
        if (!iequals(site.text, "Site")) fail(site, "expected 'Site' after 'End', got " + describe(site));
        expect_open_brace("End Site");
        clip.end_site_parent.push_back(top.joint);
        clip.end_site_offset.emplace_back(Eigen::Vector3d::Zero());
        stack.push_back({true, top.joint, t.line});
      } else if (t.text == "}") {
        if (!top.has_offset) {
          fail(t, std::string(top.end_site ? "End Site" : "joint '" + clip.skeleton.names[static_cast<size_t>(top.joint)] + "'") +
                      " (opened at line " + std::to_string(top.open_line) + ") has no OFFSET");
        }
        stack.pop_back();
      } else if (iequals(t.text, "MOTION")) {
        fail(t, "MOTION inside the hierarchy: unbalanced braces, the block opened at line " +
                    std::to_string(top.open_line) + " is never closed");
      } else if (iequals(t.text, "ROOT")) {
        fail(t, "ROOT inside a joint (unbalanced braces?)");
      } else if (t.text == "{") {
        fail(t, "unexpected '{' (unbalanced braces)");
      } else {
        Channel c;
        if (channel_from_name(t.text, &c)) {
          fail(t, "channel name " + describe(t) + " outside a CHANNELS list (CHANNELS count too small?)");
        }
        fail(t, "unknown token " + describe(t));
      }
    }
    // Channel layout of a frame row: joints in file order, each joint's channels contiguous.
    int total = 0;
    for (size_t j = 0; j < clip.channels.size(); ++j) {
      clip.channel_offset[j] = total;
      total += static_cast<int>(clip.channels[j].size());
    }
    clip.channel_count = total;
  }

  // "CHANNELS n name...": exactly n known, distinct channel names, all on the keyword's line.
  void parse_channels(BvhClip& clip, int joint, const Token& kw) {
    const Token count_tok = next();
    int n = -1;
    {
      const char* b = count_tok.text.data();
      const char* e = b + count_tok.text.size();
      const auto r = std::from_chars(b, e, n);
      if (count_tok.text.empty() || r.ec != std::errc() || r.ptr != e) {
        fail(count_tok, "CHANNELS needs a channel count, got " + describe(count_tok));
      }
    }
    if (n < 0 || n > 6) fail(count_tok, "CHANNELS count " + std::to_string(n) + " is not 0..6");
    auto& list = clip.channels[static_cast<size_t>(joint)];
    for (int k = 0; k < n; ++k) {
      const Token c = next();
      Channel ch;
      if (!channel_from_name(c.text, &ch)) {
        fail(kw, "CHANNELS " + std::to_string(n) + " lists only " + std::to_string(k) +
                    " channel name(s); got " + describe(c));
      }
      if (std::find(list.begin(), list.end(), ch) != list.end()) fail(c, "channel " + describe(c) + " listed twice");
      list.push_back(ch);
    }
    if (more_on_line()) {
      fail(kw, "CHANNELS " + std::to_string(n) + " but the line lists more channel names");
    }
  }

  // "Frames: 12" or "Frames:12"; returns the value token.
  Token labelled_value(std::string_view label, const char* what) {
    Token t = next();
    if (t.text.size() > label.size() && iequals(t.text.substr(0, label.size()), label)) {
      t.text.remove_prefix(label.size());
      return t;
    }
    if (!iequals(t.text, label)) fail(t, std::string("expected '") + std::string(label) + "' (" + what + "), got " + describe(t));
    const Token v = next();
    if (v.text.empty()) fail(v, std::string("unexpected end of file, expected ") + what);
    return v;
  }

  // MOTION, Frames:, Frame Time:, then exactly Frames rows of channel_count numbers each.
  void parse_motion(BvhClip& clip) {
    const Token m = next();
    if (m.text == "}") fail(m, "unbalanced braces: '}' after the ROOT block is closed");
    if (iequals(m.text, "ROOT")) fail(m, "more than one ROOT is not supported");
    if (!iequals(m.text, "MOTION")) fail(m, "expected MOTION, got " + describe(m));

    const Token ft = labelled_value("Frames:", "the frame count");
    long long frames = -1;
    {
      const char* b = ft.text.data();
      const char* e = b + ft.text.size();
      const auto r = std::from_chars(b, e, frames);
      if (r.ec != std::errc() || r.ptr != e) fail(ft, "Frames: needs an integer, got " + describe(ft));
    }
    if (frames <= 0) fail(ft, "zero frames (Frames: " + bounded(ft.text) + ")");
    if (frames > 100000000) fail(ft, "Frames: " + bounded(ft.text) + " is implausibly large");

    const Token frame_kw = next();
    if (!iequals(frame_kw.text, "Frame")) fail(frame_kw, "expected 'Frame Time:', got " + describe(frame_kw));
    const Token tt = labelled_value("Time:", "the frame time");
    double dt = 0.0;
    if (!to_double(tt.text, &dt)) fail(tt, "non-numeric value " + describe(tt) + " for Frame Time");
    if (!(dt > 0.0)) fail(tt, "Frame Time must be positive");
    clip.frame_time = dt;
    if (more_on_line()) fail(tt, "unexpected text after the frame time");
    if (clip.channel_count == 0) fail(m, "the hierarchy declares no channels, so there is no motion to read");

    const size_t cc = static_cast<size_t>(clip.channel_count);
    const size_t total = static_cast<size_t>(frames) * cc;
    // Reserve no more than the text could hold (a value takes at least 2 bytes), so a lying
    // Frames: count cannot make us allocate gigabytes before the truncation is detected.
    clip.motion.reserve(std::min(total, s_.size() / 2 + 1));
    advise_huge_pages(clip.motion.data(), clip.motion.capacity() * sizeof(double));

    // Move to the line after "Frame Time:".
    while (pos_ < s_.size() && s_[pos_] != '\n') ++pos_;
    if (total >= kParallelValues && total <= s_.size() / 2 + 1 && parse_motion_in_halves(clip, frames)) return;
    long long rows = 0;
    int last_line = tt.line;  // line of the last row read, where a truncation is reported
    while (rows < frames) {
      if (pos_ >= s_.size()) {
        fail(last_line, "truncated MOTION block: Frames: says " + std::to_string(frames) + ", the file ends after " +
                            std::to_string(rows) + " rows");
      }
      // pos_ is at a '\n' (or the start of a line just after one).
      if (s_[pos_] == '\n') {
        ++pos_;
        ++line_;
      }
      const size_t eol_found = s_.find('\n', pos_);
      const size_t eol = eol_found == std::string_view::npos ? s_.size() : eol_found;
      const char* p = s_.data() + pos_;
      const char* e = s_.data() + eol;
      size_t got = 0;
      for (;;) {
        while (p < e && is_blank(*p)) ++p;
        if (p == e) break;
        const char* b = p;
        while (p < e && !is_blank(*p)) ++p;
        double v = 0.0;
        if (!to_double(std::string_view(b, static_cast<size_t>(p - b)), &v)) {
          fail(line_, "non-numeric value " + describe({std::string_view(b, static_cast<size_t>(p - b)), line_}) + " in motion row " +
                          std::to_string(rows + 1));
        }
        if (got == cc) {
          fail(line_, "motion row " + std::to_string(rows + 1) + " has more than " + std::to_string(cc) +
                          " values (the hierarchy declares " + std::to_string(cc) + " channels)");
        }
        clip.motion.push_back(v);
        ++got;
      }
      pos_ = eol;
      // A blank line between rows is skipped; at the end of the text the loop reports truncation.
      if (got == 0) continue;
      if (got != cc) {
        fail(line_, "motion row " + std::to_string(rows + 1) + " has " + std::to_string(got) + " values, expected " +
                        std::to_string(cc));
      }
      ++rows;
      last_line = line_;
    }
    // Only whitespace may follow the last row.
    while (pos_ < s_.size()) {
      if (s_[pos_] == '\n') {
        ++line_;
      } else if (!is_blank(s_[pos_])) {
        fail(line_, "more motion rows than Frames: " + std::to_string(frames) + " says");
      }
      ++pos_;
    }
  }

  // A long motion block (a long teacher's: 7.9 million values at 11 minutes) is read in two halves
  // on two threads, the second half's rows from the first line break past the middle of the text:
  // the parse was a fifth of a long teacher's load, on the thread everything else waits for.
  // Only when every line of both halves is blank or a row of channel_count values and
  // the rows add up to Frames: is the result kept: it is then the values the sequential parse
  // reads, in the same order. Anything else (an error, too few or too many rows) returns false
  // with clip.motion cleared, and the sequential parse that follows names what is wrong.
  static constexpr size_t kParallelValues = size_t{1} << 20;
  bool parse_motion_in_halves(BvhClip& clip, long long frames) {
    const size_t cc = static_cast<size_t>(clip.channel_count);
    size_t mid = pos_ + (s_.size() - pos_) / 2;
    while (mid < s_.size() && s_[mid] != '\n') ++mid;
    std::vector<double> second;
    long long rows2 = -1;
    auto later = start_beside([&] {
      second.reserve((s_.size() - mid) / 2 + 1);
      advise_huge_pages(second.data(), second.capacity() * sizeof(double));
      rows2 = rows_quietly(s_.data() + mid, s_.data() + s_.size(), cc, second);
    });
    const long long rows1 = rows_quietly(s_.data() + pos_, s_.data() + mid, cc, clip.motion);
    later.get();
    if (rows1 >= 0 && rows2 >= 0 && rows1 + rows2 == frames) {
      clip.motion.insert(clip.motion.end(), second.begin(), second.end());
      return true;
    }
    clip.motion.clear();
    return false;
  }
  // The rows of [p, end) appended to `out`, and their count; -1 at the first line that is neither
  // blank nor cc numbers.
  static long long rows_quietly(const char* p, const char* end, size_t cc, std::vector<double>& out) {
    long long rows = 0;
    while (p < end) {
      const void* found = std::memchr(p, '\n', static_cast<size_t>(end - p));
      const char* eol = found ? static_cast<const char*>(found) : end;
      size_t got = 0;
      for (;;) {
        while (p < eol && is_blank(*p)) ++p;
        if (p == eol) break;
        const char* b = p;
        while (p < eol && !is_blank(*p)) ++p;
        double v = 0.0;
        if (got == cc || !to_double(std::string_view(b, static_cast<size_t>(p - b)), &v)) return -1;
        out.push_back(v);
        ++got;
      }
      if (got != 0 && got != cc) return -1;
      if (got != 0) ++rows;
      p = eol < end ? eol + 1 : end;
    }
    return rows;
  }

  std::string_view s_;
  std::string path_;  // as given
  std::string name_;  // the path cut for messages
  size_t pos_ = 0;
  int line_ = 1;
  int last_token_line_ = 1;
  std::unordered_map<std::string, int> index_;
};

std::string format_double(double v) {
  // Shortest text that reads back to the same double: the round trip is exact.
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// format_double without the temporary string, for the motion rows.
void append_double(std::string& out, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

// Rotation about one axis by `deg` degrees, acting on column vectors.
Eigen::Matrix3d axis_rotation(Channel c, double deg) {
  constexpr double kPi = 3.14159265358979323846;
  const double a = deg * (kPi / 180.0);
  const double s = std::sin(a), co = std::cos(a);
  Eigen::Matrix3d r;
  switch (c) {
    case Channel::kXrot: r << 1, 0, 0, 0, co, -s, 0, s, co; break;
    case Channel::kYrot: r << co, 0, s, 0, 1, 0, -s, 0, co; break;
    default: r << co, -s, 0, s, co, 0, 0, 0, 1; break;  // kZrot
  }
  return r;
}

// FK with caller-provided scratch space for the world rotation of each joint.
void forward_kinematics(const BvhClip& clip, const double* row, Eigen::Ref<Eigen::MatrixX3d> out, double scale,
                        Eigen::Matrix3d* world_rot) {
  const Skeleton& sk = clip.skeleton;
  const int n = sk.joint_count();
  for (int j = 0; j < n; ++j) {
    const size_t ju = static_cast<size_t>(j);
    Eigen::Vector3d t = sk.offsets[ju];
    Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
    const double* v = row + clip.channel_offset[ju];
    const auto& chans = clip.channels[ju];
    for (size_t k = 0; k < chans.size(); ++k) {
      const Channel c = chans[k];
      switch (c) {
        case Channel::kXpos: t.x() = v[k]; break;
        case Channel::kYpos: t.y() = v[k]; break;
        case Channel::kZpos: t.z() = v[k]; break;
        default: r = r * axis_rotation(c, v[k]); break;
      }
    }
    const int p = sk.parents[ju];
    if (p < 0) {
      world_rot[j] = r;
      out.row(j) = (scale * t).transpose();
    } else {
      world_rot[j] = world_rot[p] * r;
      out.row(j) = out.row(p) + (scale * (world_rot[p] * t)).transpose();
    }
  }
}

// Throws kInvalidArgument unless the clip's tables agree (a hand-assembled clip may not).
void check_clip(const BvhClip& clip, const char* who) {
  auto fail = [&](const std::string& what) {
    throw Error(ErrorKind::kInvalidArgument, std::string(who) + ": " + what);
  };
  clip.skeleton.validate();
  const size_t n = clip.skeleton.names.size();
  if (clip.channels.size() != n || clip.channel_offset.size() != n) fail("channels/channel_offset size != joint count");
  int total = 0;
  for (size_t j = 0; j < n; ++j) {
    if (clip.channel_offset[j] != total) fail("channel_offset of joint '" + clip.skeleton.names[j] + "' is wrong");
    total += static_cast<int>(clip.channels[j].size());
  }
  if (total != clip.channel_count) fail("channel_count != sum of joint channels");
  if (clip.end_site_parent.size() != clip.end_site_offset.size()) fail("end_site_parent/end_site_offset sizes differ");
  for (int p : clip.end_site_parent) {
    if (p < 0 || static_cast<size_t>(p) >= n) fail("an End Site hangs from no joint");
  }
  if (clip.channel_count > 0 && clip.motion.size() % static_cast<size_t>(clip.channel_count) != 0) {
    fail("motion size is not a multiple of channel_count");
  }
}

}  // namespace

BvhClip parse_bvh(const std::string& text, const std::string& name) { return Parser(text, name).run(); }

BvhClip load_bvh(const std::string& path) {
  // Directories, FIFOs, devices and files over kMaxBvhBytes are refused before reading.
  BoundedFile file(path, kMaxBvhBytes, "BVH file");
  const size_t n = static_cast<size_t>(file.size());
  // Not a std::string: that would be zero-filled, then read into; this buffer is written once,
  // by read(), on huge pages (a long teacher's text runs to 60 MB and more; loading.hpp).
  const std::unique_ptr<char[]> text(new char[n]);
  advise_huge_pages(text.get(), n);
  file.read_exact(text.get(), n);
  return Parser(std::string_view(text.get(), n), path).run();
}

void world_positions(const BvhClip& clip, int i, Eigen::Ref<Eigen::MatrixX3d> out, double unit_scale) {
  const int n = clip.skeleton.joint_count();
  if (i < 0 || i >= clip.frame_count()) {
    throw Error(ErrorKind::kInvalidArgument, "world_positions: frame " + std::to_string(i) + " out of range [0, " +
                                                 std::to_string(clip.frame_count()) + ")");
  }
  // O(1) guards against a hand-assembled clip whose tables do not match its skeleton.
  if (clip.channels.size() != static_cast<size_t>(n) || clip.channel_offset.size() != static_cast<size_t>(n) ||
      clip.skeleton.parents.size() != static_cast<size_t>(n) || clip.skeleton.offsets.size() != static_cast<size_t>(n)) {
    throw Error(ErrorKind::kInvalidArgument, "world_positions: the clip's tables do not match its joint count");
  }
  if (out.rows() != n) {
    throw Error(ErrorKind::kInvalidArgument, "world_positions: out has " + std::to_string(out.rows()) +
                                                 " rows, the skeleton " + std::to_string(n) + " joints");
  }
  if (n <= kStackJoints) {
    Eigen::Matrix3d scratch[kStackJoints];
    forward_kinematics(clip, clip.frame(i), out, unit_scale, scratch);
  } else {
    // Grows once per thread to the largest skeleton seen; later calls do not allocate.
    thread_local std::vector<Eigen::Matrix3d> scratch;
    if (scratch.size() < static_cast<size_t>(n)) scratch.resize(static_cast<size_t>(n));
    forward_kinematics(clip, clip.frame(i), out, unit_scale, scratch.data());
  }
}

void write_bvh(const std::string& path, const BvhClip& clip) {
  check_clip(clip, "write_bvh");
  const Skeleton& sk = clip.skeleton;
  const int n = sk.joint_count();
  for (const std::string& name : sk.names) {
    for (char c : name) {
      if (is_blank(c) || c == '\n' || c == '{' || c == '}') {
        throw Error(ErrorKind::kInvalidArgument, "write_bvh: joint name '" + name + "' cannot be written to BVH");
      }
    }
  }
  if (clip.frame_count() == 0) throw Error(ErrorKind::kInvalidArgument, "write_bvh: the clip has no frames");

  std::vector<std::vector<int>> children(static_cast<size_t>(n));
  for (int j = 1; j < n; ++j) children[static_cast<size_t>(sk.parents[static_cast<size_t>(j)])].push_back(j);
  std::vector<std::vector<int>> sites(static_cast<size_t>(n));
  for (size_t e = 0; e < clip.end_site_parent.size(); ++e) {
    sites[static_cast<size_t>(clip.end_site_parent[e])].push_back(static_cast<int>(e));
  }

  std::string out;
  out.reserve(clip.motion.size() * 10 + 4096);
  out += "HIERARCHY\n";
  auto indent = [&](size_t depth) { out.append(depth, '\t'); };
  auto offset_line = [&](size_t depth, const Eigen::Vector3d& o) {
    indent(depth);
    out += "OFFSET " + format_double(o.x()) + " " + format_double(o.y()) + " " + format_double(o.z()) + "\n";
  };
  // Iterative pre-order walk; a frame is (joint, next child to visit). Children are visited in
  // index order, so the written file lists joints in the same order and reloads identically.
  struct Frame {
    int joint;
    size_t next_child;
  };
  std::vector<Frame> stack;
  stack.push_back({0, 0});
  while (!stack.empty()) {
    Frame& f = stack.back();
    const size_t depth = stack.size() - 1;
    const size_t ju = static_cast<size_t>(f.joint);
    if (f.next_child == 0) {
      indent(depth);
      out += (f.joint == 0 ? "ROOT " : "JOINT ") + sk.names[ju] + "\n";
      indent(depth);
      out += "{\n";
      offset_line(depth + 1, sk.offsets[ju]);
      indent(depth + 1);
      out += "CHANNELS " + std::to_string(clip.channels[ju].size());
      for (Channel c : clip.channels[ju]) out += std::string(" ") + channel_name(c);
      out += "\n";
    }
    if (f.next_child < children[ju].size()) {
      const int child = children[ju][f.next_child++];
      stack.push_back({child, 0});  // invalidates f
      continue;
    }
    for (int e : sites[ju]) {
      indent(depth + 1);
      out += "End Site\n";
      indent(depth + 1);
      out += "{\n";
      offset_line(depth + 2, clip.end_site_offset[static_cast<size_t>(e)]);
      indent(depth + 1);
      out += "}\n";
    }
    indent(depth);
    out += "}\n";
    stack.pop_back();
  }
  out += "MOTION\nFrames: " + std::to_string(clip.frame_count()) + "\nFrame Time: " + format_double(clip.frame_time) + "\n";
  const size_t cc = static_cast<size_t>(clip.channel_count);
  for (int f = 0; f < clip.frame_count(); ++f) {
    const double* row = clip.frame(f);
    for (size_t k = 0; k < cc; ++k) {
      if (k) out += ' ';
      append_double(out, row[k]);
    }
    out += '\n';
  }

  AtomicFileWriter file(path);  // a unique temporary renamed into place
  file.write(out.data(), out.size());
  file.commit();
}

}  // namespace kata
