// Tests of the BVH reader/writer and forward kinematics: malformed files (every error names the
// file and line), FK against hand-derived positions and an independent Affine3d implementation,
// round trips of real CMU clips, and the other skeletons in ../shared/data/other (beside the checkout, when present).
#include <gtest/gtest.h>

#include "support/temp_paths.hpp"

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>

#include <Eigen/Geometry>

#include "common/error.hpp"
#include "io/bvh.hpp"
#include "skeleton/skeleton.hpp"

// Calls of the global operator new so far (alloc_count.cpp), to check that world_positions
// (the per-frame path) allocates nothing.
#include "support/alloc_counter.hpp"

namespace fs = std::filesystem;
using kata::BvhClip;
using kata::Channel;
using kata::Error;
using kata::ErrorKind;

namespace {

using kata::test::TempDir;

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in) << path;
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::string cmu(const std::string& name) { return std::string(KATA_DATA_DIR) + "/cmu/" + name; }

// ../shared/data (next to the checkout) or $KATA_SHARED_DATA; absent in a user's clone.
fs::path shared_data() {
  if (const char* env = std::getenv("KATA_SHARED_DATA")) return env;
  return fs::path(KATA_SOURCE_DIR).parent_path() / "shared" / "data";
}

// Lines of a text, each without its '\n'.
std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> out;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t e = text.find('\n', pos);
    if (e == std::string::npos) e = text.size();
    out.push_back(text.substr(pos, e - pos));
    pos = e + 1;
  }
  return out;
}
std::string join_lines(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}
size_t find_line(const std::vector<std::string>& lines, const std::string& needle, size_t from = 0) {
  for (size_t i = from; i < lines.size(); ++i) {
    if (lines[i].find(needle) != std::string::npos) return i;
  }
  ADD_FAILURE() << "no line contains " << needle;
  return 0;
}

void expect_same_clip(const BvhClip& a, const BvhClip& b) {
  ASSERT_EQ(a.skeleton.names, b.skeleton.names);
  EXPECT_EQ(a.skeleton.parents, b.skeleton.parents);
  ASSERT_EQ(a.skeleton.offsets.size(), b.skeleton.offsets.size());
  for (size_t i = 0; i < a.skeleton.offsets.size(); ++i) EXPECT_EQ(a.skeleton.offsets[i], b.skeleton.offsets[i]) << i;
  EXPECT_EQ(a.skeleton.has_rest_pose, b.skeleton.has_rest_pose);
  EXPECT_EQ(a.channels, b.channels);
  EXPECT_EQ(a.channel_offset, b.channel_offset);
  EXPECT_EQ(a.end_site_parent, b.end_site_parent);
  ASSERT_EQ(a.end_site_offset.size(), b.end_site_offset.size());
  for (size_t i = 0; i < a.end_site_offset.size(); ++i) EXPECT_EQ(a.end_site_offset[i], b.end_site_offset[i]) << i;
  EXPECT_EQ(a.frame_time, b.frame_time);
  EXPECT_EQ(a.channel_count, b.channel_count);
  EXPECT_EQ(a.motion, b.motion);  // exact: the writer prints shortest round-trip decimals
}

// Independent FK: Affine3d chains with AngleAxis rotations, position channels replacing the
// offset's axis (the documented convention), walked recursively from each joint to the root.
Eigen::Affine3d reference_world(const BvhClip& clip, int frame, int j) {
  const double* row = clip.frame(frame) + clip.channel_offset[static_cast<size_t>(j)];
  Eigen::Vector3d t = clip.skeleton.offsets[static_cast<size_t>(j)];
  Eigen::Affine3d rot = Eigen::Affine3d::Identity();
  const auto& ch = clip.channels[static_cast<size_t>(j)];
  for (size_t k = 0; k < ch.size(); ++k) {
    const double rad = row[k] * (3.14159265358979323846 / 180.0);
    switch (ch[k]) {
      case Channel::kXpos: t.x() = row[k]; break;
      case Channel::kYpos: t.y() = row[k]; break;
      case Channel::kZpos: t.z() = row[k]; break;
      case Channel::kXrot: rot = rot * Eigen::AngleAxisd(rad, Eigen::Vector3d::UnitX()); break;
      case Channel::kYrot: rot = rot * Eigen::AngleAxisd(rad, Eigen::Vector3d::UnitY()); break;
      case Channel::kZrot: rot = rot * Eigen::AngleAxisd(rad, Eigen::Vector3d::UnitZ()); break;
    }
  }
  const Eigen::Affine3d local = Eigen::Translation3d(t) * rot;
  const int p = clip.skeleton.parents[static_cast<size_t>(j)];
  return p < 0 ? local : reference_world(clip, frame, p) * local;
}

