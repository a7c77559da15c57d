// Any body, any source, through the public C ABI only: MediaPipe world landmarks made
// from a CMU clip by a converter written here, per-joint confidence with dropped joints, One-Euro
// smoothing, bone lengths from live frames, and a CMU teacher retargeted onto a MediaPipe student.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "kata/kata.h"

namespace {

constexpr double kMetresPerUnit = 0.056444;  // CMU BVH units (1/0.45 inch) to metres
constexpr int kLandmarks = 33;
constexpr int kGpdParent[16] = {-1, 0, 1, 2, 2, 4, 5, 2, 7, 8, 0, 10, 11, 0, 13, 14};

struct V3 {
  double x = 0, y = 0, z = 0;
};
V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 operator*(double s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }
double norm(V3 a) { return std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z); }
V3 lerp(V3 a, V3 b, double t) { return a + t * (b - a); }

// A CMU clip's world positions (Y-up, metres), frames 1.. (frame 0 is the converter's T-pose).
struct CmuClip {
  kata_context ctx = nullptr;
  kata_clip clip = nullptr;
  kata_skeleton skel = nullptr;
  std::map<std::string, int> index;
  std::vector<std::vector<V3>> frames;
  std::vector<std::vector<float>> raw;  // file units, every joint, for the teacher side
  double frame_time = 0;
  explicit CmuClip(const char* name) {
    EXPECT_EQ(kata_context_create(&ctx), KATA_OK);
    const std::string path = name[0] == '/' ? std::string(name) : std::string(KATA_DATA_DIR) + "/cmu/" + name;
    EXPECT_EQ(kata_clip_load_bvh(ctx, path.c_str(), &clip), KATA_OK) << kata_context_last_error(ctx);
    EXPECT_EQ(kata_clip_skeleton(clip, &skel), KATA_OK);
    const uint32_t n = kata_skeleton_joint_count(skel);
    for (uint32_t j = 0; j < n; ++j) index[kata_skeleton_joint_name(skel, j)] = static_cast<int>(j);
    frame_time = kata_clip_frame_time(clip);
    std::vector<float> p(3 * n);
    for (uint32_t f = 1; f < kata_clip_frame_count(clip); ++f) {
      EXPECT_EQ(kata_clip_positions(clip, f, p.data(), p.size()), KATA_OK);
      raw.push_back(p);
      std::vector<V3> w(n);
      for (uint32_t j = 0; j < n; ++j)
        w[j] = {kMetresPerUnit * p[3 * j], kMetresPerUnit * p[3 * j + 1], kMetresPerUnit * p[3 * j + 2]};
      frames.push_back(w);
    }
    ankle_height = 1e9;
    for (size_t f = 0; f < frames.size(); ++f)
      ankle_height = std::min({ankle_height, at(f, "LeftFoot").y, at(f, "RightFoot").y});
  }
  double ankle_height = 0;
  ~CmuClip() {
    kata_skeleton_destroy(skel);
    kata_clip_destroy(clip);
    kata_context_destroy(ctx);
  }
  V3 at(size_t f, const char* joint) const { return frames[f][static_cast<size_t>(index.at(joint))]; }
};

// The converter: MediaPipe landmarks placed on the CMU joints, face and hand points offset by
// fixed vectors, ears symmetric about the Head joint; origin at the hip midpoint; then turned
// into MediaPipe's camera axes (y down, z away): (x, y, z) -> (x, -y, -z).
std::vector<float> to_mediapipe(const CmuClip& c, size_t f) {
  std::array<V3, kLandmarks> l;
  const V3 head = c.at(f, "Head");
  const V3 face[11] = {{0, 0.02, 0.10},  {0.02, 0.05, 0.09}, {0.03, 0.05, 0.09}, {0.04, 0.05, 0.08},
                       {-0.02, 0.05, 0.09}, {-0.03, 0.05, 0.09}, {-0.04, 0.05, 0.08}, {0.07, 0, 0},
                       {-0.07, 0, 0},   {0.02, -0.02, 0.09}, {-0.02, -0.02, 0.09}};
  for (int i = 0; i < 11; ++i) l[static_cast<size_t>(i)] = head + face[i];
  l[11] = c.at(f, "LeftArm");
  l[12] = c.at(f, "RightArm");
  l[13] = c.at(f, "LeftForeArm");
  l[14] = c.at(f, "RightForeArm");
  l[15] = c.at(f, "LeftHand");
  l[16] = c.at(f, "RightHand");
  l[17] = l[15] + V3{0.06, -0.02, -0.02};
  l[18] = l[16] + V3{-0.06, -0.02, -0.02};
  l[19] = l[15] + V3{0.08, 0, 0};
  l[20] = l[16] + V3{-0.08, 0, 0};
  l[21] = l[15] + V3{0.03, 0, 0.03};
  l[22] = l[16] + V3{-0.03, 0, 0.03};
  l[23] = c.at(f, "LeftUpLeg");
  l[24] = c.at(f, "RightUpLeg");
  l[25] = c.at(f, "LeftLeg");
  l[26] = c.at(f, "RightLeg");
  l[27] = c.at(f, "LeftFoot");
  l[28] = c.at(f, "RightFoot");
  // Heels under the ankles at the clip's lowest ankle height (so a planted heel is on the floor).
  l[29] = l[27] + V3{0, -c.ankle_height, -0.05};
  l[30] = l[28] + V3{0, -c.ankle_height, -0.05};
  l[31] = c.at(f, "LeftToeBase");
  l[32] = c.at(f, "RightToeBase");
  const V3 origin = 0.5 * (l[23] + l[24]);
  std::vector<float> out(3 * kLandmarks);
  for (int i = 0; i < kLandmarks; ++i) {
    const V3 p = l[static_cast<size_t>(i)] - origin;
    out[3 * i] = static_cast<float>(p.x);
    out[3 * i + 1] = static_cast<float>(-p.y);
    out[3 * i + 2] = static_cast<float>(-p.z);
  }
  return out;
}

// kata.h's documented synthesis, computed here from the CMU joints (Y-up): the 16 GPD joints.
std::array<V3, 16> documented_gpd(const CmuClip& c, size_t f) {
  const V3 h = 0.5 * (c.at(f, "LeftUpLeg") + c.at(f, "RightUpLeg"));
  const V3 s = 0.5 * (c.at(f, "LeftArm") + c.at(f, "RightArm"));
  const V3 e = c.at(f, "Head");  // the ears' midpoint, by construction
  const V3 l = c.at(f, "LeftUpLeg") - c.at(f, "RightUpLeg"), u = s - h;
  const V3 back = (-0.07 / norm(l)) * V3{l.y * u.z - l.z * u.y, l.z * u.x - l.x * u.z, l.x * u.y - l.y * u.x};
  return {lerp(h, s, 0.264) + back, lerp(h, s, 0.868), lerp(lerp(h, s, 0.868), e, 0.5), e,
          c.at(f, "LeftArm"), c.at(f, "LeftForeArm"), c.at(f, "LeftHand"),
          c.at(f, "RightArm"), c.at(f, "RightForeArm"), c.at(f, "RightHand"),
          c.at(f, "LeftUpLeg"), c.at(f, "LeftLeg"), c.at(f, "LeftFoot"),
          c.at(f, "RightUpLeg"), c.at(f, "RightLeg"), c.at(f, "RightFoot")};
}

