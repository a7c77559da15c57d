// Tests of the skeleton module: GPD constants, validation, rest pose, presets, name-map files and
// the body height H, against values derived independently (by hand or from the file's text).
#include <gtest/gtest.h>

#include "support/temp_paths.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "io/name_map.hpp"
#include "common/error.hpp"
#include "common/text.hpp"
#include "io/bvh.hpp"
#include "skeleton/skeleton.hpp"

namespace fs = std::filesystem;
using kata::Error;
using kata::ErrorKind;
using kata::kGpdJoints;

namespace {

using kata::test::TempDir;

// A skeleton that has the given names, all hanging from the first (enough to resolve names).
kata::Skeleton flat_skeleton(const std::vector<std::string>& names) {
  kata::Skeleton s;
  for (size_t i = 0; i < names.size(); ++i) {
    s.names.push_back(names[i]);
    s.parents.push_back(i == 0 ? -1 : 0);
    s.offsets.emplace_back(static_cast<double>(i), 0.0, 0.0);
  }
  return s;
}

// Runs f, expects a kata::Error of `kind` whose message contains every string in `parts`.
template <typename F>
void expect_error(F&& f, ErrorKind kind, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "no kata::Error thrown";
  } catch (const Error& e) {
    EXPECT_EQ(static_cast<int>(e.kind()), static_cast<int>(kind)) << e.what();
    for (const auto& p : parts) EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << "'" << p << "' not in: " << e.what();
  }
}

const char* kCmuNames[kGpdJoints] = {"Hips",      "Spine1",    "Neck1",    "Head",         "LeftArm",  "LeftForeArm",
                                     "LeftHand",  "RightArm",  "RightForeArm", "RightHand", "LeftUpLeg", "LeftLeg",
                                     "LeftFoot",  "RightUpLeg", "RightLeg", "RightFoot"};

}  // namespace

TEST(GpdSkeleton, NamesAndParentsFollowSpecTable) {
  // Spec gpd-v1.md section 1, transcribed by hand.
  const char* names[kGpdJoints] = {"Hip",  "Chest", "Neck",  "Head",  "LShoulder", "LElbow", "LHand", "RShoulder",
                                   "RElbow", "RHand", "LHip", "LKnee", "LFoot",     "RHip",   "RKnee", "RFoot"};
  const int parents[kGpdJoints] = {-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14};
  for (int i = 0; i < kGpdJoints; ++i) {
    EXPECT_STREQ(kata::kGpdJointNames[static_cast<size_t>(i)], names[i]);
    EXPECT_EQ(kata::kGpdParents[static_cast<size_t>(i)], parents[i]) << names[i];
  }
}

TEST(SkeletonValidate, AcceptsTreeRejectsBadOnes) {
  kata::Skeleton s = flat_skeleton({"a", "b", "c"});
  EXPECT_NO_THROW(s.validate());
  EXPECT_EQ(s.find("c"), 2);
  EXPECT_EQ(s.find("zz"), -1);

  kata::Skeleton dup = flat_skeleton({"a", "b", "b"});
  expect_error([&] { dup.validate(); }, ErrorKind::kInvalidArgument, {"duplicate", "'b'"});
  kata::Skeleton fwd = flat_skeleton({"a", "b", "c"});
  fwd.parents[1] = 2;  // parent after child
  expect_error([&] { fwd.validate(); }, ErrorKind::kInvalidArgument, {"'b'"});
  kata::Skeleton noroot = flat_skeleton({"a", "b"});
  noroot.parents[0] = 0;
  expect_error([&] { noroot.validate(); }, ErrorKind::kInvalidArgument, {"root"});
  kata::Skeleton sizes = flat_skeleton({"a", "b"});
  sizes.offsets.pop_back();
  expect_error([&] { sizes.validate(); }, ErrorKind::kInvalidArgument, {"size"});
  kata::Skeleton empty_name = flat_skeleton({"a", ""});
  expect_error([&] { empty_name.validate(); }, ErrorKind::kInvalidArgument, {"empty"});
  expect_error([&] { kata::Skeleton{}.validate(); }, ErrorKind::kInvalidArgument, {"no joints"});
}