// Three joints below a 6-channel root: A rotates in X-Y-Z order, B has 6 channels (not root),
// C has a single channel. Angles of 90 degrees make the hand derivation exact.
const char* kHandBuilt =
    "HIERARCHY\n"
    "ROOT R\n"
    "{\n"
    "  OFFSET 1 2 3\n"
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n"
    "  JOINT A\n"
    "  {\n"
    "    OFFSET 0 2 0\n"
    "    CHANNELS 3 Xrotation Yrotation Zrotation\n"
    "    JOINT B\n"
    "    {\n"
    "      OFFSET 1 0 0\n"
    "      CHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation\n"
    "      JOINT C\n"
    "      {\n"
    "        OFFSET 0 1 0\n"
    "        CHANNELS 1 Xrotation\n"
    "        End Site\n"
    "        {\n"
    "          OFFSET 0 1 0\n"
    "        }\n"
    "      }\n"
    "    }\n"
    "  }\n"
    "}\n"
    "MOTION\n"
    "Frames: 3\n"
    "Frame Time: 0.5\n"
    "10 0 0 90 0 0   90 90 0   0 0 2 90 90 0   30\n"
    "1 2 3 0 0 0   0 0 0   1 0 0 0 0 0   0\n"
    "0 0 0 0 90 90   0 0 0   0 0 0 0 0 0   0\n";

void expect_row(const Eigen::MatrixX3d& p, int row, double x, double y, double z) {
  EXPECT_NEAR(p(row, 0), x, 1e-12) << "row " << row;
  EXPECT_NEAR(p(row, 1), y, 1e-12) << "row " << row;
  EXPECT_NEAR(p(row, 2), z, 1e-12) << "row " << row;
}

}  // namespace

TEST(BvhParse, HandBuiltStructure) {
  const BvhClip c = kata::parse_bvh(kHandBuilt, "hand.bvh");
  EXPECT_EQ(c.skeleton.names, (std::vector<std::string>{"R", "A", "B", "C"}));
  EXPECT_EQ(c.skeleton.parents, (std::vector<int>{-1, 0, 1, 2}));
  EXPECT_EQ(c.channel_offset, (std::vector<int>{0, 6, 9, 15}));
  EXPECT_EQ(c.channel_count, 16);
  EXPECT_EQ(c.frame_count(), 3);
  EXPECT_EQ(c.frame_time, 0.5);
  EXPECT_EQ(c.channels[1], (std::vector<Channel>{Channel::kXrot, Channel::kYrot, Channel::kZrot}));
  EXPECT_EQ(c.end_site_parent, std::vector<int>{3});
  EXPECT_EQ(c.end_site_offset[0], Eigen::Vector3d(0, 1, 0));
  EXPECT_TRUE(c.skeleton.has_rest_pose);
}

TEST(BvhFk, HandDerivedPositions) {
  const BvhClip c = kata::parse_bvh(kHandBuilt, "hand.bvh");
  Eigen::MatrixX3d p(4, 3);
  // Frame 0. Rz(90) maps x->y, y->-x. Root at its position channels (10,0,0), not its OFFSET.
  // A = R + Rz90 (0,2,0) = (8,0,0). B's position channels (0,0,2) replace its OFFSET:
  // Rz90 Rx90 Ry90 (0,0,2) = Rz90 Rx90 (2,0,0) = Rz90 (2,0,0) = (0,2,0) -> B = (8,2,0).
  // C = B + Rz90 Rx90 Ry90 * [Ry90 Rx90] (0,1,0) = B + Rz90 Rx90 Ry90 (1,0,0)
  //   = B + Rz90 Rx90 (0,0,-1) = B + Rz90 (0,1,0) = B + (-1,0,0) = (7,2,0).
  kata::world_positions(c, 0, p);
  expect_row(p, 0, 10, 0, 0);
  expect_row(p, 1, 8, 0, 0);
  expect_row(p, 2, 8, 2, 0);
  expect_row(p, 3, 7, 2, 0);
  // Frame 1: channels equal to the offsets, no rotation -> the rest pose.
  kata::world_positions(c, 1, p);
  EXPECT_TRUE(p.isApprox(kata::rest_positions(c.skeleton), 1e-15));
  expect_row(p, 3, 2, 5, 3);
  // Frame 2: root Z Y X = 0 90 90 -> Ry90 Rx90 (listed order). A = Ry90 Rx90 (0,2,0) = Ry90 (0,0,2)
  // = (2,0,0); B's position channels are 0 -> B = A; C = B + Ry90 Rx90 (0,1,0) = B + (1,0,0).
  // (The reverse product Rx90 Ry90 would put A at (0,0,2).)
  kata::world_positions(c, 2, p);
  expect_row(p, 0, 0, 0, 0);
  expect_row(p, 1, 2, 0, 0);
  expect_row(p, 2, 2, 0, 0);
  expect_row(p, 3, 3, 0, 0);
  // unit_scale scales every length.
  Eigen::MatrixX3d q(4, 3);
  kata::world_positions(c, 0, q, 0.01);
  expect_row(q, 3, 0.07, 0.02, 0);
  expect_row(q, 1, 0.08, 0, 0);
}

