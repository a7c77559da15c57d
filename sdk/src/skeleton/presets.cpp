// Built-in GPD joint-name presets and the reader for user name maps (JSON or "Gpd = source" text).
#include <algorithm>
#include <cstdint>
#include <fstream>
#include <iterator>

#include "common/error.hpp"
#include "skeleton/skeleton.hpp"

namespace kata {
namespace {

using Names = std::array<std::string, kGpdJoints>;

struct Preset {
  const char* name;
  Names joints;  // in GPD order: Hip Chest Neck Head LShoulder LElbow LHand RShoulder RElbow RHand
                 //               LHip LKnee LFoot RHip RKnee RFoot
};

// Every preset maps each GPD joint to one existing joint: a pure name map. MediaPipe Pose has
// no pelvis, chest or neck landmark (those are midpoints of left/right landmarks), so it cannot
// be a name map; a MediaPipe adapter must first synthesise those joints (see the report).
const Preset kPresets[] = {
    // CMU cgspeed "Motionbuilder-friendly" conversion, fixed by spec section 1. Neck1, not the
    // zero-offset Neck that sits on Spine1.
    {"cmu",
     {"Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm", "RightForeArm",
      "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot"}},
    // CMU cgspeed "3dsMax-friendly" conversion (Biped names): the same bones as "cmu" renamed;
    // Chest2 = Spine1, Neck (above the zero-offset lowerneck) = Neck1, LeftShoulder = LeftArm.
    {"cmu-3dsmax",
     {"Hips", "Chest2", "Neck", "Head", "LeftShoulder", "LeftElbow", "LeftWrist", "RightShoulder", "RightElbow",
      "RightWrist", "LeftHip", "LeftKnee", "LeftAnkle", "RightHip", "RightKnee", "RightAnkle"}},
    // CMU cgspeed "Daz-friendly" conversion (Poser figure): chest carries neck and collars.
    {"daz",
     {"hip", "chest", "neck", "head", "lShldr", "lForeArm", "lHand", "rShldr", "rForeArm", "rHand", "lThigh",
      "lShin", "lFoot", "rThigh", "rShin", "rFoot"}},
    // Bandai Namco Research Motion Dataset: Hips (not the ground-level joint_Root) is the pelvis.
    {"bandai",
     {"Hips", "Chest", "Neck", "Head", "UpperArm_L", "LowerArm_L", "Hand_L", "UpperArm_R", "LowerArm_R",
      "Hand_R", "UpperLeg_L", "LowerLeg_L", "Foot_L", "UpperLeg_R", "LowerLeg_R", "Foot_R"}},
    // Kinect v2 JointType names. GPD Neck is the base of the neck between the shoulders, which is
    // SpineShoulder (Kinect's own "Neck" sits higher); hands are wrists, feet are ankles.
    {"kinect2",
     {"SpineBase", "SpineMid", "SpineShoulder", "Head", "ShoulderLeft", "ElbowLeft", "WristLeft", "ShoulderRight",
      "ElbowRight", "WristRight", "HipLeft", "KneeLeft", "AnkleLeft", "HipRight", "KneeRight", "AnkleRight"}},
    // Human3.6M 17-joint set (names as in VideoPose3D / h36m tooling): Spine is mid-spine, Thorax
    // the neck base; "LFoot"/"RFoot" there are the ankles.
    {"h36m",
     {"Hip", "Spine", "Thorax", "Head", "LShoulder", "LElbow", "LWrist", "RShoulder", "RElbow", "RWrist", "LHip",
      "LKnee", "LFoot", "RHip", "RKnee", "RFoot"}},
};

[[noreturn]] void parse_error(const std::string& path, int line, const std::string& what) {
  throw Error(ErrorKind::kParse, path + ":" + std::to_string(line) + ": " + what);
}

int gpd_index(const std::string& name) {
  for (int g = 0; g < kGpdJoints; ++g) {
    if (name == kGpdJointNames[static_cast<size_t>(g)]) return g;
  }
  return -1;
}

// Collects the entries of a name map and checks them as they arrive.
class MapBuilder {
 public:
  explicit MapBuilder(const std::string& path) : path_(path) {}

