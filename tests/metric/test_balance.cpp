// The coach's test of the score: turn one joint of a real clip by a fixed angle on
// every frame (its BVH rotation channel plus N degrees, as ../shared/tools/bend-joint does) and
// score the copy against the original with the shipped model, the online alignment and the
// Scorer a lesson uses. The same error at any major joint, either way, left or right, must move
// the total about the same: 45 degrees -> total <= 50 (the neck <= 70), 15 degrees -> >= 60, the
// nine limb and spine joints' 15-degree totals within 25 points of each other per clip, left and
// right within 15 points at 30 degrees; and the turned joint's part is the part to fix on >= 70 %
// of the scored frames at 30 degrees. Asserted with each student frame matched to its own teacher
// frame (the score is under test), and with the online alignment a lesson uses (its re-match,
// AlignmentOptions::rematch_time, puts a frame that the whole-pose alignment pulled a few frames
// off, to where the teacher's knee is nearer the bent one, back where the rest of the body agrees):
// there 45 degrees -> <= 50 on the walk and the run, <= 60 on the dance (whose alignment settles
// farther off than the re-match reaches: docs/model/scores.md "The re-match"), and the turned
// joint's part named on >= 70 % at +-30 on all three. Three shipped clips of different motions
// (walk 02_01, dance 05_18, run 09_01), 3 s of each. Prints the table (joint x angle x clip) of
// docs/model/scores.md.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "fixtures.hpp"
#include "io/model_file.hpp"
#include "metric/scorer.hpp"

