// The VMC protocol through the C ABI (kata/vmc.h): a humanoid pose written as a bundle and read
// back into the "vrm" layout's joints; hostile datagrams (built with liblo, or cut by hand)
// counted by cause without disturbing the pose. The bundles' bytes are checked by liblo's own
// tools and python3-liblo in tests/transport/test_vmc_peers.py.
#include <gtest/gtest.h>
#include <lo/lo.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "kata/kata.h"

namespace {

using Q = Eigen::Quaternionf;
using V = Eigen::Vector3f;

struct Context {
  Context() { EXPECT_EQ(kata_context_create(&ctx), KATA_OK); }
  ~Context() { kata_context_destroy(ctx); }
  kata_context ctx = nullptr;
};

// The vrm layout's joint names and parents, through the C ABI.
struct VrmSkeleton {
  explicit VrmSkeleton(kata_context ctx) {
    EXPECT_EQ(kata_skeleton_create_layout(ctx, "vrm", &skel), KATA_OK);
    for (uint32_t j = 0; j < kata_skeleton_joint_count(skel); ++j) {
      names.emplace_back(kata_skeleton_joint_name(skel, j));
      parents.push_back(kata_skeleton_joint_parent(skel, j));
    }
  }
  ~VrmSkeleton() { kata_skeleton_destroy(skel); }
  int index(const char* name) const {
    for (size_t j = 0; j < names.size(); ++j)
      if (names[j] == name) return static_cast<int>(j);
    return -1;
  }
  kata_skeleton skel = nullptr;
  std::vector<std::string> names;
  std::vector<int> parents;
};

// A random pose of every humanoid bone in kata's right-handed frame: T-pose offsets of a body
// (left at +X, facing +Z, metres), random local rotations up to ~60 degrees.
kata_humanoid_pose random_pose(std::mt19937& rng) {
  kata_humanoid_pose p{};
  p.struct_size = sizeof p;
  p.frame = KATA_HUMANOID_RIGHT_HANDED;
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  p.hips_position[0] = 0.3f * u(rng), p.hips_position[1] = 0.9f + 0.1f * u(rng), p.hips_position[2] = 0.3f * u(rng);
  for (int b = 0; b < KATA_BONE_COUNT; ++b) {
    p.placed |= 1u << b;
    V axis(u(rng), u(rng), u(rng));
    if (axis.norm() < 1e-3f) axis = V::UnitY();
    const Q q(Eigen::AngleAxisf(1.0f * u(rng), axis.normalized()));
    p.rotation[b][0] = q.x(), p.rotation[b][1] = q.y(), p.rotation[b][2] = q.z(), p.rotation[b][3] = q.w();
    // Offsets away from zero (a zero offset reads as "not given").
    for (int k = 0; k < 3; ++k) p.offset[b][k] = 0.05f + 0.1f * std::fabs(u(rng));
    p.offset[b][0] *= u(rng) < 0 ? -1.0f : 1.0f;
  }
  return p;
}

// World joint positions of a pose by forward kinematics over kata_humanoid_bone_parent, in the
// pose's own frame; index = humanoid bone.
std::vector<V> humanoid_fk(const kata_humanoid_pose& p) {
  std::vector<V> at(KATA_BONE_COUNT);
  std::vector<Q> world(KATA_BONE_COUNT);
  std::vector<bool> done(KATA_BONE_COUNT, false);
  for (int pass = 0; pass < KATA_BONE_COUNT; ++pass)
    for (int b = 0; b < KATA_BONE_COUNT; ++b) {
      if (done[static_cast<size_t>(b)]) continue;
      const int parent = kata_humanoid_bone_parent(static_cast<kata_humanoid_bone>(b));
      const Q local(p.rotation[b][3], p.rotation[b][0], p.rotation[b][1], p.rotation[b][2]);
      if (parent < 0) {
        world[static_cast<size_t>(b)] = local;
        at[static_cast<size_t>(b)] = V(p.hips_position[0], p.hips_position[1], p.hips_position[2]);
      } else if (done[static_cast<size_t>(parent)]) {
        const V off(p.offset[b][0], p.offset[b][1], p.offset[b][2]);
        world[static_cast<size_t>(b)] = world[static_cast<size_t>(parent)] * local;
        at[static_cast<size_t>(b)] = at[static_cast<size_t>(parent)] + world[static_cast<size_t>(parent)] * off;
      } else {
        continue;
      }
      done[static_cast<size_t>(b)] = true;
    }
  return at;
}

std::vector<uint8_t> write_pose(const kata_humanoid_pose& p, double t, float scale = 1.0f) {
  size_t need = 0;
  EXPECT_EQ(kata_vmc_write_pose(&p, t, scale, nullptr, 0, &need), KATA_E_BUFFER_TOO_SMALL);
  std::vector<uint8_t> out(need);
  size_t n = 0;
  EXPECT_EQ(kata_vmc_write_pose(&p, t, scale, out.data(), out.size(), &n), KATA_OK);
  EXPECT_EQ(n, need);
  return out;
}

// liblo's serialised bundle of the given messages (each added with its address), timetag immediate.
std::vector<uint8_t> bundle_of(const std::vector<std::pair<const char*, lo_message>>& messages) {
  const lo_timetag immediately = {0U, 1U};  // LO_TT_IMMEDIATE, spelt out: its compound literal is C99-only in C++
  lo_bundle b = lo_bundle_new(immediately);
  for (const auto& [address, m] : messages) lo_bundle_add_message(b, address, m);
  std::vector<uint8_t> out(lo_bundle_length(b));
  size_t n = 0;
  lo_bundle_serialise(b, out.data(), &n);
  out.resize(n);
  lo_bundle_free_recursive(b);
  return out;
}

lo_message bone(const char* name, const float* p, const float* q) {
  lo_message m = lo_message_new();
  lo_message_add_string(m, name);
  for (int k = 0; k < 3; ++k) lo_message_add_float(m, p[k]);
  for (int k = 0; k < 4; ++k) lo_message_add_float(m, q[k]);
  return m;
}

lo_message time_message(float t) {
  lo_message m = lo_message_new();
  lo_message_add_float(m, t);
  return m;
}

// lo_arg fields copied out (liblo's argument pointers are 4-byte aligned, the union needs 8).
float F(const lo_arg* a) {
  float v;
  std::memcpy(&v, a, sizeof v);
  return v;
}
int32_t I(const lo_arg* a) {
  int32_t v;
  std::memcpy(&v, a, sizeof v);
  return v;
}
const char* S(const lo_arg* a) { return reinterpret_cast<const char*>(a); }

kata_vmc_counters counters_of(kata_vmc_reader r) {
  kata_vmc_counters c{};
  c.struct_size = sizeof c;
  EXPECT_EQ(kata_vmc_reader_get_counters(r, &c), KATA_OK);
  return c;
}

TEST(Vmc, WrittenPoseReadsBackToTheSameJoints) {
  Context c;
  VrmSkeleton vrm(c.ctx);
  ASSERT_EQ(vrm.names.size(), static_cast<size_t>(KATA_VMC_JOINTS));
  kata_vmc_reader reader = nullptr;
  ASSERT_EQ(kata_vmc_reader_create(c.ctx, 0, &reader), KATA_OK);
  std::mt19937 rng(7);
  for (int frame = 0; frame < 50; ++frame) {
    const kata_humanoid_pose pose = random_pose(rng);
    const std::vector<uint8_t> bytes = write_pose(pose, 0.1 * frame);
    int32_t ended = 0;
    ASSERT_EQ(kata_vmc_reader_read(reader, bytes.data(), bytes.size(), 0.0, &ended), KATA_OK);
    ASSERT_EQ(ended, 1);
    float xyz[3 * KATA_VMC_JOINTS];
    double t = -1.0;
    ASSERT_EQ(kata_vmc_reader_positions(reader, xyz, 3 * KATA_VMC_JOINTS, &t), KATA_OK);
    EXPECT_NEAR(t, 0.1 * frame, 1e-6);
    const std::vector<V> want = humanoid_fk(pose);
    for (int b = 0; b < KATA_BONE_COUNT; ++b) {
      const int j = vrm.index(kata_humanoid_bone_name(static_cast<kata_humanoid_bone>(b)));
      ASSERT_GE(j, 0) << kata_humanoid_bone_name(static_cast<kata_humanoid_bone>(b));
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(xyz[3 * j + k], want[static_cast<size_t>(b)][k], 1e-5f) << "frame " << frame << " bone " << b;
    }
  }
  const kata_vmc_counters k = counters_of(reader);
  EXPECT_EQ(k.packets, 50u);
  EXPECT_EQ(k.frames, 50u);
  EXPECT_EQ(k.malformed + k.oversized + k.wrong_type + k.unknown_bone + k.bad_value + k.out_of_order, 0u);
  EXPECT_EQ(k.ignored, 50u);  // /VMC/Ext/OK
  kata_vmc_reader_destroy(reader);
}

TEST(Vmc, BundleHoldsTheProtocolsMessagesInUnitysFrame) {
  kata_humanoid_pose p{};
  p.struct_size = sizeof p;
  p.frame = KATA_HUMANOID_RIGHT_HANDED;
  p.placed = (1u << KATA_BONE_HIPS) | (1u << KATA_BONE_SPINE);
  p.hips_position[0] = 1.0f, p.hips_position[1] = 2.0f, p.hips_position[2] = 3.0f;
  const Q q(Eigen::AngleAxisf(0.5f, V(1, 2, 3).normalized()));
  for (int b = 0; b < KATA_BONE_COUNT; ++b) {
    p.rotation[b][0] = q.x(), p.rotation[b][1] = q.y(), p.rotation[b][2] = q.z(), p.rotation[b][3] = q.w();
    p.offset[b][0] = 0.5f, p.offset[b][1] = 0.25f, p.offset[b][2] = -0.125f;
  }
  std::vector<uint8_t> bytes = write_pose(p, 1.5, 2.0f);
  ASSERT_GE(bytes.size(), 16u);
  ASSERT_EQ(std::memcmp(bytes.data(), "#bundle", 8), 0);
  // Walk the elements with liblo's deserialiser.
  std::vector<std::string> addresses;
  size_t at = 16;
  while (at + 4 <= bytes.size()) {
    const uint32_t n = (uint32_t{bytes[at]} << 24) | (uint32_t{bytes[at + 1]} << 16) | (uint32_t{bytes[at + 2]} << 8) | bytes[at + 3];
    at += 4;
    ASSERT_LE(at + n, bytes.size());
    int result = 0;
    lo_message m = lo_message_deserialise(bytes.data() + at, n, &result);
    ASSERT_NE(m, nullptr) << result;
    const std::string address(reinterpret_cast<const char*>(bytes.data() + at));
    addresses.push_back(address);
    lo_arg** argv = lo_message_get_argv(m);
    const std::string types = lo_message_get_types(m);
    if (address == "/VMC/Ext/Bone/Pos") {
      EXPECT_EQ(types, "sfffffff");
      const std::string name = S(argv[0]);
      const float* want = name == "Hips" ? p.hips_position : p.offset[KATA_BONE_SPINE];
      EXPECT_FLOAT_EQ(F(argv[1]), -2.0f * want[0]) << name;  // mirrored, scaled
      EXPECT_FLOAT_EQ(F(argv[2]), 2.0f * want[1]);
      EXPECT_FLOAT_EQ(F(argv[3]), 2.0f * want[2]);
      EXPECT_FLOAT_EQ(F(argv[4]), q.x());
      EXPECT_FLOAT_EQ(F(argv[5]), -q.y());
      EXPECT_FLOAT_EQ(F(argv[6]), -q.z());
      EXPECT_FLOAT_EQ(F(argv[7]), q.w());
    } else if (address == "/VMC/Ext/Root/Pos") {
      EXPECT_EQ(types, "sfffffff");
      EXPECT_STREQ(S(argv[0]), "root");
    } else if (address == "/VMC/Ext/OK") {
      EXPECT_EQ(types, "i");
      EXPECT_EQ(I(argv[0]), 1);
    } else if (address == "/VMC/Ext/T") {
      EXPECT_EQ(types, "f");
      EXPECT_FLOAT_EQ(F(argv[0]), 1.5f);
    }
    lo_message_free(m);
    at += n;
  }
  EXPECT_EQ(at, bytes.size());
  const std::vector<std::string> want = {"/VMC/Ext/Root/Pos", "/VMC/Ext/Bone/Pos", "/VMC/Ext/Bone/Pos", "/VMC/Ext/OK",
                                         "/VMC/Ext/T"};
  EXPECT_EQ(addresses, want);
}

TEST(Vmc, WriterRefusesBadPoses) {
  Context c;
  std::mt19937 rng(3);
  kata_humanoid_pose p = random_pose(rng);
  uint8_t buffer[4096];
  size_t n = 99;
  EXPECT_EQ(kata_vmc_write_pose(nullptr, 0.0, 1.0f, buffer, sizeof buffer, &n), KATA_E_NULL_POINTER);
  EXPECT_EQ(kata_vmc_write_pose(&p, 0.0, 0.0f, buffer, sizeof buffer, &n), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(n, 0u);
  EXPECT_EQ(kata_vmc_write_pose(&p, NAN, 1.0f, buffer, sizeof buffer, &n), KATA_E_NON_FINITE);
  kata_humanoid_pose bad = p;
  bad.rotation[KATA_BONE_HEAD][1] = NAN;
  EXPECT_EQ(kata_vmc_write_pose(&bad, 0.0, 1.0f, buffer, sizeof buffer, &n), KATA_E_NON_FINITE);
  EXPECT_NE(std::string(kata_context_last_error(c.ctx)).find("Head"), std::string::npos) << kata_context_last_error(c.ctx);
  bad = p;
  bad.frame = 7;
  EXPECT_EQ(kata_vmc_write_pose(&bad, 0.0, 1.0f, buffer, sizeof buffer, &n), KATA_E_INVALID_ARGUMENT);
  bad = p;
  bad.placed &= ~(1u << KATA_BONE_HIPS);
  EXPECT_EQ(kata_vmc_write_pose(&bad, 0.0, 1.0f, buffer, sizeof buffer, &n), KATA_E_INVALID_ARGUMENT);
  bad = p;
  bad.struct_size = 8;
  EXPECT_EQ(kata_vmc_write_pose(&bad, 0.0, 1.0f, buffer, sizeof buffer, &n), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(kata_vmc_write_pose(&p, 0.0, 1.0f, buffer, 10, &n), KATA_E_BUFFER_TOO_SMALL);
  EXPECT_GT(n, 10u);
  EXPECT_LT(n, 2048u);  // every bone: under 2 KiB, as kata/vmc.h says
}

// Hostile datagrams: each refused or skipped datagram is counted by its cause, and the good
// frames between them read exactly as they would alone.
TEST(Vmc, BadInputIsCountedByCauseAndChangesNothing) {
  Context c;
  VrmSkeleton vrm(c.ctx);
  kata_vmc_reader reader = nullptr;
  ASSERT_EQ(kata_vmc_reader_create(c.ctx, 4096, &reader), KATA_OK);
  const float p0[3] = {0.0f, 1.0f, 0.0f}, id[4] = {0.0f, 0.0f, 0.0f, 1.0f};
  const Q turn(Eigen::AngleAxisf(0.7f, V::UnitY()));
  const float qt[4] = {turn.x(), turn.y(), turn.z(), turn.w()};
  const std::vector<uint8_t> good1 = bundle_of({{"/VMC/Ext/Bone/Pos", bone("Hips", p0, id)}, {"/VMC/Ext/T", time_message(1.0f)}});
  const std::vector<uint8_t> good2 = bundle_of({{"/VMC/Ext/Bone/Pos", bone("Hips", p0, qt)}, {"/VMC/Ext/T", time_message(2.0f)}});
  int32_t ended = 0;
  auto read = [&](const std::vector<uint8_t>& b) {
    EXPECT_EQ(kata_vmc_reader_read(reader, b.data(), b.size(), 0.0, &ended), KATA_OK);
    return ended;
  };
  float before[3 * KATA_VMC_JOINTS], after[3 * KATA_VMC_JOINTS];
  EXPECT_EQ(kata_vmc_reader_positions(reader, before, 3 * KATA_VMC_JOINTS, nullptr), KATA_NO_DATA);
  EXPECT_EQ(read(good1), 1);
  ASSERT_EQ(kata_vmc_reader_positions(reader, before, 3 * KATA_VMC_JOINTS, nullptr), KATA_OK);
  // Truncated at every length: malformed (a cut inside an element) or, cut between elements,
  // a shorter good bundle without its time (no frame).
  uint64_t cuts_malformed = 0;
  for (size_t n = 1; n < good2.size(); ++n) {
    std::vector<uint8_t> cut(good2.begin(), good2.begin() + static_cast<std::ptrdiff_t>(n));
    const uint64_t was = counters_of(reader).malformed;
    EXPECT_EQ(read(cut), 0) << n;
    cuts_malformed += counters_of(reader).malformed - was;
  }
  EXPECT_GE(cuts_malformed, good2.size() - 4);
  // The cut-off good bundles that parsed changed no frame: the joints are still frame 1's? A
  // bundle with the Hips and no time holds the bone for the next frame, so read frame 1 again.
  EXPECT_EQ(read(bundle_of({{"/VMC/Ext/Bone/Pos", bone("Hips", p0, id)}, {"/VMC/Ext/T", time_message(1.5f)}})), 1);
  ASSERT_EQ(kata_vmc_reader_positions(reader, after, 3 * KATA_VMC_JOINTS, nullptr), KATA_OK);
  for (int k = 0; k < 3 * KATA_VMC_JOINTS; ++k) ASSERT_FLOAT_EQ(after[k], before[k]) << k;
  kata_vmc_counters k0 = counters_of(reader);

  // Wrong types: an int where a float goes; a bone without its rotation.
  lo_message wrong = lo_message_new();
  lo_message_add_string(wrong, "Hips");
  for (int i = 0; i < 7; ++i) lo_message_add_int32(wrong, 1);
  lo_message shortm = lo_message_new();
  lo_message_add_string(shortm, "Hips");
  lo_message_add_float(shortm, 1.0f);
  lo_message wrong_t = lo_message_new();
  lo_message_add_string(wrong_t, "soon");
  EXPECT_EQ(read(bundle_of({{"/VMC/Ext/Bone/Pos", wrong}, {"/VMC/Ext/Bone/Pos", shortm}, {"/VMC/Ext/T", wrong_t}})), 0);
  // Unknown bones (a hostile sender's names: nothing is kept of them), NaN and infinite values, a
  // zero quaternion, a position beyond 10 km.
  const float nanp[3] = {NAN, 0.0f, 0.0f}, far[3] = {2e4f, 0.0f, 0.0f}, zero[4] = {0, 0, 0, 0};
  const float infq[4] = {INFINITY, 0, 0, 1};
  EXPECT_EQ(read(bundle_of({{"/VMC/Ext/Bone/Pos", bone("Tail", p0, id)},
                            {"/VMC/Ext/Bone/Pos", bone("LeftUpperArmXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXXX", p0, id)},
                            {"/VMC/Ext/Bone/Pos", bone("Hips", nanp, id)},
                            {"/VMC/Ext/Bone/Pos", bone("Hips", p0, infq)},
                            {"/VMC/Ext/Bone/Pos", bone("Hips", p0, zero)},
                            {"/VMC/Ext/Bone/Pos", bone("Hips", far, id)},
                            {"/VMC/Ext/T", time_message(NAN)}})),
            0);
  // Out of order: a frame at 1.2 s after the one at 1.5 s.
  EXPECT_EQ(read(bundle_of({{"/VMC/Ext/Bone/Pos", bone("Hips", p0, qt)}, {"/VMC/Ext/T", time_message(1.2f)}})), 0);
  // Oversized (above the reader's 4096 bytes) and not OSC at all; a bundle nested 9 deep.
  EXPECT_EQ(read(std::vector<uint8_t>(5000, 0)), 0);
  EXPECT_EQ(read(std::vector<uint8_t>{'h', 'e', 'l', 'l', 'o', 0, 0, 0}), 0);
  std::vector<uint8_t> nested = good1;
  for (int d = 0; d < 9; ++d) {
    std::vector<uint8_t> outer = {'#', 'b', 'u', 'n', 'd', 'l', 'e', 0, 0, 0, 0, 0, 0, 0, 0, 1};
    const uint32_t n = static_cast<uint32_t>(nested.size());
    outer.push_back(static_cast<uint8_t>(n >> 24)), outer.push_back(static_cast<uint8_t>(n >> 16));
    outer.push_back(static_cast<uint8_t>(n >> 8)), outer.push_back(static_cast<uint8_t>(n));
    outer.insert(outer.end(), nested.begin(), nested.end());
    nested = outer;
  }
  EXPECT_EQ(read(nested), 0);
  // Blend shapes: ignored.
  lo_message blend = lo_message_new();
  lo_message_add_string(blend, "Joy");
  lo_message_add_float(blend, 1.0f);
  EXPECT_EQ(read(bundle_of({{"/VMC/Ext/Blend/Val", blend}})), 0);

  const kata_vmc_counters k1 = counters_of(reader);
  EXPECT_EQ(k1.wrong_type - k0.wrong_type, 3u);
  EXPECT_EQ(k1.unknown_bone - k0.unknown_bone, 2u);
  EXPECT_EQ(k1.bad_value - k0.bad_value, 5u);
  EXPECT_EQ(k1.out_of_order - k0.out_of_order, 1u);
  EXPECT_EQ(k1.oversized - k0.oversized, 1u);
  EXPECT_EQ(k1.malformed - k0.malformed, 2u);
  EXPECT_EQ(k1.ignored - k0.ignored, 1u);
  EXPECT_EQ(k1.frames, k0.frames);
  // None of it moved a joint; the next good frame reads as it would alone.
  ASSERT_EQ(kata_vmc_reader_positions(reader, after, 3 * KATA_VMC_JOINTS, nullptr), KATA_OK);
  for (int k = 0; k < 3 * KATA_VMC_JOINTS; ++k) ASSERT_FLOAT_EQ(after[k], before[k]) << k;
  EXPECT_EQ(read(good2), 1);
  kata_vmc_reader fresh = nullptr;
  ASSERT_EQ(kata_vmc_reader_create(c.ctx, 4096, &fresh), KATA_OK);
  EXPECT_EQ(kata_vmc_reader_read(fresh, good2.data(), good2.size(), 0.0, &ended), KATA_OK);
  float alone[3 * KATA_VMC_JOINTS];
  ASSERT_EQ(kata_vmc_reader_positions(fresh, alone, 3 * KATA_VMC_JOINTS, nullptr), KATA_OK);
  ASSERT_EQ(kata_vmc_reader_positions(reader, after, 3 * KATA_VMC_JOINTS, nullptr), KATA_OK);
  for (int k = 0; k < 3 * KATA_VMC_JOINTS; ++k) ASSERT_FLOAT_EQ(after[k], alone[k]) << k;
  kata_vmc_reader_destroy(fresh);
  kata_vmc_reader_destroy(reader);
}

// Rotations only (a tracker that sends zero positions): a VRM-proportioned body; the T-pose with
// no bone named stands 1.65 m tall, facing +Z with its left side at +X (kata's frame).
TEST(Vmc, RotationsOnlyMoveAVrmProportionedBody) {
  Context c;
  VrmSkeleton vrm(c.ctx);
  kata_vmc_reader reader = nullptr;
  ASSERT_EQ(kata_vmc_reader_create(c.ctx, 0, &reader), KATA_OK);
  const float zero[3] = {0, 0, 0}, hips[3] = {0.0f, 0.95f, 0.0f}, id[4] = {0, 0, 0, 1};
  // The left upper arm turned 90 degrees down about Unity's +Z (its arm points along -X there).
  const Q down(Eigen::AngleAxisf(static_cast<float>(M_PI / 2), V::UnitZ()));
  const float qd[4] = {down.x(), down.y(), down.z(), down.w()};
  const std::vector<uint8_t> b = bundle_of({{"/VMC/Ext/Bone/Pos", bone("Hips", hips, id)},
                                            {"/VMC/Ext/Bone/Pos", bone("LeftUpperArm", zero, qd)},
                                            {"/VMC/Ext/Bone/Pos", bone("LeftToes", zero, id)}});
  int32_t ended = 0;
  ASSERT_EQ(kata_vmc_reader_read(reader, b.data(), b.size(), 3.0, &ended), KATA_OK);
  ASSERT_EQ(ended, 1);  // no /VMC/Ext/T from this sender: every bone datagram is a frame
  float xyz[3 * KATA_VMC_JOINTS];
  double t = 0.0;
  ASSERT_EQ(kata_vmc_reader_positions(reader, xyz, 3 * KATA_VMC_JOINTS, &t), KATA_OK);
  EXPECT_DOUBLE_EQ(t, 3.0);  // the arrival time
  auto at = [&](const char* name) {
    const int j = vrm.index(name);
    return V(xyz[3 * j], xyz[3 * j + 1], xyz[3 * j + 2]);
  };
  EXPECT_GT(at("LeftUpperArm").x(), 0.1f);  // left at +X
  EXPECT_LT(at("RightUpperArm").x(), -0.1f);
  EXPECT_GT(at("LeftToes").z(), at("LeftFoot").z());  // facing +Z
  // Collapsed optional bones: a sender that never names UpperChest (or the shoulders) has none.
  EXPECT_NEAR(at("Head").y(), 0.95f + 0.07f + 0.12f + 0.13f + 0.10f, 1e-5f);
  EXPECT_NEAR((at("UpperChest") - at("Chest")).norm(), 0.0f, 1e-6f);
  // The elbow hangs below the shoulder joint by the upper arm's length (0.26 m).
  const V arm = at("LeftLowerArm") - at("LeftUpperArm");
  EXPECT_NEAR(arm.y(), -0.26f, 1e-5f);
  EXPECT_NEAR(arm.x(), 0.0f, 1e-5f);
  kata_vmc_reader_destroy(reader);
}

TEST(Vmc, ReaderRefusesMisuse) {
  Context c;
  kata_vmc_reader r = nullptr;
  EXPECT_EQ(kata_vmc_reader_create(c.ctx, (1u << 20) + 1, &r), KATA_E_INVALID_ARGUMENT);
  EXPECT_EQ(r, nullptr);
  ASSERT_EQ(kata_vmc_reader_create(c.ctx, 0, &r), KATA_OK);
  int32_t f = 5;
  EXPECT_EQ(kata_vmc_reader_read(r, nullptr, 4, 0.0, &f), KATA_E_NULL_POINTER);
  EXPECT_EQ(f, 0);
  EXPECT_EQ(kata_vmc_reader_read(r, nullptr, 0, 0.0, &f), KATA_OK);  // an empty datagram: malformed
  EXPECT_EQ(counters_of(r).malformed, 1u);
  float small[3];
  EXPECT_EQ(kata_vmc_reader_positions(r, small, 3, nullptr), KATA_E_BUFFER_TOO_SMALL);
  kata_vmc_counters tiny{};
  tiny.struct_size = 4;
  EXPECT_EQ(kata_vmc_reader_get_counters(r, &tiny), KATA_E_INVALID_ARGUMENT);
  kata_vmc_reader_destroy(r);
  kata_vmc_reader_destroy(nullptr);
}

// What kata serve's [vmc] sends the student from: kata_runtime_desc.on_frame hands over every frame
// a runtime queues, with its stream, sequence, time and joints as pushed, and nothing for a frame
// it did not queue (an unknown stream).
struct Frames {
  std::vector<uint64_t> ids, sequences;
  std::vector<double> times;
  std::vector<float> xyz;
  std::vector<uint32_t> joints;
};
void on_frame(void* user, uint64_t id, uint64_t sequence, double t, const float* xyz, uint32_t joints) {
  auto& f = *static_cast<Frames*>(user);
  f.ids.push_back(id);
  f.sequences.push_back(sequence);
  f.times.push_back(t);
  f.joints.push_back(joints);
  f.xyz.insert(f.xyz.end(), xyz, xyz + 3 * joints);
}

TEST(vmc, TheRuntimeHandsEveryQueuedFrameToOnFrame) {
  Context c;
  kata_skeleton skel = nullptr;
  ASSERT_EQ(kata_skeleton_create_layout(c.ctx, "vrm", &skel), KATA_OK);
  const uint32_t joints = kata_skeleton_joint_count(skel);
  kata_stream_desc sd;
  kata_stream_desc_init(&sd);
  sd.layout = "vrm";
  kata_stream s = nullptr;
  ASSERT_EQ(kata_stream_open(c.ctx, skel, &sd, &s), KATA_OK) << kata_context_last_error(c.ctx);
  Frames got;
  kata_runtime_desc rd;
  kata_runtime_desc_init(&rd);
  EXPECT_EQ(rd.on_frame, nullptr);
  EXPECT_EQ(rd.on_frame_user, nullptr);
  rd.workers = 1;
  rd.on_frame = on_frame;
  rd.on_frame_user = &got;
  kata_runtime rt = nullptr;
  ASSERT_EQ(kata_runtime_create(c.ctx, &rd, &rt), KATA_OK) << kata_context_last_error(c.ctx);
  ASSERT_EQ(kata_runtime_add_stream(rt, 9, &s, "vrm", 0), KATA_OK) << kata_context_last_error(c.ctx);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> sent;
  for (uint64_t k = 0; k < 5; ++k) {
    std::vector<float> p(3 * joints);
    for (float& v : p) v = u(rng);
    ASSERT_EQ(kata_runtime_push(rt, 9, 100 + k, 0.5 * static_cast<double>(k), p.data(), joints), KATA_OK);
    sent.insert(sent.end(), p.begin(), p.end());
    EXPECT_NE(kata_runtime_push(rt, 10, k, 0.0, p.data(), joints), KATA_OK);  // no such stream: not handed over
  }
  ASSERT_EQ(kata_runtime_stop(rt), KATA_OK);
  ASSERT_EQ(got.ids.size(), 5u);
  for (size_t k = 0; k < 5; ++k) {
    EXPECT_EQ(got.ids[k], 9u);
    EXPECT_EQ(got.sequences[k], 100 + k);
    EXPECT_EQ(got.times[k], 0.5 * static_cast<double>(k));
    EXPECT_EQ(got.joints[k], joints);
  }
  EXPECT_EQ(got.xyz, sent);
  kata_runtime_destroy(rt);
  kata_skeleton_destroy(skel);
}

}  // namespace