TEST(BvhFk, PositionChannelSubsetReplacesOnlyItsAxis) {
  const char* text =
      "HIERARCHY\nROOT P\n{\n OFFSET 5 6 7\n CHANNELS 1 Yposition\n JOINT Q\n {\n  OFFSET 1 1 1\n  CHANNELS 0\n"
      "  End Site\n  {\n   OFFSET 0 0 1\n  }\n }\n}\nMOTION\nFrames: 1\nFrame Time: 1\n100\n";
  const BvhClip c = kata::parse_bvh(text, "subset.bvh");
  Eigen::MatrixX3d p(2, 3);
  kata::world_positions(c, 0, p);
  expect_row(p, 0, 5, 100, 7);
  expect_row(p, 1, 6, 101, 8);
}

TEST(BvhFk, DoesNotAllocatePerFrame) {
  const BvhClip c = kata::load_bvh(cmu("02_01.bvh"));
  Eigen::MatrixX3d p(c.skeleton.joint_count(), 3);
  const long before = kata::test::allocations();
  for (int f = 0; f < c.frame_count(); ++f) kata::world_positions(c, f, p);
  EXPECT_EQ(kata::test::allocations() - before, 0);

  // A 300-joint chain takes the large-skeleton path: it may allocate on the first call only.
  std::string text = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n";
  for (int j = 1; j < 300; ++j) text += "JOINT j" + std::to_string(j) + "\n{\nOFFSET 0 1 0\nCHANNELS 1 Zrotation\n";
  text += "End Site\n{\nOFFSET 0 1 0\n}\n";
  for (int j = 0; j < 300; ++j) text += "}\n";
  text += "MOTION\nFrames: 1\nFrame Time: 1\n5 0 0";
  for (int j = 1; j < 300; ++j) text += j == 1 ? " 90" : " 0";
  text += "\n";
  const BvhClip chain = kata::parse_bvh(text, "chain.bvh");
  Eigen::MatrixX3d q(300, 3);
  kata::world_positions(chain, 0, q);
  const long before_chain = kata::test::allocations();
  kata::world_positions(chain, 0, q);
  EXPECT_EQ(kata::test::allocations() - before_chain, 0);
  // j1 sits at (5,1,0) and turns 90 degrees about Z, so the rest of the chain runs along -X.
  expect_row(q, 1, 5, 1, 0);
  expect_row(q, 299, 5 - 298, 1, 0);
}

TEST(BvhFk, RejectsBadFrameOrShape) {
  const BvhClip c = kata::parse_bvh(kHandBuilt, "hand.bvh");
  Eigen::MatrixX3d p(4, 3), wrong(3, 3);
  EXPECT_THROW(kata::world_positions(c, 3, p), Error);
  EXPECT_THROW(kata::world_positions(c, -1, p), Error);
  EXPECT_THROW(kata::world_positions(c, 0, wrong), Error);
}

TEST(BvhFk, CmuClipMatchesIndependentAffineFk) {
  const BvhClip c = kata::load_bvh(cmu("02_01.bvh"));
  Eigen::MatrixX3d p(c.skeleton.joint_count(), 3);
  for (int f : {0, 1, 57, 171, 343}) {
    kata::world_positions(c, f, p);
    for (int j = 0; j < c.skeleton.joint_count(); ++j) {
      const Eigen::Vector3d ref = reference_world(c, f, j).translation();
      EXPECT_LT((p.row(j).transpose() - ref).norm(), 1e-9) << "frame " << f << " joint " << c.skeleton.names[static_cast<size_t>(j)];
    }
  }
  // Frame 0 is the converter's T-pose: head above hips, left hand at +X (body faces +Z).
  kata::world_positions(c, 0, p);
  const int head = c.skeleton.find("Head"), hips = c.skeleton.find("Hips");
  const int lhand = c.skeleton.find("LeftHand"), rhand = c.skeleton.find("RightHand");
  EXPECT_GT(p(head, 1), p(hips, 1) + 5);
  EXPECT_GT(p(lhand, 0), p(rhand, 0) + 20);
}