  void add(const std::string& gpd, const std::string& source, int line) {
    const int g = gpd_index(gpd);
    if (g < 0) {
      std::string known;
      for (const char* n : kGpdJointNames) known += std::string(known.empty() ? "" : ", ") + n;
      parse_error(path_, line, "unknown GPD joint '" + gpd + "' (known: " + known + ")");
    }
    if (source.empty()) parse_error(path_, line, "GPD joint '" + gpd + "' maps to an empty name");
    if (line_[static_cast<size_t>(g)] != 0) {
      parse_error(path_, line,
                  "GPD joint '" + gpd + "' given twice (first at line " + std::to_string(line_[static_cast<size_t>(g)]) + ")");
    }
    names_[static_cast<size_t>(g)] = source;
    line_[static_cast<size_t>(g)] = line;
  }

  // `end_line` is the line the map ended on, for the "missing joint" message.
  Names finish(int end_line) const {
    std::string missing;
    for (int g = 0; g < kGpdJoints; ++g) {
      if (line_[static_cast<size_t>(g)] == 0) {
        missing += std::string(missing.empty() ? "" : ", ") + kGpdJointNames[static_cast<size_t>(g)];
      }
    }
    if (!missing.empty()) parse_error(path_, end_line, "name map lacks GPD joint(s) " + missing);
    return names_;
  }

 private:
  std::string path_;
  Names names_;
  std::array<int, kGpdJoints> line_{};
};

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

std::string trim(const std::string& s) {
  size_t b = 0, e = s.size();
  while (b < e && is_space(s[b])) ++b;
  while (e > b && is_space(s[e - 1])) --e;
  return s.substr(b, e - b);
}

// A flat JSON object of string values, parsed by hand so every error can name its line.
class JsonMapParser {
 public:
  JsonMapParser(const std::string& text, const std::string& path) : s_(text), path_(path), map_(path) {}

  Names parse() {
    skip_ws();
    expect('{');
    skip_ws();
    if (peek() == '}') {
      ++pos_;
    } else {
      for (;;) {
        skip_ws();
        const int key_line = line_;
        if (peek() != '"') fail("expected a string key");
        const std::string key = read_string();
        skip_ws();
        expect(':');
        skip_ws();
        if (peek() != '"') fail("the value of '" + key + "' must be a string (a joint name)");
        const std::string value = read_string();
        map_.add(key, value, key_line);
        skip_ws();
        const char c = next();
        if (c == '}') break;
        if (c != ',') fail(c ? std::string("expected ',' or '}', got '") + c + "'" : "unexpected end of file");
      }
    }
    const int end_line = line_;
    skip_ws();
    if (pos_ < s_.size()) fail("unexpected text after the JSON object");
    return map_.finish(end_line);
  }