// The landmarks each GPD joint reads (kata.h): for the independent count of missing joints.
const std::vector<std::vector<int>> kGpdLandmarks = {
    {23, 24, 11, 12}, {23, 24, 11, 12}, {23, 24, 11, 12, 7, 8}, {7, 8}, {11}, {13}, {15}, {12}, {14}, {16},
    {23}, {25}, {27}, {24}, {26}, {28}};

struct Handles {
  kata_context ctx = nullptr;
  kata_skeleton mp = nullptr;
  kata_model model = nullptr;
  Handles() {
    EXPECT_EQ(kata_context_create(&ctx), KATA_OK);
    EXPECT_EQ(kata_skeleton_create_layout(ctx, "mediapipe", &mp), KATA_OK) << kata_context_last_error(ctx);
    EXPECT_EQ(kata_model_load(ctx, KATA_SOURCE_DIR "/models/default.kata", &model), KATA_OK)
        << kata_context_last_error(ctx);
  }
  ~Handles() {
    kata_model_destroy(model);
    kata_skeleton_destroy(mp);
    kata_context_destroy(ctx);
  }
  // smoothing: -1 the layout's default (on, 2 Hz / 1.0 / 1 Hz), 0 off, 1 on with the defaults.
  kata_stream open_mediapipe(int smoothing) const {
    kata_stream_desc d;
    kata_stream_desc_init(&d);
    d.layout = "mediapipe";
    d.stencil = kata_model_stencil(model);
    kata_stream s = nullptr;
    EXPECT_EQ(kata_stream_open(ctx, mp, &d, &s), KATA_OK) << kata_context_last_error(ctx);
    if (smoothing >= 0) {
      EXPECT_EQ(kata_stream_set_smoothing(s, smoothing, 2.0, 1.0, 1.0), KATA_OK);
    }
    return s;
  }
};

bool finite(const std::vector<float>& v) {
  return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
}

struct RunResult {
  std::vector<std::vector<float>> features;  // per pushed frame (empty when none)
  std::vector<float> scores;                 // per scored frame
  std::vector<float> distances;              // per scored frame
  std::vector<int> part_to_fix;              // per scored frame (-1: none)
  std::vector<kata_status> status;
};

// Pushes frames (with confidences when given) and scores every new vector against the teacher.
RunResult run(kata_stream s, kata_model model, kata_clip teacher, const std::vector<std::vector<float>>& frames,
              const std::vector<std::vector<float>>* confidence, double dt) {
  RunResult r;
  if (teacher) {
    kata_teacher_desc t;
    kata_teacher_desc_init(&t);
    t.model = model;
    t.clip = teacher;
    t.layout = "cmu";
    t.first_frame = 1;
    t.ghost = 0;
    EXPECT_EQ(kata_stream_attach_teacher(s, &t), KATA_OK) << kata_stream_last_error(s);
  }
  std::vector<float> f(KATA_GPD_DIMS);
  int64_t seen = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    const kata_status st = confidence ? kata_stream_push_confidence(s, i * dt, frames[i].data(), (*confidence)[i].data(), kLandmarks)
                                      : kata_stream_push(s, i * dt, frames[i].data(), kLandmarks);
    r.status.push_back(st);
    r.features.emplace_back();
    if (kata_stream_feature_count(s) == seen) continue;
    seen = kata_stream_feature_count(s);
    EXPECT_EQ(kata_stream_features(s, f.data(), f.size(), nullptr, nullptr), KATA_OK);
    r.features.back() = f;
    if (teacher) {
      kata_result_record rec;
      rec.struct_size = sizeof rec;
      EXPECT_EQ(kata_stream_read_newest(s, &rec, nullptr, 0, nullptr, 0), KATA_OK) << kata_stream_last_error(s);
      EXPECT_TRUE(rec.scored);
      r.scores.push_back(rec.score);
      r.distances.push_back(rec.distance);
      r.part_to_fix.push_back(rec.part_to_fix);
    }
  }
  return r;
}