TEST(BvhParse, CmuClipStructureAndValuesFromText) {
  const std::string path = cmu("02_01.bvh");
  const BvhClip c = kata::load_bvh(path);
  EXPECT_EQ(c.path, path);
  EXPECT_EQ(c.skeleton.joint_count(), 31);
  EXPECT_EQ(c.channel_count, 96);
  EXPECT_EQ(c.end_site_parent.size(), 7u);
  EXPECT_EQ(c.frame_count(), 344);
  EXPECT_DOUBLE_EQ(c.frame_time, 0.0083333);
  EXPECT_EQ(c.skeleton.names[0], "Hips");
  EXPECT_EQ(c.skeleton.parents[static_cast<size_t>(c.skeleton.find("Neck1"))], c.skeleton.find("Neck"));
  // The last row read with strtod, independently.
  const auto lines = split_lines(read_text(path));
  std::istringstream last(lines.back());
  std::vector<double> want;
  std::string w;
  while (last >> w) want.push_back(std::strtod(w.c_str(), nullptr));
  ASSERT_EQ(want.size(), 96u);
  for (size_t k = 0; k < 96; ++k) EXPECT_EQ(c.frame(343)[k], want[k]) << k;
  EXPECT_EQ(c.frame(0)[0], 10.4194);
  EXPECT_EQ(c.frame(0)[9], -21.0);
}

TEST(BvhParse, CrlfTabsAndFramesWithTabGiveTheSameClip) {
  const std::string text = read_text(cmu("02_01.bvh"));
  std::string crlf;
  for (char ch : text) {
    if (ch == '\n') crlf += '\r';
    crlf += ch == ' ' ? '\t' : ch;  // every separator a tab, too
  }
  const BvhClip a = kata::parse_bvh(text, "a");
  BvhClip b = kata::parse_bvh(crlf, "a");
  expect_same_clip(a, b);
  ASSERT_NE(crlf.find("Frames:\t344"), std::string::npos);
}

TEST(BvhRoundTrip, RealCmuClipsAndHandBuilt) {
  TempDir dir;
  for (const char* name : {"02_01.bvh", "02_02.bvh", "05_02.bvh", "05_03.bvh", "07_01.bvh", "09_01.bvh"}) {
    SCOPED_TRACE(name);
    const BvhClip a = kata::load_bvh(cmu(name));
    const std::string out = dir.file(std::string("rt_") + name);
    kata::write_bvh(out, a);
    const BvhClip b = kata::load_bvh(out);
    expect_same_clip(a, b);
    // And a second generation is byte-identical to the first.
    kata::write_bvh(out + "2", b);
    EXPECT_EQ(read_text(out), read_text(out + "2"));
  }
  const BvhClip h = kata::parse_bvh(kHandBuilt, "hand.bvh");
  kata::write_bvh(dir.file("hand.bvh"), h);
  expect_same_clip(h, kata::load_bvh(dir.file("hand.bvh")));
}

TEST(BvhWrite, RefusesInconsistentClip) {
  TempDir dir;
  BvhClip c = kata::parse_bvh(kHandBuilt, "hand.bvh");
  c.motion.pop_back();
  EXPECT_THROW(kata::write_bvh(dir.file("x.bvh"), c), Error);
  c = kata::parse_bvh(kHandBuilt, "hand.bvh");
  c.skeleton.names[1] = "two words";
  EXPECT_THROW(kata::write_bvh(dir.file("x.bvh"), c), Error);
  c = kata::parse_bvh(kHandBuilt, "hand.bvh");
  try {
    kata::write_bvh(dir.file("no_such_dir/x.bvh"), c);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kIo);
  }
}