TEST(SkeletonRest, PositionsAccumulateOffsets) {
  kata::Skeleton s;
  s.names = {"root", "a", "b", "c"};
  s.parents = {-1, 0, 1, 0};
  s.offsets = {{1, 2, 3}, {0, 1, 0}, {2, 0, 0}, {0, 0, -4}};
  const Eigen::MatrixX3d p = kata::rest_positions(s);
  ASSERT_EQ(p.rows(), 4);
  // Sums along each chain, by hand.
  EXPECT_EQ(p.row(0), Eigen::RowVector3d(1, 2, 3));
  EXPECT_EQ(p.row(1), Eigen::RowVector3d(1, 3, 3));
  EXPECT_EQ(p.row(2), Eigen::RowVector3d(3, 3, 3));
  EXPECT_EQ(p.row(3), Eigen::RowVector3d(1, 2, -1));
}

TEST(Presets, CmuIsTheSpecMap) {
  const auto names = kata::preset_joint_names("cmu");
  for (int i = 0; i < kGpdJoints; ++i) EXPECT_EQ(names[static_cast<size_t>(i)], kCmuNames[i]);
}

TEST(Presets, EveryListedPresetResolvesAgainstItsSkeletonNames) {
  // Full joint lists of each source skeleton, typed from the sources (README hierarchies, the
  // Kinect v2 JointType enum, the Human3.6M 17-joint list), not from the preset table.
  const std::map<std::string, std::vector<std::string>> sources = {
      {"cmu",
       {"Hips", "LHipJoint", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "RHipJoint", "RightUpLeg", "RightLeg",
        "RightFoot", "RightToeBase", "LowerBack", "Spine", "Spine1", "Neck", "Neck1", "Head", "LeftShoulder",
        "LeftArm", "LeftForeArm", "LeftHand", "LeftFingerBase", "LeftHandIndex1", "LThumb", "RightShoulder",
        "RightArm", "RightForeArm", "RightHand", "RightFingerBase", "RightHandIndex1", "RThumb"}},
      {"cmu-3dsmax",
       {"Hips", "LHipJoint", "LeftHip", "LeftKnee", "LeftAnkle", "LeftToe", "RHipJoint", "RightHip", "RightKnee",
        "RightAnkle", "RightToe", "lowerback", "Chest", "Chest2", "lowerneck", "Neck", "Head", "LeftCollar",
        "LeftShoulder", "LeftElbow", "LeftWrist", "lhand", "LFingers", "LThumb", "RightCollar", "RightShoulder",
        "RightElbow", "RightWrist", "rhand", "RFingers", "RThumb"}},
      {"daz",
       {"hip",      "abdomen",  "chest",    "neck",    "head",    "leftEye", "rightEye", "rCollar", "rShldr",
        "rForeArm", "rHand",    "rThumb1",  "rThumb2", "rIndex1", "rIndex2", "rMid1",    "rMid2",   "rRing1",
        "rRing2",   "rPinky1",  "rPinky2",  "lCollar", "lShldr",  "lForeArm", "lHand",   "lThumb1", "lThumb2",
        "lIndex1",  "lIndex2",  "lMid1",    "lMid2",   "lRing1",  "lRing2",  "lPinky1",  "lPinky2", "rButtock",
        "rThigh",   "rShin",    "rFoot",    "lButtock", "lThigh", "lShin",   "lFoot"}},
      {"bandai",
       {"joint_Root", "Hips", "Spine", "Chest", "Neck", "Head", "Shoulder_L", "UpperArm_L", "LowerArm_L", "Hand_L",
        "Shoulder_R", "UpperArm_R", "LowerArm_R", "Hand_R", "UpperLeg_L", "LowerLeg_L", "Foot_L", "Toes_L",
        "UpperLeg_R", "LowerLeg_R", "Foot_R", "Toes_R"}},
      {"kinect2",
       {"SpineBase", "SpineMid", "Neck", "Head", "ShoulderLeft", "ElbowLeft", "WristLeft", "HandLeft",
        "ShoulderRight", "ElbowRight", "WristRight", "HandRight", "HipLeft", "KneeLeft", "AnkleLeft", "FootLeft",
        "HipRight", "KneeRight", "AnkleRight", "FootRight", "SpineShoulder", "HandTipLeft", "ThumbLeft",
        "HandTipRight", "ThumbRight"}},
      {"h36m",
       {"Hip", "RHip", "RKnee", "RFoot", "LHip", "LKnee", "LFoot", "Spine", "Thorax", "Neck/Nose", "Head",
        "LShoulder", "LElbow", "LWrist", "RShoulder", "RElbow", "RWrist"}},
      {"azure-kinect",
       {"PELVIS", "SPINE_NAVEL", "SPINE_CHEST", "NECK", "CLAVICLE_LEFT", "SHOULDER_LEFT", "ELBOW_LEFT", "WRIST_LEFT",
        "HAND_LEFT", "HANDTIP_LEFT", "THUMB_LEFT", "CLAVICLE_RIGHT", "SHOULDER_RIGHT", "ELBOW_RIGHT", "WRIST_RIGHT",
        "HAND_RIGHT", "HANDTIP_RIGHT", "THUMB_RIGHT", "HIP_LEFT", "KNEE_LEFT", "ANKLE_LEFT", "FOOT_LEFT", "HIP_RIGHT",
        "KNEE_RIGHT", "ANKLE_RIGHT", "FOOT_RIGHT", "HEAD", "NOSE", "EYE_LEFT", "EAR_LEFT", "EYE_RIGHT", "EAR_RIGHT"}},
      {"xsens",
       {"Pelvis", "L5", "L3", "T12", "T8", "Neck", "Head", "RightShoulder", "RightUpperArm", "RightForeArm",
        "RightHand", "LeftShoulder", "LeftUpperArm", "LeftForeArm", "LeftHand", "RightUpperLeg", "RightLowerLeg",
        "RightFoot", "RightToe", "LeftUpperLeg", "LeftLowerLeg", "LeftFoot", "LeftToe"}},
      {"gpd",
       {"Hip", "Chest", "Neck", "Head", "LShoulder", "LElbow", "LHand", "RShoulder", "RElbow", "RHand", "LHip",
        "LKnee", "LFoot", "RHip", "RKnee", "RFoot"}},
      {"vrm",
       {"Hips", "Spine", "Chest", "UpperChest", "Neck", "Head", "LeftShoulder", "LeftUpperArm", "LeftLowerArm",
        "LeftHand", "RightShoulder", "RightUpperArm", "RightLowerArm", "RightHand", "LeftUpperLeg", "LeftLowerLeg",
        "LeftFoot", "LeftToes", "RightUpperLeg", "RightLowerLeg", "RightFoot", "RightToes"}},
  };
  const auto presets = kata::preset_names();
  EXPECT_EQ(presets.size(), sources.size());
  for (const auto& p : presets) {
    SCOPED_TRACE(p);
    ASSERT_TRUE(sources.count(p)) << "preset without a test skeleton";
    const kata::Skeleton s = flat_skeleton(sources.at(p));
    ASSERT_NO_THROW(s.validate());
    const auto names = kata::preset_joint_names(p);
    const kata::GpdMap map = kata::make_gpd_map(s, names);
    // Distinct GPD joints must read distinct source joints.
    for (int a = 0; a < kGpdJoints; ++a) {
      EXPECT_EQ(s.names[static_cast<size_t>(map.source[static_cast<size_t>(a)])], names[static_cast<size_t>(a)]);
      for (int b = a + 1; b < kGpdJoints; ++b) EXPECT_NE(map.source[static_cast<size_t>(a)], map.source[static_cast<size_t>(b)]);
    }
  }
}

