#include "io/name_map.hpp"

#include <algorithm>
#include <cstddef>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/error.hpp"
#include "common/text.hpp"
#include "io/file.hpp"

namespace kata {
namespace {

using Names = std::array<std::string, kGpdJoints>;

[[noreturn]] void parse_error(const std::string& origin, int line, const std::string& what) {
  // User text (names, whole lines) can be any length: both parts are cut for the message.
  throw Error(ErrorKind::kParse, bounded(origin) + ":" + std::to_string(line) + ": " + bounded(what, 4 * kMaxQuotedBytes));
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
  explicit MapBuilder(const std::string& origin) : origin_(origin) {}

  void add(const std::string& gpd, const std::string& source, int line) {
    const int g = gpd_index(gpd);
    if (g < 0) {
      std::string known;
      for (const char* n : kGpdJointNames) known += std::string(known.empty() ? "" : ", ") + n;
      parse_error(origin_, line, "unknown GPD joint '" + gpd + "' (known: " + known + ")");
    }
    if (source.empty()) parse_error(origin_, line, "GPD joint '" + gpd + "' maps to an empty name");
    if (line_[static_cast<size_t>(g)] != 0) {
      parse_error(origin_, line,
                  "GPD joint '" + gpd + "' given twice (first at line " + std::to_string(line_[static_cast<size_t>(g)]) +
                      ")");
    }
    names_[static_cast<size_t>(g)] = source;
    line_[static_cast<size_t>(g)] = line;
  }

  // `end_line` is the line the map ended on, for the "missing joint" message.
  const std::array<int, kGpdJoints>& lines() const { return line_; }

  Names finish(int end_line) const {
    std::string missing;
    for (int g = 0; g < kGpdJoints; ++g) {
      if (line_[static_cast<size_t>(g)] == 0) missing += std::string(missing.empty() ? "" : ", ") + kGpdJointNames[static_cast<size_t>(g)];
    }
    if (!missing.empty()) parse_error(origin_, end_line, "name map lacks GPD joint(s) " + missing);
    return names_;
  }

 private:
  std::string origin_;
  Names names_;
  std::array<int, kGpdJoints> line_{};
};

std::string trim(const std::string& s) {
  const char* space = " \t\r\n\f\v";
  const size_t a = s.find_first_not_of(space);
  if (a == std::string::npos) return {};
  return s.substr(a, s.find_last_not_of(space) - a + 1);
}

// "Gpd = source" lines.
Names parse_text_map(const std::string& text, const std::string& origin, std::array<int, kGpdJoints>* lines) {
  MapBuilder map(origin);
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
    if (eq == std::string::npos) parse_error(origin, line_no, "expected 'GpdJoint = source_joint', got '" + line + "'");
    const std::string gpd = trim(line.substr(0, eq));
    const std::string source = trim(line.substr(eq + 1));
    if (source.find('=') != std::string::npos) parse_error(origin, line_no, "more than one '=' on the line");
    map.add(gpd, source, line_no);
  }
  Names names = map.finish(std::max(line_no, 1));
  if (lines) *lines = map.lines();
  return names;
}

// An input iterator over the text that records how far the JSON lexer has read, so every SAX
// event can be given the line it ended on (nlohmann-json 3.11 reports positions only in errors).
struct TrackingIterator {
  using iterator_category = std::input_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;
  const char* p = nullptr;
  const char** furthest = nullptr;
  reference operator*() const {
    if (p + 1 > *furthest) *furthest = p + 1;
    return *p;
  }
  TrackingIterator& operator++() {
    ++p;
    return *this;
  }
  TrackingIterator operator++(int) {
    TrackingIterator old = *this;
    ++p;
    return old;
  }
  bool operator==(const TrackingIterator& o) const { return p == o.p; }
  bool operator!=(const TrackingIterator& o) const { return p != o.p; }
};

// SAX handler for a flat object of strings; everything else is an error at its line.
class JsonMapHandler : public nlohmann::json_sax<nlohmann::json> {
 public:
  JsonMapHandler(const std::string& text, const char* const* furthest, const std::string& origin)
      : begin_(text.data()), furthest_(furthest), origin_(origin), map_(origin) {}

  Names finish() const { return map_.finish(end_line_); }
  const std::array<int, kGpdJoints>& lines() const { return map_.lines(); }

  bool null() override { return value("null"); }
  bool boolean(bool) override { return value("a boolean"); }
  bool number_integer(number_integer_t) override { return value("a number"); }
  bool number_unsigned(number_unsigned_t) override { return value("a number"); }
  bool number_float(number_float_t, const string_t&) override { return value("a number"); }
  bool binary(binary_t&) override { return value("binary"); }
  bool string(string_t& s) override {
    if (depth_ != 1 || !have_key_) return value("a string");
    map_.add(key_, s, key_line_);
    have_key_ = false;
    return true;
  }
  bool start_object(std::size_t) override {
    if (depth_ != 0) return value("an object");
    ++depth_;
    return true;
  }
  bool key(string_t& k) override {
    key_ = k;
    key_line_ = line();
    have_key_ = true;
    return true;
  }
  bool end_object() override {
    end_line_ = line();
    --depth_;
    return true;
  }
  bool start_array(std::size_t) override { return value("an array"); }
  bool end_array() override { return true; }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception& ex) override {
    // The library's message reads "[json.exception.parse_error.101] parse error at line L, column
    // C: what"; keep "what" and give the line in our form.
    std::string what = ex.what();
    const size_t colon = what.find(": ", what.find("column"));
    if (colon != std::string::npos) what = what.substr(colon + 2);
    kata::parse_error(origin_, line(), what);
  }

 private:
  int line() const { return 1 + static_cast<int>(std::count(begin_, std::max(begin_, *furthest_ - 1), '\n')); }
  bool value(const char* kind) {
    if (depth_ == 0) kata::parse_error(origin_, line(), "a name map must be a JSON object");
    kata::parse_error(origin_, line(), "the value of '" + key_ + "' must be a string, not " + kind);
  }

  const char* begin_;
  const char* const* furthest_;
  std::string origin_;
  MapBuilder map_;
  std::string key_;
  int key_line_ = 1, end_line_ = 1, depth_ = 0;
  bool have_key_ = false;
};

Names parse_json_map(const std::string& text, const std::string& origin, std::array<int, kGpdJoints>* lines) {
  const char* furthest = text.data();
  JsonMapHandler handler(text, &furthest, origin);
  TrackingIterator first{text.data(), &furthest}, last{text.data() + text.size(), &furthest};
  nlohmann::json::sax_parse(first, last, &handler);
  Names names = handler.finish();
  if (lines) *lines = handler.lines();
  return names;
}

}  // namespace

Names parse_name_map(std::string text, const std::string& origin, std::array<int, kGpdJoints>* lines) {
  // Editors on Windows often prepend a UTF-8 byte-order mark; it is not part of the map.
  if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);
  const size_t first = text.find_first_not_of(" \t\r\n\f\v");
  if (first != std::string::npos && text[first] == '{') return parse_json_map(text, origin, lines);
  return parse_text_map(text, origin, lines);
}

Names load_name_map(const std::string& path, std::array<int, kGpdJoints>* lines) {
  // Directories, FIFOs, devices and files over kMaxNameMapBytes are refused before reading.
  return parse_name_map(read_file_bounded(path, kMaxNameMapBytes, "name map"), path, lines);
}

}  // namespace kata