TEST(BvhErrors, EveryMalformedFileNamesFileAndLine) {
  TempDir dir;
  const std::string text = read_text(cmu("02_01.bvh"));
  const std::vector<std::string> lines = split_lines(text);
  const size_t n = lines.size();
  const size_t chan = find_line(lines, "CHANNELS 3 Zrotation Yrotation Xrotation");  // LHipJoint
  const size_t off = find_line(lines, "OFFSET 1.65674 -1.80282 0.62477");          // LeftUpLeg
  const size_t end_site = find_line(lines, "End Site");
  const size_t rhip = find_line(lines, "JOINT RHipJoint");
  const size_t motion = find_line(lines, "MOTION");
  const size_t frames = motion + 1, ftime = motion + 2, row0 = motion + 3;
  ASSERT_EQ(n - row0, 344u);
  ASSERT_EQ(lines[motion - 1], "}");

  struct Case {
    const char* what;
    std::vector<std::string> lines;
    size_t line;         // 1-based line the error must name
    const char* phrase;  // part of the message
  };
  std::vector<Case> cases;
  auto edit = [&](size_t i, const std::string& s) {
    auto l = lines;
    l[i] = s;
    return l;
  };
  auto erase = [&](size_t i) {
    auto l = lines;
    l.erase(l.begin() + static_cast<long>(i));
    return l;
  };
  auto insert = [&](size_t i, const std::string& s) {
    auto l = lines;
    l.insert(l.begin() + static_cast<long>(i), s);
    return l;
  };
  std::vector<std::string> truncated(lines.begin(), lines.end() - 10);
  cases.push_back({"truncated rows", truncated, n - 10, "truncated MOTION block"});
  cases.push_back({"fewer channel names", edit(chan, "\t\tCHANNELS 3 Zrotation Yrotation"), chan + 1, "CHANNELS 3 lists only 2"});
  cases.push_back({"more channel names", edit(chan, "\t\tCHANNELS 2 Zrotation Yrotation Xrotation"), chan + 1, "CHANNELS 2"});
  cases.push_back({"misspelt channel", edit(chan, "\t\tCHANNELS 3 Zrotation Yrotatoin Xrotation"), chan + 1, "'Yrotatoin'"});
  cases.push_back({"channel count 7", edit(chan, "\t\tCHANNELS 7 Zrotation Yrotation Xrotation"), chan + 1, "not 0..6"});
  cases.push_back({"row too long", edit(row0 + 5, lines[row0 + 5] + " 0"), row0 + 6, "more than 96 values"});
  cases.push_back({"row too short", edit(row0 + 5, lines[row0 + 5].substr(0, lines[row0 + 5].rfind(' '))), row0 + 6, "95 values"});
  cases.push_back({"unknown token", edit(off, "\t\t\tOFSET 1.65674 -1.80282 0.62477"), off + 1, "unknown token 'OFSET'"});
  cases.push_back({"non-numeric offset", edit(off, "\t\t\tOFFSET 1.65674 abc 0.62477"), off + 1, "non-numeric value 'abc'"});
  cases.push_back({"offset with 4 values", edit(off, "\t\t\tOFFSET 1 2 3 4"), off + 1, "OFFSET takes 3"});
  cases.push_back({"non-numeric motion", edit(row0 + 7, "1.2.3" + lines[row0 + 7].substr(lines[row0 + 7].find(' '))), row0 + 8, "non-numeric value '1.2.3'"});
  cases.push_back({"nan in motion", edit(row0 + 2, "nan" + lines[row0 + 2].substr(lines[row0 + 2].find(' '))), row0 + 3, "non-numeric value 'nan'"});
  cases.push_back({"zero frames", edit(frames, "Frames: 0"), frames + 1, "zero frames"});
  cases.push_back({"frames not integer", edit(frames, "Frames: 34.4"), frames + 1, "integer"});
  cases.push_back({"negative frame time", edit(ftime, "Frame Time: -0.01"), ftime + 1, "positive"});
  cases.push_back({"missing brace", erase(motion - 1), motion, "unbalanced braces"});
  cases.push_back({"extra brace", insert(motion, "}"), motion + 1, "unbalanced braces"});
  cases.push_back({"End Site without OFFSET", erase(end_site + 2), end_site + 3, "has no OFFSET"});
  cases.push_back({"duplicate joint", edit(rhip, "\tJOINT LHipJoint"), rhip + 1, "duplicate joint name 'LHipJoint'"});
  cases.push_back({"extra row", insert(n, lines.back()), n + 1, "more motion rows than Frames: 344"});
  cases.push_back({"no HIERARCHY", erase(0), 1, "expected HIERARCHY"});
  std::vector<std::string> cut_hierarchy(lines.begin(), lines.begin() + static_cast<long>(off + 1));
  cases.push_back({"file ends in hierarchy", cut_hierarchy, off + 1, "unexpected end of file"});

  for (size_t k = 0; k < cases.size(); ++k) {
    SCOPED_TRACE(cases[k].what);
    const std::string path = dir.write("case" + std::to_string(k) + ".bvh", join_lines(cases[k].lines));
    try {
      kata::load_bvh(path);
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_EQ(e.kind(), ErrorKind::kParse) << msg;
      EXPECT_EQ(msg.rfind(path + ":" + std::to_string(cases[k].line) + ": ", 0), 0u) << msg;
      EXPECT_NE(msg.find(cases[k].phrase), std::string::npos) << msg;
    }
  }

  // Cut in the middle of the last row (no final newline): the short row is named.
  const std::string mid = text.substr(0, text.size() - lines.back().size() / 2 - 1);
  const std::string path = dir.write("midrow.bvh", mid);
  try {
    kata::load_bvh(path);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ":" + std::to_string(n) + ": motion row 344 has ", 0), 0u) << e.what();
  }
  // Empty text, and parse_bvh names its stand-in.
  try {
    kata::parse_bvh("", "empty.bvh");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("empty.bvh:1: expected HIERARCHY", 0), 0u) << e.what();
  }
  // A hierarchy without any channel has no motion to read.
  try {
    kata::parse_bvh("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 1\nFrame Time: 1\n\n", "nochan.bvh");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("nochan.bvh:6: ", 0), 0u) << e.what();
  }
  try {
    kata::load_bvh(dir.file("does_not_exist.bvh"));
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::kIo);
    EXPECT_NE(std::string(e.what()).find("does_not_exist.bvh"), std::string::npos);
  }
}