TEST(Presets, SpotChecksOfNonCmuPresets) {
  // GPD Neck is the neck base: Kinect's SpineShoulder, H36M's Thorax; hands are wrists.
  EXPECT_EQ(kata::preset_joint_names("kinect2")[2], "SpineShoulder");
  EXPECT_EQ(kata::preset_joint_names("kinect2")[6], "WristLeft");
  EXPECT_EQ(kata::preset_joint_names("h36m")[2], "Thorax");
  EXPECT_EQ(kata::preset_joint_names("h36m")[9], "RWrist");
  EXPECT_EQ(kata::preset_joint_names("bandai")[0], "Hips");
  EXPECT_EQ(kata::preset_joint_names("daz")[12], "lFoot");
  EXPECT_EQ(kata::preset_joint_names("cmu-3dsmax")[15], "RightAnkle");
}

TEST(Presets, UnknownPresetListsKnownOnes) {
  // MediaPipe is deliberately not a preset: its pelvis/chest/neck are not landmarks.
  expect_error([] { kata::preset_joint_names("mediapipe"); }, ErrorKind::kNotFound, {"mediapipe", "cmu", "kinect2", "h36m"});
}

TEST(GpdMapTest, MissingJointIsNamed) {
  std::vector<std::string> names(kCmuNames, kCmuNames + kGpdJoints);
  names.erase(names.begin() + 2);  // no Neck1
  const kata::Skeleton s = flat_skeleton(names);
  expect_error([&] { kata::make_gpd_map(s, kata::preset_joint_names("cmu")); }, ErrorKind::kNotFound, {"Neck1", "GPD Neck"});
}