double mean(const std::vector<float>& v) {
  double s = 0;
  for (float x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

// Frame-to-frame jitter of the joint-coordinate block (second differences, RMS).
double jitter(const std::vector<std::vector<float>>& feats, int dims) {
  double sum = 0;
  int n = 0;
  for (size_t i = 2; i < feats.size(); ++i) {
    if (feats[i].empty() || feats[i - 1].empty() || feats[i - 2].empty()) continue;
    for (int k = 0; k < dims; ++k) {
      const double d2 = feats[i][k] - 2.0 * feats[i - 1][k] + feats[i - 2][k];
      sum += d2 * d2;
    }
    ++n;
  }
  return std::sqrt(sum / std::max(1, n * dims));
}

TEST(AnyBody, MediaPipeLandmarksMatchTheDocumentedSynthesisAndScoreAgainstTheBvhTeacher) {
  CmuClip clip("02_01.bvh");
  Handles h;
  std::vector<std::vector<float>> mp;
  for (size_t f = 0; f < clip.frames.size(); ++f) mp.push_back(to_mediapipe(clip, f));

  // The reference: the documented joints, computed here from the CMU joints, through "gpd".
  kata_skeleton gpd = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(h.ctx, "gpd", &gpd), KATA_OK);
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  d.layout = "gpd";
  d.stencil = kata_model_stencil(h.model);
  kata_stream ref = nullptr;
  ASSERT_EQ(kata_stream_open(h.ctx, gpd, &d, &ref), KATA_OK) << kata_context_last_error(h.ctx);
  std::vector<std::vector<float>> joints;
  for (size_t f = 0; f < clip.frames.size(); ++f) {
    const auto g = documented_gpd(clip, f);
    // The documented floor: the lowest of the ankles, heels and foot indices.
    double floor = 1e9;
    for (const char* j : {"LeftFoot", "RightFoot", "LeftToeBase", "RightToeBase"}) floor = std::min(floor, clip.at(f, j).y);
    floor = std::min(floor, std::min(clip.at(f, "LeftFoot").y, clip.at(f, "RightFoot").y) - clip.ankle_height);
    std::vector<float> p;
    for (const V3& v : g) p.insert(p.end(), {float(v.x), float(v.y - floor), float(v.z)});
    joints.push_back(p);
  }
  std::vector<std::vector<float>> ref_feats;
  {
    std::vector<float> out(KATA_GPD_DIMS);
    int64_t seen = 0;
    for (size_t i = 0; i < joints.size(); ++i) {
      ASSERT_EQ(kata_stream_push(ref, i * clip.frame_time, joints[i].data(), 16), KATA_OK);
      ref_feats.emplace_back();
      if (kata_stream_feature_count(ref) == seen) continue;
      seen = kata_stream_feature_count(ref);
      kata_stream_features(ref, out.data(), out.size(), nullptr, nullptr);
      ref_feats.back() = out;
    }
  }

  kata_stream s = h.open_mediapipe(/*smoothing=*/0);
  const RunResult r = run(s, h.model, clip.clip, mp, nullptr, clip.frame_time);
  EXPECT_NEAR(kata_stream_body_height(s), kata_stream_body_height(ref), 1e-5 * kata_stream_body_height(ref));
  double worst_all = 0;
  for (size_t i = 0; i < mp.size(); ++i) {
    ASSERT_EQ(r.status[i], KATA_OK);
    ASSERT_EQ(r.features[i].empty(), ref_feats[i].empty());
    for (int k = 0; k < static_cast<int>(r.features[i].size()); ++k) {
      const double e = std::fabs(r.features[i][k] - ref_feats[i][k]);
      worst_all = std::max(worst_all, e);
    }
  }
  // Float32 landmarks (metres, camera axes) against the same joints computed here: equal up to
  // float rounding, amplified in the kinetics (1/120 s steps): measured 6e-3.
  std::printf("[ figures ] mediapipe vs documented synthesis: max |diff| %.3g\n", worst_all);
  EXPECT_LT(worst_all, 2e-2);
  const double m = mean(r.scores), dist = mean(r.distances), delta_star = kata_model_delta_star(h.model);
  std::printf("[ figures ] mediapipe student vs its own BVH teacher: mean score %.2f, mean distance %.5f "
              "(delta* %.4f) over %zu frames\n",
              m, dist, delta_star, r.scores.size());
  // The landmarks sit on the CMU joints, so the whole distance comes from the synthesised Hip,
  // Chest and Neck against CMU's Hips, Spine1 and Neck1 (no landmark lies on the spine). Measured
  // by swapping one synthesised joint into the CMU joints at a time: Hip 0.0020, Neck 0.0022,
  // Chest 0.0009; all three 0.0035 (0.0035..0.0082 over the six shipped clips). Well inside
  // "similar" (d < delta*), so the shipped calibrated map scores it ~100.
  EXPECT_LT(dist, 0.5 * delta_star);
  EXPECT_GE(m, 95.0);
  kata_stream_destroy(s);
  kata_stream_destroy(ref);
  kata_skeleton_destroy(gpd);
}

TEST(AnyBody, NoiseAndDroppedJointsHoldTrackAndSmoothingCutsJitter) {
  CmuClip clip("02_01.bvh");
  Handles h;
  std::mt19937 rng(11);
  std::normal_distribution<float> noise(0.0f, 0.01f);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<std::vector<float>> clean, noisy, dropped, conf;
  std::vector<int> missing;
  std::vector<long> last_good(16, -1);
  for (size_t f = 0; f < clip.frames.size(); ++f) {
    clean.push_back(to_mediapipe(clip, f));
    std::vector<float> n = clean.back();
    for (float& x : n) x += noise(rng);
    noisy.push_back(n);
    std::vector<float> c(kLandmarks, 0.9f);
    std::vector<bool> gone(kLandmarks, false);
    for (int i = 0; i < kLandmarks; ++i) {
      if (u(rng) < 0.10f) {
        gone[static_cast<size_t>(i)] = true;
        n[3 * i] = n[3 * i + 1] = n[3 * i + 2] = std::nanf("");
        c[static_cast<size_t>(i)] = (i % 2) ? std::nanf("") : 0.0f;
      }
    }
    // Independent bookkeeping of the documented rule: a missing joint is held for 0.5 s after its
    // last good frame (never seen: not held); more than 4 missing, or one not held, is lost.
    int m = 0;
    bool expired = false;
    for (size_t g = 0; g < kGpdLandmarks.size(); ++g) {
      const auto& terms = kGpdLandmarks[g];
      if (std::any_of(terms.begin(), terms.end(), [&](int l) { return gone[static_cast<size_t>(l)]; })) {
        ++m;
        if (last_good[g] < 0 || (f - last_good[g]) * clip.frame_time > 0.5) expired = true;
      } else {
        last_good[g] = static_cast<long>(f);
      }
    }
    missing.push_back(expired ? 99 : m);

    dropped.push_back(n);
    conf.push_back(c);
  }
  kata_stream s_clean = h.open_mediapipe(1);
  const RunResult rc = run(s_clean, h.model, clip.clip, clean, nullptr, clip.frame_time);
  kata_stream s_raw = h.open_mediapipe(0);
  const RunResult rn = run(s_raw, h.model, nullptr, noisy, nullptr, clip.frame_time);
  kata_stream s_smooth = h.open_mediapipe(1);
  const RunResult rs = run(s_smooth, h.model, nullptr, noisy, nullptr, clip.frame_time);
  kata_stream s_drop = h.open_mediapipe(1);
  const RunResult rd = run(s_drop, h.model, clip.clip, dropped, &conf, clip.frame_time);

  int lost = 0;
  for (size_t i = 0; i < dropped.size(); ++i) {
    // "Tracking lost" exactly when more than 25% (4) of the 16 joints are missing (or one expired).
    const kata_status want = missing[i] > 4 ? KATA_TRACKING_LOST : KATA_OK;
    ASSERT_EQ(rd.status[i], want) << "frame " << i << ", " << missing[i] << " missing: " << kata_stream_last_error(s_drop);
    lost += want == KATA_TRACKING_LOST;
    ASSERT_TRUE(finite(rd.features[i])) << "frame " << i;
  }
  EXPECT_EQ(kata_stream_lost_frames(s_drop), lost);
  const double jitter_raw = jitter(rn.features, 48 * 3), jitter_smooth = jitter(rs.features, 48 * 3);
  std::printf("[ figures ] 1 cm noise + 10%% dropped: %d of %zu frames tracking lost; mean score %.2f (clean %.2f)\n",
              lost, dropped.size(), mean(rd.scores), mean(rc.scores));
  std::printf("[ figures ] One-Euro jitter factor (raw / smoothed, joint block): %.2f\n", jitter_raw / jitter_smooth);
  EXPECT_GT(jitter_raw / jitter_smooth, 3.0);
  // Scores are reported, not asserted: with 1 cm noise and 10% drops they fall well below the clean
  // run (figures in the closing note).
  for (kata_stream s : {s_clean, s_raw, s_smooth, s_drop}) kata_stream_destroy(s);
}

TEST(AnyBody, BoneLengthsFromSixtyNoisyFramesWithinTwoPercent) {
  CmuClip clip("07_01.bvh");
  Handles h;
  // The truth: per bone, the median over the 60 frames of the documented joints' distances
  // (computed here from the clean CMU joints).
  std::vector<double> truth(16, 0.0);
  {
    std::vector<std::vector<double>> per_frame(16);
    for (size_t f = 0; f < 60; ++f) {
      const auto g = documented_gpd(clip, f);
      for (int j = 1; j < 16; ++j) per_frame[j].push_back(norm(g[j] - g[kGpdParent[j]]));
    }
    for (int j = 1; j < 16; ++j) {
      auto v = per_frame[j];
      std::nth_element(v.begin(), v.begin() + 30, v.end());
      truth[j] = v[30];
    }
  }
  // 20 independent draws of 1 cm noise on every landmark coordinate: the estimate is a statistic
  // of 60 noisy frames (a 19 cm forearm measured between two landmarks with 1 cm noise each
  // scatters by about 1.4 cm / sqrt(60) = 1% of its length), so its error is judged over draws.
  std::vector<double> errors;
  double worst = 0, bias = 0;
  for (int draw = 0; draw < 20; ++draw) {
    std::mt19937 rng(static_cast<unsigned>(100 + draw));
    std::normal_distribution<float> noise(0.0f, 0.01f);
    kata_stream s = h.open_mediapipe(0);
    for (size_t f = 0; f < 60; ++f) {
      std::vector<float> p = to_mediapipe(clip, f);
      for (float& x : p) x += noise(rng);
      ASSERT_EQ(kata_stream_push(s, f * clip.frame_time, p.data(), kLandmarks), KATA_OK);
      if (f + 1 < 60) {
        double l[16];
        EXPECT_EQ(kata_stream_bone_lengths(s, l, nullptr, 16), KATA_NO_DATA);
      }
    }
    double est[16], spread[16];
    ASSERT_EQ(kata_stream_bone_lengths(s, est, spread, 16), KATA_OK);
    for (int j = 1; j < 16; ++j) {
      const double e = (est[j] - truth[j]) / truth[j];
      errors.push_back(std::fabs(e));
      bias += e;
      worst = std::max(worst, std::fabs(e));
      EXPECT_GT(spread[j], 0.0);
      EXPECT_LT(spread[j], 0.05);
    }
    kata_stream_destroy(s);
  }
  bias /= static_cast<double>(errors.size());
  double sum2 = 0;
  for (double e : errors) sum2 += e * e;
  const double rms = std::sqrt(sum2 / static_cast<double>(errors.size()));
  const double within = static_cast<double>(std::count_if(errors.begin(), errors.end(), [](double e) { return e <= 0.02; })) /
                        static_cast<double>(errors.size());
  std::printf("[ figures ] bone lengths from 60 noisy frames (1 cm noise, 20 draws x 15 bones): mean error %+.3f%%, rms "
              "%.3f%%, %.1f%% of estimates within 2%%, worst %.3f%%\n",
              100 * bias, 100 * rms, 100 * within, 100 * worst);
  EXPECT_LT(std::fabs(bias), 0.003);  // no lengthening by the noise left
  EXPECT_LT(rms, 0.01);
  EXPECT_GE(within, 0.97);
  EXPECT_LT(worst, 0.03);
}

TEST(AnyBody, CmuTeacherRetargetedOntoAMediaPipeStudentOfAnotherSubject) {
  CmuClip teacher("02_01.bvh"), student("07_01.bvh");
  Handles h;
  kata_stream s = h.open_mediapipe(-1);
  // Before the bone window is full the retargeter cannot know the student's bones.
  kata_retargeter rt = nullptr;
  std::vector<std::vector<float>> frames;
  for (size_t f = 0; f < student.frames.size(); ++f) frames.push_back(to_mediapipe(student, f));
  ASSERT_EQ(kata_stream_push(s, 0.0, frames[0].data(), kLandmarks), KATA_OK);
  EXPECT_EQ(kata_retargeter_create_across(h.ctx, s, teacher.skel, "cmu", KATA_UP_Y, nullptr, &rt), KATA_E_STATE);
  for (size_t f = 1; f < 60; ++f) ASSERT_EQ(kata_stream_push(s, f * student.frame_time, frames[f].data(), kLandmarks), KATA_OK);
  ASSERT_EQ(kata_retargeter_create_across(h.ctx, s, teacher.skel, "cmu", KATA_UP_Y, nullptr, &rt), KATA_OK) << kata_context_last_error(h.ctx);
  ASSERT_EQ(kata_retargeter_joint_count(rt), 16u);
  // The same stream (no rest pose) as a student of a teacher in its own layout: GPD mode.
  kata_retargeter own = nullptr;
  ASSERT_EQ(kata_retargeter_create_for_stream(h.ctx, s, nullptr, &own), KATA_OK) << kata_context_last_error(h.ctx);
  EXPECT_EQ(kata_retargeter_joint_count(own), 16u);
  {
    std::vector<float> g(48);
    EXPECT_EQ(kata_retargeter_solve(own, frames[100].data(), kLandmarks, g.data(), g.size(), nullptr), KATA_OK);
    EXPECT_TRUE(finite(g));
  }
  kata_retargeter_destroy(own);
  EXPECT_EQ(kata_retargeter_joint_source(rt, 0), -1);   // Hip: synthesised
  EXPECT_EQ(kata_retargeter_joint_source(rt, 4), 11);   // LShoulder: left_shoulder
  double bones[16];
  ASSERT_EQ(kata_stream_bone_lengths(s, bones, nullptr, 16), KATA_OK);

  const uint32_t tj = kata_skeleton_joint_count(teacher.skel);
  std::vector<float> ghost(48);
  double worst_bone = 0, sum_angle = 0, worst_place = 0;
  int n_angle = 0;
  const size_t frames_used = std::min<size_t>(300, std::min(teacher.raw.size(), frames.size()));
  for (size_t f = 0; f < frames_used; ++f) {
    kata_retarget_info info;
    info.struct_size = sizeof info;
    ASSERT_EQ(kata_retargeter_solve(rt, teacher.raw[f].data(), tj, ghost.data(), ghost.size(), &info), KATA_OK)
        << kata_retargeter_last_error(rt);
    ASSERT_TRUE(finite(ghost));
    // Ghost in MediaPipe axes: back to Y-up for the direction check.
    auto g = [&](int j) { return V3{ghost[3 * j], -ghost[3 * j + 1], -ghost[3 * j + 2]}; };
    const auto t = documented_gpd(teacher, f);  // teacher GPD joints (cmu preset) are CMU joints...
    const char* cmu[16] = {"Hips", "Spine1", "Neck1", "Head", "LeftArm", "LeftForeArm", "LeftHand", "RightArm",
                           "RightForeArm", "RightHand", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg",
                           "RightLeg", "RightFoot"};
    (void)t;
    for (int j = 1; j < 16; ++j) {
      const V3 gb = g(j) - g(kGpdParent[j]);
      worst_bone = std::max(worst_bone, std::fabs(norm(gb) - bones[j]) / bones[j]);
      const V3 tb = teacher.at(f, cmu[j]) - teacher.at(f, cmu[kGpdParent[j]]);
      const double c = (gb.x * tb.x + gb.y * tb.y + gb.z * tb.z) / (norm(gb) * norm(tb));
      sum_angle += std::acos(std::max(-1.0, std::min(1.0, c))) * 180.0 / 3.14159265358979;
      ++n_angle;
    }
    // Placed over the student: its Hip on the student's synthesised Hip (MediaPipe axes).
    ASSERT_EQ(kata_retargeter_place(rt, frames[f].data(), kLandmarks, ghost.data(), ghost.size()), KATA_OK);
    const auto sg = documented_gpd(student, f);
    const V3 origin = 0.5 * (student.at(f, "LeftUpLeg") + student.at(f, "RightUpLeg"));
    const V3 hip = sg[0] - origin;
    worst_place = std::max(worst_place, norm(V3{ghost[0] - hip.x, ghost[1] + hip.y, ghost[2] + hip.z}));
  }
  const double mean_angle = sum_angle / n_angle;
  std::printf("[ figures ] cross-layout ghost (CMU 02_01 onto MediaPipe 07_01, %zu frames): worst bone error %.2g%%, "
              "mean bone-direction angle to the teacher %.2f deg, hip placement error %.2g m\n",
              frames_used, 100 * worst_bone, mean_angle, worst_place);
  EXPECT_LT(worst_bone, 0.005);
  EXPECT_LT(mean_angle, 10.0);
  EXPECT_LT(worst_place, 1e-4);
  kata_retargeter_destroy(rt);
  kata_stream_destroy(s);
}

TEST(AnyBody, NameMapFromMemoryAndVendorLayouts) {
  Handles h;
  kata_skeleton gpd = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(h.ctx, "gpd", &gpd), KATA_OK);
  kata_stream_desc d;
  kata_stream_desc_init(&d);
  const char* json = "{\"Hip\":\"Hip\",\"Chest\":\"Chest\",\"Neck\":\"Neck\",\"Head\":\"Head\",\"LShoulder\":\"LShoulder\","
                    "\"LElbow\":\"LElbow\",\"LHand\":\"LHand\",\"RShoulder\":\"RShoulder\",\"RElbow\":\"RElbow\","
                    "\"RHand\":\"RHand\",\"LHip\":\"LHip\",\"LKnee\":\"LKnee\",\"LFoot\":\"LFoot\",\"RHip\":\"RHip\","
                    "\"RKnee\":\"RKnee\",\"RFoot\":\"RFoot\"}";
  kata_stream s = nullptr;
  ASSERT_EQ(kata_stream_open_name_map(h.ctx, gpd, &d, json, &s), KATA_OK) << kata_context_last_error(h.ctx);
  kata_stream_destroy(s);
  EXPECT_EQ(kata_stream_open_name_map(h.ctx, gpd, &d, "Hip = Hip\nChest = Nope\n", &s), KATA_E_PARSE);
  EXPECT_NE(std::string(kata_context_last_error(h.ctx)).find("<name map>:"), std::string::npos)
      << kata_context_last_error(h.ctx);
  EXPECT_STREQ(kata_status_string(KATA_TRACKING_LOST), "KATA_TRACKING_LOST");
  // Vendor layouts: their joint lists open streams with their presets.
  for (const char* vendor : {"azure-kinect", "xsens"}) {
    kata_skeleton v = nullptr;
    ASSERT_EQ(kata_skeleton_create_layout(h.ctx, vendor, &v), KATA_OK) << vendor;
    kata_stream_desc_init(&d);
    d.layout = vendor;
    ASSERT_EQ(kata_stream_open(h.ctx, v, &d, &s), KATA_OK) << kata_context_last_error(h.ctx);
    kata_stream_destroy(s);
    kata_skeleton_destroy(v);
  }
  kata_skeleton none = nullptr;
  EXPECT_EQ(kata_skeleton_create_layout(h.ctx, "optitrack", &none), KATA_E_NOT_FOUND);
  EXPECT_EQ(none, nullptr);
  kata_skeleton_destroy(gpd);
}