// Any prefix of a real file is refused with a kata::Error naming the stand-in name and a line
// (every byte of the hierarchy, then every 4999th byte of the motion); one-byte corruptions
// either parse or are refused. Never a crash (run under the sanitizers too) or a partial clip.
TEST(BvhErrors, TruncationAndCorruptionNeverCrash) {
  const std::string text = read_text(cmu("02_01.bvh"));
  const size_t motion = text.find("MOTION");
  std::vector<size_t> cuts;
  for (size_t c = 0; c < motion + 40; ++c) cuts.push_back(c);
  for (size_t c = motion + 40; c + 1 < text.size(); c += 4999) cuts.push_back(c);
  for (size_t c : cuts) {
    try {
      kata::parse_bvh(text.substr(0, c), "cut.bvh");
      ADD_FAILURE() << "a prefix of " << c << " bytes parsed";
    } catch (const Error& e) {
      ASSERT_EQ(std::string(e.what()).rfind("cut.bvh:", 0), 0u) << e.what();
      ASSERT_EQ(e.kind(), ErrorKind::kParse);
    }
  }
  // The whole text minus its final newline is still complete.
  EXPECT_EQ(kata::parse_bvh(text.substr(0, text.size() - 1), "x").frame_count(), 344);

  const char junk[] = {'{', '}', 'x', '-', '.', ' ', '\n', '\t', '9', 'e', '\0'};
  uint64_t rng = 12345;
  for (int k = 0; k < 150; ++k) {
    rng = rng * 6364136223846793005ull + 1442695040888963407ull;  // LCG, fixed seed
    std::string t = text;
    // Half the corruptions land in the hierarchy, where the grammar is richest.
    const size_t span = (k % 2) ? motion : text.size();
    t[static_cast<size_t>((rng >> 33) % span)] = junk[(rng >> 20) % sizeof junk];
    try {
      const BvhClip c = kata::parse_bvh(t, "junk.bvh");
      EXPECT_EQ(c.motion.size(), static_cast<size_t>(c.frame_count()) * static_cast<size_t>(c.channel_count));
    } catch (const Error& e) {
      ASSERT_EQ(std::string(e.what()).rfind("junk.bvh:", 0), 0u) << e.what();
    }
  }
}

// The longest developer clip loads whole (its load time is measured in kata_bench, BM_LoadBvh*).
// Motion values are read by a fast path for plain decimals (bvh.cpp plain_decimal) and by
// from_chars otherwise: every value, of every shape a file may hold (digit and decimal counts
// around the fast path's limits, signs, a bare leading or trailing point, exponents, mantissas
// above 2^53, negative zero), is from_chars' own bit for bit.
TEST(BvhParse, MotionValuesAreFromCharsBitForBit) {
  std::mt19937_64 rng(36);
  auto digits = [&](int n) {
    std::string d;
    for (int i = 0; i < n; ++i) d += static_cast<char>('0' + rng() % 10);
    return d;
  };
  std::vector<std::string> values = {"0", "-0", "-0.0", "0.", ".5", "-.25", "5.", "+3.5", "1e5", "-2.5E-3",
                                     "9007199254740992", "9007199254740993", "18446744073709551616",
                                     "1234567890123456789", "0.0000000000000000000001", "0.00000000000000000000001",
                                     "123456789.123456789", "-179.99999999999997", "1.7976931348623157e308"};
  for (int i = 0; i < 6000; ++i) {
    const int before = static_cast<int>(rng() % 21), after = static_cast<int>(rng() % 26);
    std::string v = (rng() % 2 ? "-" : "") + digits(before);
    if (after > 0 || before == 0) v += "." + digits(std::max(after, 1));
    if (rng() % 50 == 0) v += "e" + std::to_string(static_cast<int>(rng() % 40) - 20);
    values.push_back(v);
  }
  while (values.size() % 6 != 0) values.push_back("1");
  std::string text = "HIERARCHY\nROOT R\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation "
                     "Xrotation Yrotation\n End Site\n {\n OFFSET 0 1 0\n }\n}\nMOTION\nFrames: " +
                     std::to_string(values.size() / 6) + "\nFrame Time: 0.5\n";
  for (size_t i = 0; i < values.size(); ++i) text += values[i] + (i % 6 == 5 ? "\n" : " ");
  const BvhClip c = kata::parse_bvh(text, "values.bvh");
  ASSERT_EQ(c.motion.size(), values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    const std::string& v = values[i];
    const char* b = v.data() + (v[0] == '+' ? 1 : 0);
    double want = 0.0;
    ASSERT_EQ(std::from_chars(b, v.data() + v.size(), want).ec, std::errc()) << v;
    uint64_t got_bits = 0, want_bits = 0;
    std::memcpy(&got_bits, &c.motion[i], sizeof got_bits);
    std::memcpy(&want_bits, &want, sizeof want_bits);
    ASSERT_EQ(got_bits, want_bits) << v << ": " << c.motion[i] << " vs " << want;
  }
}