TEST(GpdMapTest, MissingJointSuggestsTheClosestNameAndListsTheSkeletonsJoints) {
  // A typo ("RightFot" for RightFoot) gets its correction; the message lists every joint the
  // skeleton has, so that a name map can be written from it.
  std::vector<std::string> names(kCmuNames, kCmuNames + kGpdJoints);
  const auto right_foot = std::find(names.begin(), names.end(), std::string("RightFoot"));
  ASSERT_NE(right_foot, names.end());
  *right_foot = "RightFot";
  const kata::Skeleton s = flat_skeleton(names);
  expect_error([&] { kata::resolve_layout(s, "cmu"); }, ErrorKind::kNotFound,
               {"layout 'cmu'", "'RightFoot' (GPD RFoot)", "did you mean 'RightFot'?", "its 16 joints are: Hips, ",
                "RightFot"});
  // A name nothing resembles gets no suggestion.
  *std::find(names.begin(), names.end(), std::string("RightFot")) = "Xyzzy";
  try {
    kata::resolve_layout(flat_skeleton(names), "cmu");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).find("did you mean"), std::string::npos) << e.what();
  }
}

TEST(ClosestName, TyposAreFoundOtherWordsAreNot) {
  const std::vector<std::string> candidates = {"LeftFoot", "RightFoot", "Hips", "Spine1"};
  EXPECT_EQ(kata::closest_name("RightFot", candidates), "RightFoot");
  EXPECT_EQ(kata::closest_name("hips", candidates), "Hips");  // case alone is a difference worth naming
  EXPECT_EQ(kata::closest_name("leftfoot", candidates), "LeftFoot");
  EXPECT_EQ(kata::closest_name("Neck", candidates), "");
  EXPECT_EQ(kata::closest_name("RightFoot", candidates), "");  // an exact match is not a typo
  EXPECT_EQ(kata::closest_name("x", {}), "");
}

TEST(BodyHeight, HandComputedSegments) {
  Eigen::Matrix<double, kGpdJoints, 3> j = Eigen::Matrix<double, kGpdJoints, 3>::Zero();
  j.row(0) << 0, 10, 0;   // Hip
  j.row(1) << 0, 13, 4;   // Chest: |(0,3,4)| = 5
  j.row(2) << 0, 13, 6;   // Neck: 2
  j.row(3) << 0, 14, 6;   // Head: 1
  j.row(10) << 1, 10, 0;  // LHip
  j.row(11) << 1, 5, 0;   // LKnee: 5
  j.row(12) << 1, 1, 0;   // LFoot: 4  -> left leg 9
  j.row(13) << -1, 10, 0; // RHip
  j.row(14) << -1, 4, 0;  // RKnee: 6
  j.row(15) << -1, 0, 0;  // RFoot: 4  -> right leg 10
  // 1 + 2 + 5 + (9 + 10) / 2 = 17.5; arm joints (zero) must not matter.
  EXPECT_DOUBLE_EQ(kata::body_height(j), 17.5);
  j.row(5) << 100, 100, 100;
  EXPECT_DOUBLE_EQ(kata::body_height(j), 17.5);
}