TEST(AnyBody, AJointMissingPastMaxHoldLosesTrackingAndTheStreamRecovers) {
  CmuClip clip("07_01.bvh");
  Handles h;
  kata_stream s = h.open_mediapipe(0);
  std::vector<float> conf(kLandmarks, 1.0f);
  const double dt = clip.frame_time;
  size_t f = 0;
  for (; f < 20; ++f)
    ASSERT_EQ(kata_stream_push_confidence(s, f * dt, to_mediapipe(clip, f).data(), conf.data(), kLandmarks), KATA_OK);
  conf[15] = 0.1f;  // left wrist lost: held for 0.5 s, then the frame is lost
  int held = 0;
  kata_status st = KATA_OK;
  for (; st == KATA_OK; ++f, ++held)
    st = kata_stream_push_confidence(s, f * dt, to_mediapipe(clip, f).data(), conf.data(), kLandmarks);
  EXPECT_EQ(st, KATA_TRACKING_LOST);
  EXPECT_NEAR((held - 1) * dt, 0.5, 1.5 * dt);
  const int64_t before = kata_stream_feature_count(s);
  conf[15] = 1.0f;
  ASSERT_EQ(kata_stream_push_confidence(s, f * dt, to_mediapipe(clip, f).data(), conf.data(), kLandmarks), KATA_OK);
  EXPECT_EQ(kata_stream_feature_count(s), before + 1);
  kata_stream_destroy(s);
}