// A motion block of over 2^20 values is read in two halves on two threads (bvh.cpp
// parse_motion_in_halves): the clip is the one the row-by-row parse makes of a short file with
// the same rows, and a fault anywhere in either half (a bad value, a short or long row, a row
// missing or one too many) is reported exactly as the row-by-row parse reports it, at its line.
TEST(BvhParse, LongMotionReadInHalvesIsTheSequentialParse) {
  const std::string text = read_text(cmu("02_01.bvh"));
  const size_t motion_at = text.find("Frame Time:");
  const size_t rows_at = text.find('\n', motion_at) + 1;
  const std::string header = text.substr(0, text.find("Frames:"));
  const std::vector<std::string> rows = split_lines(text.substr(rows_at));
  const BvhClip one = kata::parse_bvh(text, "02_01.bvh");
  const int copies = 40;  // 40 x 344 frames x 96 channels = 1.3 million values
  std::vector<std::string> lines;
  for (int c = 0; c < copies; ++c)
    for (int f = 0; f < one.frame_count(); ++f) lines.push_back(rows[static_cast<size_t>(f)]);
  const int header_lines = static_cast<int>(std::count(header.begin(), header.end(), '\n')) + 2;
  auto make = [&](const std::vector<std::string>& body, size_t frames) {
    std::string t = header + "Frames: " + std::to_string(frames) + "\n" + text.substr(motion_at, rows_at - motion_at);
    for (const std::string& l : body) t += l + "\n";
    return t;
  };
  const BvhClip long_clip = kata::parse_bvh(make(lines, lines.size()), "long.bvh");
  ASSERT_EQ(long_clip.frame_count(), copies * one.frame_count());
  ASSERT_GT(long_clip.motion.size(), size_t{1} << 20);
  for (int c = 0; c < copies; ++c)
    ASSERT_TRUE(std::equal(one.motion.begin(), one.motion.end(),
                           long_clip.motion.begin() + static_cast<long>(c) * static_cast<long>(one.motion.size())))
        << "copy " << c;
  // A blank line anywhere is skipped, as row by row.
  std::vector<std::string> blank = lines;
  blank.insert(blank.begin() + static_cast<long>(blank.size() * 3 / 4), "  \t");
  EXPECT_EQ(kata::parse_bvh(make(blank, lines.size()), "blank.bvh").motion, long_clip.motion);
  struct Case {
    const char* what;
    std::vector<std::string> body;
    size_t frames;
    int line;  // 1-based line of the report
    const char* says;
  };
  const size_t late = lines.size() * 3 / 4, early = lines.size() / 4;
  std::vector<Case> cases;
  auto with = [&](size_t at, const std::string& row) {
    std::vector<std::string> b = lines;
    b[at] = row;
    return b;
  };
  cases.push_back({"bad value late", with(late, lines[late] + "x"), lines.size(), static_cast<int>(late) + header_lines + 1, "non-numeric value"});
  cases.push_back({"bad value early", with(early, "1 2 zz" + lines[early]), lines.size(), static_cast<int>(early) + header_lines + 1, "non-numeric value"});
  cases.push_back({"short row late", with(late, "1 2 3"), lines.size(), static_cast<int>(late) + header_lines + 1, "has 3 values"});
  cases.push_back({"long row early", with(early, lines[early] + " 7"), lines.size(), static_cast<int>(early) + header_lines + 1, "has more than 96"});
  cases.push_back({"one row too many", lines, lines.size() - 1, static_cast<int>(lines.size()) + header_lines, "more motion rows"});
  cases.push_back({"one row missing", lines, lines.size() + 1, static_cast<int>(lines.size()) + header_lines, "truncated MOTION block"});
  for (const Case& c : cases) {
    try {
      (void)kata::parse_bvh(make(c.body, c.frames), "long.bvh");
      ADD_FAILURE() << c.what << ": accepted";
    } catch (const Error& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("long.bvh:" + std::to_string(c.line) + ":"), std::string::npos) << c.what << ": " << m;
      EXPECT_NE(m.find(c.says), std::string::npos) << c.what << ": " << m;
    }
  }
}