 private:
  [[noreturn]] void fail(const std::string& what) const { parse_error(path_, line_, what); }
  char peek() const { return pos_ < s_.size() ? s_[pos_] : '\0'; }
  char next() {
    if (pos_ >= s_.size()) return '\0';
    const char c = s_[pos_++];
    if (c == '\n') ++line_;
    return c;
  }
  void skip_ws() {
    while (pos_ < s_.size() && is_space(s_[pos_])) next();
  }
  void expect(char want) {
    const char c = next();
    if (c != want) {
      fail(std::string("expected '") + want + "', got " + (c ? std::string("'") + c + "'" : "end of file"));
    }
  }
  static void append_utf8(std::string& out, uint32_t cp) {
    if (cp < 0x80) {
      out += static_cast<char>(cp);
    } else if (cp < 0x800) {
      out += static_cast<char>(0xC0 | (cp >> 6));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
      out += static_cast<char>(0xE0 | (cp >> 12));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (cp >> 18));
      out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    }
  }
  uint32_t read_hex4() {
    uint32_t v = 0;
    for (int k = 0; k < 4; ++k) {
      const char c = next();
      v <<= 4;
      if (c >= '0' && c <= '9') v |= static_cast<uint32_t>(c - '0');
      else if (c >= 'a' && c <= 'f') v |= static_cast<uint32_t>(c - 'a' + 10);
      else if (c >= 'A' && c <= 'F') v |= static_cast<uint32_t>(c - 'A' + 10);
      else fail("bad \\u escape");
    }
    return v;
  }
  std::string read_string() {
    expect('"');
    std::string out;
    for (;;) {
      if (pos_ >= s_.size()) fail("unterminated string");
      if (peek() == '\n') fail("unterminated string (newline inside it)");
      const char c = next();
      if (c == '"') return out;
      if (c != '\\') {
        out += c;
        continue;
      }
      const char e = next();
      switch (e) {
        case '"': out += '"'; break;
        case '\\': out += '\\'; break;
        case '/': out += '/'; break;
        case 'b': out += '\b'; break;
        case 'f': out += '\f'; break;
        case 'n': out += '\n'; break;
        case 'r': out += '\r'; break;
        case 't': out += '\t'; break;
        case 'u': {
          uint32_t cp = read_hex4();
          // A UTF-16 surrogate pair encodes one code point above U+FFFF.
          if (cp >= 0xD800 && cp < 0xDC00) {
            if (next() != '\\' || next() != 'u') fail("unpaired UTF-16 surrogate");
            const uint32_t lo = read_hex4();
            if (lo < 0xDC00 || lo >= 0xE000) fail("unpaired UTF-16 surrogate");
            cp = 0x10000 + ((cp - 0xD800) << 10) + (lo - 0xDC00);
          } else if (cp >= 0xDC00 && cp < 0xE000) {
            fail("unpaired UTF-16 surrogate");
          }
          append_utf8(out, cp);
          break;
        }
        default: fail("bad escape in string");
      }
    }
  }

  const std::string& s_;
  std::string path_;
  MapBuilder map_;
  size_t pos_ = 0;
  int line_ = 1;
};

// "Gpd = source" lines; '#' starts a comment; blank lines are ignored.
Names parse_text_map(const std::string& text, const std::string& path) {
  MapBuilder map(path);
  int line_no = 0;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    line = trim(line);
    if (line.empty()) continue;
    const size_t eq = line.find('=');
    if (eq == std::string::npos) parse_error(path, line_no, "expected 'GpdJoint = source_joint', got '" + line + "'");
    const std::string gpd = trim(line.substr(0, eq));
    const std::string source = trim(line.substr(eq + 1));
    if (source.find('=') != std::string::npos) parse_error(path, line_no, "more than one '=' on the line");
    map.add(gpd, source, line_no);
  }
  return map.finish(std::max(line_no, 1));
}

}  // namespace

std::array<std::string, kGpdJoints> preset_joint_names(const std::string& preset) {
  for (const Preset& p : kPresets) {
    if (preset == p.name) return p.joints;
  }
  std::string known;
  for (const Preset& p : kPresets) known += std::string(known.empty() ? "" : ", ") + p.name;
  throw Error(ErrorKind::kNotFound, "unknown skeleton preset '" + preset + "' (known: " + known + ")");
}

std::vector<std::string> preset_names() {
  std::vector<std::string> out;
  for (const Preset& p : kPresets) out.emplace_back(p.name);
  return out;
}

std::array<std::string, kGpdJoints> load_name_map(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorKind::kIo, path + ": cannot open name map");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(ErrorKind::kIo, path + ": cannot read name map");
  // Editors on Windows often prepend a UTF-8 byte-order mark; it is not part of the map.
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);
  // JSON when the first non-blank character opens an object; text lines otherwise.
  const size_t first = text.find_first_not_of(" \t\r\n\f\v");
  if (first != std::string::npos && text[first] == '{') return JsonMapParser(text, path).parse();
  return parse_text_map(text, path);
}

}  // namespace kata