TEST(BodyHeight, RestHeightOfCmu0201FromOffsetLines) {
  const std::string path = std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh";
  // Independent reading of the OFFSET lines: the OFFSET right after "JOINT name" / "ROOT name".
  std::map<std::string, Eigen::Vector3d> off;
  {
    std::ifstream in(path);
    ASSERT_TRUE(in) << path;
    std::string line, pending;
    while (std::getline(in, line)) {
      std::istringstream ls(line);
      std::string word;
      ls >> word;
      if (word == "ROOT" || word == "JOINT") ls >> pending;
      if (word == "End") pending.clear();
      if (word == "OFFSET" && !pending.empty()) {
        Eigen::Vector3d v;
        ls >> v.x() >> v.y() >> v.z();
        off[pending] = v;
        pending.clear();
      }
      if (word == "MOTION") break;
    }
  }
  ASSERT_EQ(off.size(), 31u);
  // GPD segments along the CMU chains (README hierarchy): a rest-pose distance is the norm of
  // the summed offsets between the two joints.
  const double head_neck = off["Head"].norm();
  const double neck_chest = (off["Neck"] + off["Neck1"]).norm();
  const double chest_hip = (off["LowerBack"] + off["Spine"] + off["Spine1"]).norm();
  const double left = off["LeftLeg"].norm() + off["LeftFoot"].norm();
  const double right = off["RightLeg"].norm() + off["RightFoot"].norm();
  const double expected = head_neck + neck_chest + chest_hip + 0.5 * (left + right);

  const kata::BvhClip clip = kata::load_bvh(path);
  const kata::GpdMap map = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
  const double h = kata::rest_body_height(clip.skeleton, map);
  EXPECT_NEAR(h, expected, 1e-12);
  // Plausibility: CMU units are 5.644 cm; H of an adult is roughly 1.0-1.8 m (1.25 m here).
  EXPECT_GT(h * 0.056444, 1.0);
  EXPECT_LT(h * 0.056444, 1.8);

  kata::Skeleton bare = clip.skeleton;
  bare.has_rest_pose = false;
  expect_error([&] { kata::rest_body_height(bare, map); }, ErrorKind::kInvalidArgument, {"rest pose"});
}

TEST(NameMap, JsonFile) {
  TempDir dir;
  std::string json = "{\n";
  for (int i = 0; i < kGpdJoints; ++i) {
    json += std::string("  \"") + kata::kGpdJointNames[static_cast<size_t>(i)] + "\": \"src_" + std::to_string(i) + "\"" +
            (i + 1 < kGpdJoints ? ",\n" : "\n");
  }
  json += "}\n";
  const auto names = kata::load_name_map(dir.write("map.json", json));
  for (int i = 0; i < kGpdJoints; ++i) EXPECT_EQ(names[static_cast<size_t>(i)], "src_" + std::to_string(i));

  // Escapes decode (\u00e9 is e-acute, two UTF-8 bytes).
  std::string esc = json;
  esc.replace(esc.find("src_0"), 5, "p\\u00e9lvis\\\"");
  EXPECT_EQ(kata::load_name_map(dir.write("esc.json", esc))[0], "p\xC3\xA9lvis\"");
}

TEST(NameMap, TextFileWithComments) {
  TempDir dir;
  std::string text = "# my rig\n\n";
  for (int i = kGpdJoints - 1; i >= 0; --i) {  // any order
    text += std::string(kata::kGpdJointNames[static_cast<size_t>(i)]) + "\t=  bone " + std::to_string(i) + "  # c\r\n";
  }
  const auto names = kata::load_name_map(dir.write("map.txt", text));
  for (int i = 0; i < kGpdJoints; ++i) EXPECT_EQ(names[static_cast<size_t>(i)], "bone " + std::to_string(i));
  // A UTF-8 byte-order mark (Windows editors) does not become part of the first GPD name.
  std::string bom = "\xEF\xBB\xBF";
  for (int i = 0; i < kGpdJoints; ++i) bom += std::string(kata::kGpdJointNames[static_cast<size_t>(i)]) + "=b" + std::to_string(i) + "\n";
  EXPECT_EQ(kata::load_name_map(dir.write("bom.txt", bom))[0], "b0");
}