// A BVH clip with one rotation channel of one joint turned by `degrees` on every frame after frame
// 0 (the converter's T-pose), as ../shared/tools/bend-joint does, written to `out`: the channel's
// column counted from the CHANNELS lines of the hierarchy, in file order.
// max_frames > 0 keeps the first max_frames frames only.
void write_turned_bvh(const std::string& in, const std::string& joint, const std::string& channel, double degrees,
                      const std::string& out, int max_frames = -1) {
  std::ifstream f(in);
  ASSERT_TRUE(f.good()) << in;
  std::ofstream o(out);
  std::string line, current;
  int column = -1, columns = 0, frame = -1;
  bool motion = false;
  while (std::getline(f, line)) {
    std::istringstream words(line);
    std::string w;
    words >> w;
    if (!motion) {
      if (w == "ROOT" || w == "JOINT") words >> current;
      if (w == "CHANNELS") {
        int n = 0;
        words >> n;
        for (int i = 0; i < n; ++i) {
          std::string c;
          words >> c;
          if (current == joint && c == channel) column = columns;
          ++columns;
        }
      }
      if (w == "Frame") {  // "Frame Time:": the frames follow
        motion = true;
        frame = 0;
      }
      int frames = 0;
      if (w == "Frames:" && max_frames > 0 && (words >> frames) && frames > max_frames) {
        o << "Frames: " << max_frames << "\n";
        continue;
      }
      o << line << "\n";
      continue;
    }
    if (max_frames > 0 && frame >= max_frames) break;
    ASSERT_GE(column, 0) << joint << " " << channel << " not in " << in;
    std::istringstream values(line);
    std::vector<std::string> v;  // the other channels' text unchanged
    for (std::string x; values >> x;) v.push_back(x);
    if (v.empty()) continue;
    ASSERT_EQ(static_cast<int>(v.size()), columns) << in << " frame " << frame;
    if (frame > 0) {
      char turned[64];
      std::snprintf(turned, sizeof turned, "%.6f", std::stod(v[static_cast<size_t>(column)]) + degrees);
      v[static_cast<size_t>(column)] = turned;
    }
    for (size_t i = 0; i < v.size(); ++i) o << (i ? " " : "") << v[i];
    o << "\n";
    ++frame;
  }
}