TEST(BvhLoad, LongCmuClipLoadsWhole) {
  const fs::path p = shared_data() / "cmu" / "01_06.bvh";
  if (!fs::exists(p)) GTEST_SKIP() << p << " not present";
  const BvhClip c = kata::load_bvh(p.string());
  EXPECT_EQ(c.frame_count(), 5134);
  EXPECT_EQ(c.skeleton.joint_count(), 31);
  EXPECT_EQ(c.channel_count, 96);
}

// The other skeletons (shared/data/other): each loads, maps with its preset, has a plausible
// rest height, and in the walking clips the head stays above the hips above both feet.
TEST(BvhOtherSkeletons, LoadWithTheirPresets) {
  const fs::path root = shared_data() / "other";
  if (!fs::exists(root)) GTEST_SKIP() << root << " not present (only on the development machine)";
  struct File {
    const char* path;
    const char* preset;
    int joints, channels, frames;
    double fps;
    double metres_per_unit;  // README: CMU ASF units, or centimetres
    bool walk;
  };
  const File files[] = {
      {"bandai_namco/dataset-1_walk_normal_001.bvh", "bandai", 22, 132, 195, 30, 0.01, true},
      {"bandai_namco/dataset-1_run_normal_001.bvh", "bandai", 22, 132, 24, 30, 0.01, false},
      {"bandai_namco/dataset-1_run_active_001.bvh", "bandai", 22, 132, 72, 30, 0.01, false},
      {"bandai_namco/dataset-1_punch_normal_001.bvh", "bandai", 22, 132, 224, 30, 0.01, false},
      {"bandai_namco/dataset-1_kick_normal_001.bvh", "bandai", 22, 132, 358, 30, 0.01, false},
      {"bandai_namco/dataset-1_dance-short_normal_001.bvh", "bandai", 22, 132, 1901, 30, 0.01, false},
      {"cmu_3dsmax_friendly/131_01.bvh", "cmu-3dsmax", 31, 96, 994, 120, 0.056444, true},
      {"cmu_daz_friendly/12_01.bvh", "daz", 43, 132, 524, 120, 0.01, true},
      {"cmu_daz_friendly/13_11.bvh", "daz", 43, 132, 416, 120, 0.01, false},
  };
  TempDir dir;
  for (const File& f : files) {
    SCOPED_TRACE(f.path);
    const BvhClip c = kata::load_bvh((root / f.path).string());
    // Mixed CRLF/LF, tabs after "Frames:", 6-channel joints and ZXY orders survive a round trip.
    kata::write_bvh(dir.file("rt.bvh"), c);
    expect_same_clip(c, kata::load_bvh(dir.file("rt.bvh")));
    EXPECT_EQ(c.skeleton.joint_count(), f.joints);
    EXPECT_EQ(c.channel_count, f.channels);
    EXPECT_EQ(c.frame_count(), f.frames);
    EXPECT_NEAR(1.0 / c.frame_time, f.fps, 0.01);
    const kata::GpdMap map = kata::make_gpd_map(c.skeleton, kata::preset_joint_names(f.preset));
    const double h_m = kata::rest_body_height(c.skeleton, map) * f.metres_per_unit;
    RecordProperty(std::string("H_m_") + fs::path(f.path).stem().string(), std::to_string(h_m));
    // H leaves out the skull above the Head joint and the foot below the ankle, so it is well
    // under stature; these subjects give 1.2-1.45 m.
    EXPECT_GT(h_m, 1.0);
    EXPECT_LT(h_m, 1.8);
    Eigen::MatrixX3d p(c.skeleton.joint_count(), 3);
    for (int i = 0; i < c.frame_count(); ++i) {
      kata::world_positions(c, i, p, f.metres_per_unit);
      ASSERT_TRUE(p.allFinite()) << "frame " << i;
      if (!f.walk) continue;
      const double hip = p(map.source[0], 1), head = p(map.source[3], 1);
      const double lfoot = p(map.source[12], 1), rfoot = p(map.source[15], 1);
      // Upright with a stance foot on the floor (Y = 0), even in 131_01's deep crouch (hips at
      // 0.53 m): a wrong rotation order or translation convention breaks these at once.
      ASSERT_GT(head, hip + 0.2) << "frame " << i;
      ASSERT_GT(hip, std::max(lfoot, rfoot) + 0.2) << "frame " << i;
      ASSERT_LT(std::min(lfoot, rfoot), 0.25) << "frame " << i;
      ASSERT_GT(std::min(lfoot, rfoot), -0.05) << "frame " << i;
    }
  }
}