TEST(NameMap, ErrorsNameFileAndLine) {
  TempDir dir;
  // Text: all but RFoot (line numbers: line 1 comment, joints on lines 2..16).
  std::string text = "# header\n";
  for (int i = 0; i < kGpdJoints - 1; ++i) text += std::string(kata::kGpdJointNames[static_cast<size_t>(i)]) + " = j" + std::to_string(i) + "\n";
  std::string p = dir.write("missing.txt", text);
  expect_error([&] { kata::load_name_map(p); }, ErrorKind::kParse, {p + ":16:", "RFoot"});

  p = dir.write("nosign.txt", "Hip = a\nChest b\n");
  expect_error([&] { kata::load_name_map(p); }, ErrorKind::kParse, {p + ":2:", "Chest b"});
  p = dir.write("unknown.txt", "Hip = a\n\nPelvis = b\n");
  expect_error([&] { kata::load_name_map(p); }, ErrorKind::kParse, {p + ":3:", "unknown GPD joint 'Pelvis'"});
  p = dir.write("dup.txt", "Hip = a\nHip = b\n");
  expect_error([&] { kata::load_name_map(p); }, ErrorKind::kParse, {p + ":2:", "twice", "line 1"});
  p = dir.write("empty.txt", "Hip = a\nChest =   # nothing\n");
  expect_error([&] { kata::load_name_map(p); }, ErrorKind::kParse, {p + ":2:", "empty"});

  // JSON: the missing joint is reported at the closing brace's line.
  p = dir.write("missing.json", "{\n \"Hip\": \"a\",\n \"Chest\": \"b\"\n}\n");
  expect_error([&] { kata::load_name_map(p); }, ErrorKind::kParse, {p + ":4:", "Neck", "RFoot"});
  p = dir.write("syntax.json", "{\n \"Hip\": \"a\"\n \"Chest\": \"b\"\n}\n");
  expect_error([&] { kata::load_name_map(p); }, ErrorKind::kParse, {p + ":3:", "syntax error"});
  p = dir.write("number.json", "{\n \"Hip\": 3\n}\n");
  expect_error([&] { kata::load_name_map(p); }, ErrorKind::kParse, {p + ":2:", "must be a string"});
  p = dir.write("unterminated.json", "{\n \"Hip\": \"a\n");
  expect_error([&] { kata::load_name_map(p); }, ErrorKind::kParse, {p + ":2:"});
  p = dir.write("unknownkey.json", "{\"Hip\": \"a\",\n\n\"Spine\": \"b\"}");
  expect_error([&] { kata::load_name_map(p); }, ErrorKind::kParse, {p + ":3:", "'Spine'"});

  expect_error([&] { kata::load_name_map((fs::temp_directory_path() / "kata_no_such_map.json").string()); },
               ErrorKind::kIo, {"kata_no_such_map.json"});
}