// The 45-degree catch, on the webcam's path: a student bends a knee in front of the camera and
// the coach sees the score drop and the cue name the knee. The student is MediaPipe landmarks of the
// teacher's own walk (the converter above) with the left knee turned on every frame (the BVH's
// LeftLeg X channel: + flexes it, +45 by 42 deg on 02_01), at the webcam's 30 frames a
// second, with the layout's default smoothing, against the unturned CMU clip as the teacher
// through the online alignment, all through the C ABI; the same landmarks unturned are the
// control. Asserted, with the coach's criteria: at +-45 deg the mean total is <= 50 (the control
// >= 90); at +-30 deg the cue names LKnee on >= 70 % of scoring frames with a median angle within
// 30 +- 8 deg, saying "straighten" on most of them when the student's knee is the more bent one
// (+), "bend" when it is the straighter one (-).
TEST(AnyBody, AWebcamStudentsTurnedKneeDropsTheScoreAndIsNamed) {
  CmuClip teacher("02_01.bvh");
  Handles h;
  struct Seen {
    double mean_score = 0;
    int scoring = 0, knee = 0, straighten = 0;
    std::vector<float> knee_degrees;
  };
  auto lesson = [&](const CmuClip& student) {
    Seen seen;
    kata_stream s = h.open_mediapipe(/*smoothing=*/-1);
    kata_teacher_desc t;
    kata_teacher_desc_init(&t);
    t.model = h.model;
    t.clip = teacher.clip;
    t.layout = "cmu";
    t.first_frame = 1;
    t.ghost = 0;
    EXPECT_EQ(kata_stream_attach_teacher(s, &t), KATA_OK) << kata_stream_last_error(s);
    const int step = std::max(1, static_cast<int>(std::lround(1.0 / 30.0 / student.frame_time)));  // 30 fps
    int64_t count = 0, scored = 0;
    double sum = 0;
    for (size_t f = 0; f < student.frames.size(); f += static_cast<size_t>(step)) {
      const std::vector<float> mp = to_mediapipe(student, f);
      EXPECT_EQ(kata_stream_push(s, static_cast<double>(f) * student.frame_time, mp.data(), kLandmarks), KATA_OK);
      if (kata_stream_feature_count(s) == count) continue;
      count = kata_stream_feature_count(s);
      kata_result_record r;
      r.struct_size = sizeof r;
      EXPECT_EQ(kata_stream_read_newest(s, &r, nullptr, 0, nullptr, 0), KATA_OK) << kata_stream_last_error(s);
      if (!r.scored) continue;
      sum += r.score;
      ++scored;
      if (r.state != KATA_SCORE_SCORING) continue;
      ++seen.scoring;
      const char* joint = kata_gpd_joint_name(r.cue_joint);
      if (joint && std::string(joint) == "LKnee") {
        ++seen.knee;
        seen.knee_degrees.push_back(r.cue_degrees);
        seen.straighten += r.cue_action == KATA_CUE_STRAIGHTEN;
      }
    }
    kata_stream_destroy(s);
    seen.mean_score = scored ? sum / static_cast<double>(scored) : 0.0;
    return seen;
  };
  const Seen control = lesson(teacher);
  EXPECT_GE(control.mean_score, 90.0);
  for (const double degrees : {30.0, -30.0, 45.0, -45.0}) {
    const std::string path = testing::TempDir() + "kata_anybody_knee_02_01.bvh";
    write_turned_bvh(std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh", "LeftLeg", "Xrotation", degrees, path);
    const CmuClip turned(path.c_str());
    std::remove(path.c_str());
    ASSERT_EQ(turned.frames.size(), teacher.frames.size());
    Seen knee = lesson(turned);
    std::sort(knee.knee_degrees.begin(), knee.knee_degrees.end());
    const double median = knee.knee_degrees.empty() ? 0.0 : knee.knee_degrees[knee.knee_degrees.size() / 2];
    std::printf("[ figures ] webcam student, left knee %+.0f deg: mean score %.1f (unturned %.1f), cue LKnee on %d of "
                "%d scoring frames (unturned: %d), median %.1f deg, straighten on %d\n",
                degrees, knee.mean_score, control.mean_score, knee.knee, knee.scoring, control.knee, median,
                knee.straighten);
    if (std::fabs(degrees) > 40) {
      EXPECT_LE(knee.mean_score, 50.0) << degrees;
      continue;
    }
    ASSERT_GT(knee.scoring, 10) << degrees;
    EXPECT_GE(knee.knee, 0.7 * knee.scoring) << degrees;
    EXPECT_NEAR(median, 30.0, 8.0) << degrees;
    if (degrees > 0)
      EXPECT_GT(knee.straighten, knee.knee / 2) << degrees;
    else
      EXPECT_LT(knee.straighten, knee.knee / 2) << degrees;
  }
}

// The webcam student is judged as the mocap student is: one limb joint turned by 45 degrees on
// every frame of 3 s of a shipped clip of each subject it has (2, 5, 7, 9; frame 0 and 360 frames, the teacher the same 3 s
// unturned), through the C ABI as MediaPipe world landmarks (the converter above, 120 Hz, the
// layout's default smoothing) and as the BVH itself, each against the CMU teacher with the online
// alignment: both mean totals <= 50, and the turned joint's part the one to fix on most frames
// that name one. The turns are those of the balance table through landmarks
// (docs/model/landmark_balance.py) that the default 0.05 s re-match let through (52.1-53.0: 02_01 and
// 07_01's left elbow -45, 09_01's left knee +45) before a smoothed stream re-matched within 0.1 s
// (metric/smoothed_rematch.hpp), and two no re-match reach moved: 09_01's left knee -45 (the run;
// 52.8, 47.1 as BVH) and subject 5's 05_03 left knee +45 (the dance; 52.2, 44.6 as BVH), which
// scored over 50 until the teacher's trunk was made by the landmark layout's rule
// (trunk_as_student; docs/model/landmark_balance.md).
TEST(AnyBody, AWebcamStudentsTurnedJointScoresAsTheMocapStudents) {
  Handles h;
  struct Case {
    const char* clip;
    const char* joint;
    const char* channel;
    double degrees;
    double landmarks_bound;
  };
  const Case cases[] = {{"02_01", "LeftForeArm", "Yrotation", -45, 50}, {"05_03", "LeftLeg", "Xrotation", 45, 50},
                        {"07_01", "LeftForeArm", "Yrotation", -45, 50}, {"09_01", "LeftLeg", "Xrotation", 45, 50},
                        {"09_01", "LeftLeg", "Xrotation", -45, 50}};
  const std::string dir = testing::TempDir();
  for (const Case& c : cases) {
    const std::string in = std::string(KATA_DATA_DIR) + "/cmu/" + c.clip + ".bvh";
    const std::string tpath = dir + "kata_anybody_balance_teacher.bvh", spath = dir + "kata_anybody_balance_student.bvh";
    write_turned_bvh(in, c.joint, c.channel, 0.0, tpath, 361);
    write_turned_bvh(in, c.joint, c.channel, c.degrees, spath, 361);
    const CmuClip teacher(tpath.c_str()), student(spath.c_str());
    std::remove(tpath.c_str());
    std::remove(spath.c_str());
    ASSERT_EQ(student.frames.size(), teacher.frames.size()) << c.clip;
    ASSERT_GE(student.frames.size(), 148u) << c.clip;  // 09_01 has 148 frames after its T-pose, the others >= 343
    // Through landmarks.
    std::vector<std::vector<float>> mp;
    for (size_t f = 0; f < student.frames.size(); ++f) mp.push_back(to_mediapipe(student, f));
    kata_stream s = h.open_mediapipe(/*smoothing=*/-1);
    const RunResult through = run(s, h.model, teacher.clip, mp, nullptr, student.frame_time);
    const double landmarks = mean(through.scores);
    kata_stream_destroy(s);
    // The part named: the turned joint's, on most frames that name a part.
    const int part = std::string(c.joint) == "LeftLeg" ? KATA_PART_LEFT_LEG : KATA_PART_LEFT_ARM;
    const auto named = std::count_if(through.part_to_fix.begin(), through.part_to_fix.end(), [](int p) { return p >= 0; });
    const auto right = std::count(through.part_to_fix.begin(), through.part_to_fix.end(), part);
    std::printf("[ figures ] %s %s %+.0f deg through landmarks: part %d named on %ld of %ld frames naming one\n", c.clip,
                c.joint, c.degrees, part, static_cast<long>(right), static_cast<long>(named));
    EXPECT_GE(named, 100) << c.clip << " " << c.joint << " " << c.degrees;
    EXPECT_GE(right, 0.9 * static_cast<double>(named)) << c.clip << " " << c.joint << " " << c.degrees;
    // Through the BVH: a "cmu" stream of the clip's own skeleton.
    kata_stream_desc d;
    kata_stream_desc_init(&d);
    d.layout = "cmu";
    d.stencil = kata_model_stencil(h.model);
    kata_stream b = nullptr;
    ASSERT_EQ(kata_stream_open(h.ctx, student.skel, &d, &b), KATA_OK) << kata_context_last_error(h.ctx);
    kata_teacher_desc t;
    kata_teacher_desc_init(&t);
    t.model = h.model;
    t.clip = teacher.clip;
    t.layout = "cmu";
    t.first_frame = 1;
    t.ghost = 0;
    ASSERT_EQ(kata_stream_attach_teacher(b, &t), KATA_OK) << kata_stream_last_error(b);
    const uint32_t joints = kata_skeleton_joint_count(student.skel);
    std::vector<float> out(KATA_GPD_DIMS);
    int64_t seen = 0;
    double sum = 0;
    int n = 0;
    for (size_t f = 0; f < student.raw.size(); ++f) {
      ASSERT_EQ(kata_stream_push(b, static_cast<double>(f) * student.frame_time, student.raw[f].data(), joints), KATA_OK);
      if (kata_stream_feature_count(b) == seen) continue;
      seen = kata_stream_feature_count(b);
      kata_result_record r;
      r.struct_size = sizeof r;
      ASSERT_EQ(kata_stream_read_newest(b, &r, nullptr, 0, nullptr, 0), KATA_OK);
      sum += r.score;
      ++n;
    }
    kata_stream_destroy(b);
    const double bvh = n ? sum / n : 0.0;
    std::printf("[ figures ] %s %s %+.0f deg: mean total through landmarks %.1f, through the BVH %.1f\n", c.clip, c.joint,
                c.degrees, landmarks, bvh);
    EXPECT_LE(landmarks, c.landmarks_bound) << c.clip << " " << c.joint << " " << c.degrees;
    EXPECT_LE(bvh, 50.0) << c.clip << " " << c.joint << " " << c.degrees;
  }
}

// The trunk rule binds only across layouts: a "cmu" student of a "cmu" teacher clip scores, bit
// for bit, what it scores against the same teacher given as features made by a "cmu" stream of
// the teacher's frames (kata_stream_features: no student in sight), while a "mediapipe" student
// of the same teacher clip does not (its teacher is read with the synthesised trunk).
TEST(AnyBody, TheTeachersTrunkIsReadAsTheStudentsOnlyAcrossLayouts) {
  Handles h;
  const CmuClip teacher("02_01.bvh");
  const std::string in = std::string(KATA_DATA_DIR) + "/cmu/02_01.bvh";
  const std::string spath = testing::TempDir() + "kata_anybody_trunk_student.bvh";
  write_turned_bvh(in, "LeftLeg", "Xrotation", 45.0, spath, 241);
  const CmuClip student(spath.c_str());
  std::remove(spath.c_str());
  const uint32_t joints = kata_skeleton_joint_count(teacher.skel);
  auto cmu_stream = [&](kata_skeleton skel) {
    kata_stream_desc d;
    kata_stream_desc_init(&d);
    d.layout = "cmu";
    d.stencil = kata_model_stencil(h.model);
    kata_stream s = nullptr;
    EXPECT_EQ(kata_stream_open(h.ctx, skel, &d, &s), KATA_OK) << kata_context_last_error(h.ctx);
    return s;
  };
  // The teacher's features by its own stream, frames first_frame = 1.. as the clip teacher reads them.
  std::vector<float> features;
  {
    kata_stream t = cmu_stream(teacher.skel);
    std::vector<float> f(KATA_GPD_DIMS);
    int64_t seen = 0;
    auto take = [&] {
      while (kata_stream_feature_count(t) > seen) {
        ++seen;
        ASSERT_EQ(kata_stream_features(t, f.data(), f.size(), nullptr, nullptr), KATA_OK);
        features.insert(features.end(), f.begin(), f.end());
      }
    };
    for (size_t i = 0; i < teacher.raw.size(); ++i) {
      ASSERT_EQ(kata_stream_push(t, static_cast<double>(i) * teacher.frame_time, teacher.raw[i].data(), joints), KATA_OK);
      take();
    }
    ASSERT_EQ(kata_stream_flush(t), KATA_OK);
    take();
    kata_stream_destroy(t);
  }
  ASSERT_EQ(features.size(), teacher.raw.size() * KATA_GPD_DIMS);
  // The student's scores against the clip, and against the features.
  auto scores = [&](bool as_features) {
    kata_stream s = cmu_stream(student.skel);
    kata_teacher_desc t;
    kata_teacher_desc_init(&t);
    t.model = h.model;
    t.layout = "cmu";
    t.ghost = 0;
    if (as_features) {
      t.features = features.data();
      t.frames = static_cast<uint32_t>(teacher.raw.size());
      t.frame_time = teacher.frame_time;
    } else {
      t.clip = teacher.clip;
      t.first_frame = 1;
    }
    EXPECT_EQ(kata_stream_attach_teacher(s, &t), KATA_OK) << kata_stream_last_error(s);
    std::vector<float> out;
    int64_t seen = 0;
    for (size_t f = 0; f < student.raw.size(); ++f) {
      EXPECT_EQ(kata_stream_push(s, static_cast<double>(f) * student.frame_time, student.raw[f].data(), joints), KATA_OK);
      if (kata_stream_feature_count(s) == seen) continue;
      seen = kata_stream_feature_count(s);
      kata_result_record r;
      r.struct_size = sizeof r;
      EXPECT_EQ(kata_stream_read_newest(s, &r, nullptr, 0, nullptr, 0), KATA_OK);
      out.push_back(r.score);
      out.push_back(r.distance);
      out.push_back(static_cast<float>(r.matched_teacher_frame));
    }
    kata_stream_destroy(s);
    return out;
  };
  const std::vector<float> clip = scores(false), given = scores(true);
  ASSERT_GT(clip.size(), 3u * 200u);
  ASSERT_EQ(clip.size(), given.size());
  for (size_t i = 0; i < clip.size(); ++i) ASSERT_EQ(clip[i], given[i]) << "result " << i / 3 << " field " << i % 3;
  // Across layouts the teacher clip is read with the student's trunk: the same student as
  // landmarks scores otherwise against the clip than against the "cmu" features (the teacher's own
  // trunk joints), and the turned knee is caught (<= 50) against the clip.
  std::vector<std::vector<float>> mp;
  for (size_t f = 0; f < student.frames.size(); ++f) mp.push_back(to_mediapipe(student, f));
  kata_stream a = h.open_mediapipe(-1);
  const double against_clip = mean(run(a, h.model, teacher.clip, mp, nullptr, student.frame_time).scores);
  kata_stream_destroy(a);
  kata_stream b = h.open_mediapipe(-1);
  kata_teacher_desc t;
  kata_teacher_desc_init(&t);
  t.model = h.model;
  t.ghost = 0;
  t.features = features.data();
  t.frames = static_cast<uint32_t>(teacher.raw.size());
  t.frame_time = teacher.frame_time;
  ASSERT_EQ(kata_stream_attach_teacher(b, &t), KATA_OK) << kata_stream_last_error(b);
  double sum = 0;
  int n = 0;
  int64_t seen = 0;
  for (size_t f = 0; f < mp.size(); ++f) {
    ASSERT_EQ(kata_stream_push(b, static_cast<double>(f) * student.frame_time, mp[f].data(), kLandmarks), KATA_OK);
    if (kata_stream_feature_count(b) == seen) continue;
    seen = kata_stream_feature_count(b);
    kata_result_record r;
    r.struct_size = sizeof r;
    ASSERT_EQ(kata_stream_read_newest(b, &r, nullptr, 0, nullptr, 0), KATA_OK);
    sum += r.score;
    ++n;
  }
  kata_stream_destroy(b);
  const double against_joints = n ? sum / n : 0.0;
  std::printf("[ figures ] 02_01 left knee +45 through landmarks: %.1f against the clip (the landmark rule's trunk), "
              "%.1f against the teacher's own trunk joints\n",
              against_clip, against_joints);
  EXPECT_NE(against_clip, against_joints);
  EXPECT_LE(against_clip, 50.0);
}

// A MediaPipe teacher given as positions (1.1: the teacher desc's layout read as a stream of it
// reads frames, its Y-down axes and smoothing included; 1.0 refused "mediapipe" there): a
// MediaPipe stream of the same landmarks is at distance 0 on every scored frame. Read as Y-up
// (the teacher upside down) it would not be.
TEST(AnyBody, AMediaPipeTeacherGivenAsPositionsScoresItsOwnLandmarksAtDistanceZero) {
  CmuClip clip("02_01.bvh");
  Handles h;
  const size_t frames = 240;
  std::vector<float> positions;
  for (size_t f = 1; f <= frames; ++f) {
    const std::vector<float> l = to_mediapipe(clip, f);
    positions.insert(positions.end(), l.begin(), l.end());
  }
  kata_stream s = h.open_mediapipe(-1);
  kata_teacher_desc t;
  kata_teacher_desc_init(&t);
  t.model = h.model;
  t.skeleton = h.mp;
  t.positions = positions.data();
  t.frames = static_cast<uint32_t>(frames);
  t.frame_time = 1.0 / 120.0;
  t.layout = "mediapipe";
  t.ghost = 0;
  ASSERT_EQ(kata_stream_attach_teacher(s, &t), KATA_OK) << kata_stream_last_error(s);
  std::vector<kata_result_record> r;
  for (size_t f = 0; f < frames; ++f) {
    ASSERT_EQ(kata_stream_push(s, f / 120.0, positions.data() + f * 3 * kLandmarks, kLandmarks), KATA_OK)
        << kata_stream_last_error(s);
    kata_result_record one;
    one.struct_size = sizeof one;
    uint32_t got = 0;
    ASSERT_EQ(kata_stream_read_results(s, &one, nullptr, 0, nullptr, 0, 1, &got), KATA_OK);
    if (got == 1) r.push_back(one);
  }
  ASSERT_GT(r.size(), 200u);
  const size_t n = r.size();
  int scored = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!r[i].scored || r[i].state != KATA_SCORE_SCORING) continue;
    ++scored;
    EXPECT_LT(r[i].distance, 1e-5f) << i;
    EXPECT_GT(r[i].score, 99.0f) << i;
  }
  EXPECT_GT(scored, 150);
  kata_stream_destroy(s);
}

}  // namespace