namespace kata {
namespace {

struct Turn {
  const char* joint;  // CMU BVH joint whose channel is turned
  Channel axis;       // its rotation channel
  int part;           // the part it belongs to (parts.hpp)
};
// The balance table's ten joints and channels (../shared/tools/balance-table).
const Turn kTurns[] = {
    {"LeftForeArm", Channel::kYrot, 1}, {"RightForeArm", Channel::kYrot, 2}, {"LeftArm", Channel::kZrot, 1},
    {"RightArm", Channel::kZrot, 2},    {"LeftLeg", Channel::kXrot, 3},      {"RightLeg", Channel::kXrot, 4},
    {"LeftUpLeg", Channel::kXrot, 3},   {"RightUpLeg", Channel::kXrot, 4},   {"Spine1", Channel::kXrot, 0},
    {"Neck1", Channel::kXrot, 0}};
constexpr int kNeck = 9;
constexpr int kAngles[] = {15, 30, 45, -15, -30, -45};
constexpr int kMaxFrames = 361;  // frame 0 (the converter's T-pose) and up to 3 s at 120 fps

struct Result {
  double total = 0.0;  // mean total over the scored records (calibrating included, as balance-table)
  double named = 0.0;  // share of kScoring records whose part to fix is the turned joint's part
};

BvhClip excerpt(const std::string& name) {
  BvhClip clip = load_bvh(test::cmu(name));
  const int frames = std::min(clip.frame_count(), kMaxFrames);
  clip.motion.resize(static_cast<size_t>(frames) * clip.channel_count);
  return clip;
}

// The clip with `turn` turned by `degrees` on every frame after frame 0.
BvhClip turned(const BvhClip& clip, const Turn& turn, double degrees) {
  BvhClip out = clip;
  const int j = clip.skeleton.find(turn.joint);
  EXPECT_GE(j, 0) << turn.joint;
  const auto& ch = clip.channels[static_cast<size_t>(j)];
  const int c = static_cast<int>(std::find(ch.begin(), ch.end(), turn.axis) - ch.begin());
  EXPECT_LT(c, static_cast<int>(ch.size())) << turn.joint;
  for (int f = 1; f < out.frame_count(); ++f)
    out.motion[static_cast<size_t>(f) * out.channel_count + static_cast<size_t>(clip.channel_offset[static_cast<size_t>(j)] + c)] += degrees;
  return out;
}

// Scores every frame of `student` against `ref` and hands each record to `on_record(frame, record)`:
// each student frame matched to its own teacher frame (`matched`: the truth is known, and the
// score is under test) or by the online alignment.
template <class OnRecord>
void score_frames(const std::shared_ptr<const metric::Reference>& ref, const BvhClip& student, const GpdMap& map,
                  bool matched, OnRecord on_record) {
  const std::vector<float> x = clip_features(student, map, gpd::Stencil::kBackward, 1);
  const int frames = static_cast<int>(x.size() / gpd::kDims);
  metric::Scorer scorer(ref);
  for (int f = 0; f < frames; ++f) {
    const float* xf = x.data() + static_cast<size_t>(f) * gpd::kDims;
    const double t = f * student.frame_time;
    on_record(f, matched ? scorer.score_matched(xf, t, f) : scorer.score(xf, t));
  }
}

// Mean total and share naming `part` (score_frames).
Result score_turn(const std::shared_ptr<const metric::Reference>& ref, const BvhClip& student, const GpdMap& map,
                  int part, bool matched) {
  double sum = 0.0;
  int n = 0, live = 0, named = 0;
  score_frames(ref, student, map, matched, [&](int, const metric::ScoreRecord& r) {
    if (r.state == metric::ScoreState::kTrackingLost) return;
    sum += r.score;
    ++n;
    if (r.state != metric::ScoreState::kScoring) return;
    ++live;
    named += r.part_to_fix == part;
  });
  return {n ? sum / n : 0.0, live ? static_cast<double>(named) / live : 0.0};
}

TEST(Balance, EveryJointCountsAlikeLeftAndRight) {
  const auto metric = std::make_shared<const metric::Metric>(
      metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
  std::printf("clip   joint         %s\n",
              "  15    30    45   -15   -30   -45   (mean total; share naming the part at +-30), each frame matched to "
              "its own | the same by the online alignment");
  for (const char* name : {"02_01.bvh", "05_18.bvh", "09_01.bvh"}) {
    const BvhClip clip = excerpt(name);
    const GpdMap map = make_gpd_map(clip.skeleton, preset_joint_names("cmu"));
    const std::vector<float> t = clip_features(clip, map, gpd::Stencil::kBackward, 1);
    const auto ref = std::make_shared<const metric::Reference>(metric, t.data(), static_cast<int>(t.size() / gpd::kDims),
                                                               clip.frame_time);
    std::map<std::pair<int, int>, Result> got, online;  // (turn, angle): matched, online alignment
    auto key = [](int k, int a) { return std::make_pair(k, a); };
    for (int k = 0; k < 10; ++k) {
      std::printf("%.5s  %-12s", name, kTurns[k].joint);
      for (int a : kAngles) {
        const BvhClip student = turned(clip, kTurns[k], a);
        got[key(k, a)] = score_turn(ref, student, map, kTurns[k].part, true);
        online[key(k, a)] = score_turn(ref, student, map, kTurns[k].part, false);
        std::printf(" %3.0f", got[key(k, a)].total);
      }
      std::printf("  %.2f %.2f |", got[key(k, 30)].named, got[key(k, -30)].named);
      for (int a : kAngles) std::printf(" %3.0f", online[key(k, a)].total);
      std::printf("  %.2f %.2f\n", online[key(k, 30)].named, online[key(k, -30)].named);
    }
    for (int k = 0; k < 10; ++k) {
      for (int a : {45, -45}) EXPECT_LE(got[key(k, a)].total, k == kNeck ? 70.0 : 50.0) << name << " " << kTurns[k].joint << " " << a;
      for (int a : {15, -15}) EXPECT_GE(got[key(k, a)].total, 60.0) << name << " " << kTurns[k].joint << " " << a;
      for (int a : {30, -30}) EXPECT_GE(got[key(k, a)].named, 0.70) << name << " " << kTurns[k].joint << " " << a;
      // The online alignment (before the re-match: 45 degrees scored 50-64 for the knees of the walk
      // and the run, and the left knee of the run was named on 6 % of frames at +30).
      const bool dance = std::string(name) == "05_18.bvh";
      for (int a : {45, -45})
        EXPECT_LE(online[key(k, a)].total, k == kNeck ? 70.0 : dance ? 60.0 : 50.0)
            << "online " << name << " " << kTurns[k].joint << " " << a;
      for (int a : {30, -30})
        EXPECT_GE(online[key(k, a)].named, 0.70) << "online " << name << " " << kTurns[k].joint << " " << a;
    }
    for (int a : {15, -15}) {
      double lo = 100.0, hi = 0.0;
      for (int k = 0; k < kNeck; ++k) lo = std::min(lo, got[key(k, a)].total), hi = std::max(hi, got[key(k, a)].total);
      EXPECT_LE(hi - lo, 25.0) << name << " at " << a << " degrees";
    }
    for (int k = 0; k < 8; k += 2)
      for (int a : {30, -30})
        EXPECT_LE(std::fabs(got[key(k, a)].total - got[{k + 1, a}].total), 15.0)
            << name << " " << kTurns[k].joint << " vs " << kTurns[k + 1].joint << " at " << a;
  }
}

// The correction cue on the same turned copies: the GPD joint whose BVH channel
// is turned (the cue names the joint to move, cue.hpp), per kTurns entry.
constexpr int kCueJoint[] = {5, 8, 4, 7, 11, 14, 10, 13, 1, 2};  // LElbow RElbow LShoulder ... Chest Neck

struct CueResult {
  double named = 0.0;   // share of kScoring records whose cue_joint is the turned joint
  double median = 0.0;  // median cue_degrees over those records (0: none)
};

CueResult cue_turn(const std::shared_ptr<const metric::Reference>& ref, const BvhClip& student, const GpdMap& map,
                   int joint, bool matched) {
  int live = 0;
  std::vector<double> degrees;
  score_frames(ref, student, map, matched, [&](int f, const metric::ScoreRecord& r) {
    if (r.state != metric::ScoreState::kScoring) return;
    ++live;
    EXPECT_TRUE(std::isfinite(r.cue_degrees));
    EXPECT_EQ(r.cue_joint >= 0, r.part_to_fix >= 0) << "frame " << f;
    if (r.cue_joint == joint) degrees.push_back(r.cue_degrees);
  });
  CueResult out;
  out.named = live ? static_cast<double>(degrees.size()) / live : 0.0;
  if (!degrees.empty()) {
    std::nth_element(degrees.begin(), degrees.begin() + static_cast<long>(degrees.size() / 2), degrees.end());
    out.median = degrees[degrees.size() / 2];
  }
  return out;
}

// Every one of the ten joints turned by +-30 degrees: its cue names it on >= 70 % of the scored
// frames, with a median angle of 30 +- 8 degrees (each student frame matched to its own teacher
// frame, as above; with the online alignment the share on every clip, the angle on the walk and
// the run).
TEST(Balance, TheCueNamesTheTurnedJoint) {
  const auto metric = std::make_shared<const metric::Metric>(
      metric::load_model(std::string(KATA_SOURCE_DIR) + "/models/default.kata"));
  std::printf("clip   joint        cue joint  +30: share median  -30: share median | online +30, -30\n");
  for (const char* name : {"02_01.bvh", "05_18.bvh", "09_01.bvh"}) {
    const BvhClip clip = excerpt(name);
    const GpdMap map = make_gpd_map(clip.skeleton, preset_joint_names("cmu"));
    const std::vector<float> t = clip_features(clip, map, gpd::Stencil::kBackward, 1);
    const auto ref = std::make_shared<const metric::Reference>(metric, t.data(), static_cast<int>(t.size() / gpd::kDims),
                                                               clip.frame_time);
    for (int k = 0; k < 10; ++k) {
      const int joint = kCueJoint[k];
      CueResult got[2], online[2];
      for (int i = 0; i < 2; ++i) {
        const BvhClip student = turned(clip, kTurns[k], i == 0 ? 30.0 : -30.0);
        got[i] = cue_turn(ref, student, map, joint, true);
        online[i] = cue_turn(ref, student, map, joint, false);
      }
      std::printf("%.5s  %-12s %-9s  %.2f %5.1f        %.2f %5.1f      | %.2f %5.1f, %.2f %5.1f\n", name,
                  kTurns[k].joint, kGpdJointNames[static_cast<size_t>(joint)], got[0].named, got[0].median,
                  got[1].named, got[1].median, online[0].named, online[0].median, online[1].named, online[1].median);
      for (int i = 0; i < 2; ++i) {
        EXPECT_GE(got[i].named, 0.70) << name << " " << kTurns[k].joint << (i ? " -30" : " +30");
        EXPECT_NEAR(got[i].median, 30.0, 8.0) << name << " " << kTurns[k].joint << (i ? " -30" : " +30");
        // The online alignment with its re-match: named alike; the angle too on the walk and the run
        // (the dance's left knee at -30 reads 21 deg where its alignment settles off).
        EXPECT_GE(online[i].named, 0.70) << "online " << name << " " << kTurns[k].joint << (i ? " -30" : " +30");
        if (std::string(name) != "05_18.bvh") {
          EXPECT_NEAR(online[i].median, 30.0, 8.0) << "online " << name << " " << kTurns[k].joint << (i ? " -30" : " +30");
        }
      }
    }
  }
}

}  // namespace
}  // namespace kata