// A CMU teacher read with the trunk of a MediaPipe student (trunk_as_student): Hip, Chest and Neck
// are made from the teacher's own hip, shoulder and head joints by the rule skeleton.hpp documents
// for the "mediapipe" layout (written out here from the documented constants, not read from the
// map); every other joint stays the teacher's. A student that synthesises nothing, or a teacher
// that already synthesises its trunk, leaves the teacher's map as it was, field for field.
TEST(TrunkAsStudent, ACmuTeacherGetsTheMediaPipeTrunkFromItsOwnJoints) {
  const kata::BvhClip clip = kata::load_bvh(std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh");
  const kata::GpdMap cmu = kata::make_gpd_map(clip.skeleton, kata::preset_joint_names("cmu"));
  const kata::GpdMap mp = kata::resolve_layout(kata::layout_skeleton("mediapipe"), "mediapipe").map;
  const kata::GpdMap t = kata::trunk_as_student(cmu, mp);
  for (int g = 0; g < kGpdJoints; ++g)
    EXPECT_EQ(t.synthesised(g), g <= 2) << kata::kGpdJointNames[static_cast<size_t>(g)];
  for (int g = 3; g < kGpdJoints; ++g) EXPECT_EQ(t.source[static_cast<size_t>(g)], cmu.source[static_cast<size_t>(g)]);
  EXPECT_EQ(t.floor_count, 0);

  Eigen::MatrixX3d world(clip.skeleton.joint_count(), 3);
  const int frames[] = {1, clip.frame_count() / 2, clip.frame_count() - 1};
  for (const int f : frames) {
    kata::world_positions(clip, f, world);
    std::vector<float> xyz;
    for (int j = 0; j < clip.skeleton.joint_count(); ++j)
      for (int k = 0; k < 3; ++k) xyz.push_back(static_cast<float>(world(j, k)));
    float got[3 * kGpdJoints];
    kata::map_to_gpd(t, kata::UpAxis::kY, xyz.data(), got);
    auto at = [&](const char* name) -> Eigen::Vector3d { return world.row(clip.skeleton.find(name)).transpose(); };
    const Eigen::Vector3d lh = at("LeftUpLeg"), rh = at("RightUpLeg"), ls = at("LeftArm"), rs = at("RightArm");
    const Eigen::Vector3d head = at("Head");
    const Eigen::Vector3d h = 0.5 * (lh + rh), s = 0.5 * (ls + rs);
    const Eigen::Vector3d lateral = lh - rh;
    const Eigen::Vector3d forward = lateral.cross(s - h) / lateral.norm();
    const Eigen::Vector3d hip = h + 0.264 * (s - h) - 0.07 * forward;
    const Eigen::Vector3d chest = h + 0.868 * (s - h);
    const Eigen::Vector3d neck = 0.5 * (chest + head);
    const Eigen::Vector3d want[3] = {hip, chest, neck};
    for (int g = 0; g < 3; ++g)
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(got[3 * g + k], want[g][k], 1e-4 * clip.skeleton.offsets[0].norm() + 1e-4)
            << "frame " << f << " " << kata::kGpdJointNames[static_cast<size_t>(g)] << " axis " << k;
    // The other joints are the teacher's own.
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(got[9 + k], static_cast<float>(head[k]));
  }
  // The teacher keeps the rest height of its own joints; without rest_joint the blends' rest
  // positions give another, finite, within a tenth of it.
  const double h_joints = kata::rest_body_height(clip.skeleton, cmu);
  EXPECT_EQ(kata::rest_body_height(clip.skeleton, t), h_joints);
  kata::GpdMap blends = t;
  for (int g = 0; g < 3; ++g) blends.blend[static_cast<size_t>(g)].rest_joint = -1;
  const double h_trunk = kata::rest_body_height(clip.skeleton, blends);
  EXPECT_TRUE(std::isfinite(h_trunk));
  EXPECT_NE(h_trunk, h_joints);
  EXPECT_NEAR(h_trunk, h_joints, 0.1 * h_joints);

  // Unchanged: a student that synthesises nothing, or a teacher of the student's own layout.
  auto same = [](const kata::GpdMap& a, const kata::GpdMap& b) {
    if (a.source != b.source || a.floor_count != b.floor_count || a.floor_joints != b.floor_joints) return false;
    for (int g = 0; g < kGpdJoints; ++g) {
      const kata::GpdBlend &x = a.blend[static_cast<size_t>(g)], &y = b.blend[static_cast<size_t>(g)];
      if (x.count != y.count || x.joint != y.joint || x.weight != y.weight || x.offset != y.offset ||
          x.offset_joint != y.offset_joint || x.rest_joint != y.rest_joint)
        return false;
    }
    return true;
  };
  EXPECT_TRUE(same(kata::trunk_as_student(cmu, cmu), cmu));
  EXPECT_TRUE(same(kata::trunk_as_student(mp, mp), mp));
  EXPECT_TRUE(same(kata::trunk_as_student(mp, cmu), mp));
}
