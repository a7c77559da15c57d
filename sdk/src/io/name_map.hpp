// User name maps: which joint of an input skeleton each of the 16 GPD joints reads. Two forms,
// told apart by the first non-blank character:
//   JSON   {"Hip": "pelvis", "Chest": "spine_02", ...}        (parsed with nlohmann-json)
//   text   Hip = pelvis      one entry per line, '#' starts a comment, blank lines ignored
// All 16 GPD joints must be present, each once, with a non-empty name. A UTF-8 byte-order mark
// is ignored. Errors are kata::Error(kParse) "ORIGIN:LINE: what", ORIGIN being the file path or
// the caller's label for a map held in memory.
#pragma once

#include <array>
#include <string>

#include "skeleton/skeleton.hpp"

namespace kata {

// Parses a name map held in memory; `origin` names it in error messages (e.g. "<name map>").
// `lines`, when given, receives the line of each GPD joint's entry (for later errors about a name
// the skeleton lacks).
std::array<std::string, kGpdJoints> parse_name_map(std::string text, const std::string& origin,
                                                   std::array<int, kGpdJoints>* lines = nullptr);
// Reads a name-map file. Throws kata::Error(kIo) naming the path when it cannot be read.
std::array<std::string, kGpdJoints> load_name_map(const std::string& path, std::array<int, kGpdJoints>* lines = nullptr);

}  // namespace kata
