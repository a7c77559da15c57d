// The VRM humanoid rig (rig.hpp; kata/humanoid.h "The rig" is the contract this implements).
#include "humanoid/rig.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <Eigen/Geometry>

#include "common/error.hpp"

namespace kata::humanoid {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

// How a bone's turn about its own axis is chosen (kata/humanoid.h, "Chosen").
enum TwistKind : int {
  kSwing = 0,      // the smallest rotation from the parent's
  kShoulderLine,   // the topmost chest bone: the upper arms' line is its +X
  kBendForward,    // the upper arm: the forearm bends toward its +Z
  kBendBack,       // the upper leg: the shin bends toward its -Z
  kHandLateral,    // the forearm and the hand: hand point A - B is their +Z
  kFace,           // the head (no child point): ears' line +X, nose +Z
};

// Below this a direction (metres) is degenerate.
constexpr double kEpsilon = 1e-9;
constexpr double kPi = 3.14159265358979323846;
// The bend twist fades in between these bend angles (a straight limb says nothing of its turn).
constexpr double kBendNone = 5.0 * kPi / 180.0, kBendFull = 20.0 * kPi / 180.0;
constexpr double kTanBendFull = 0.36397023426620234;  // tan(20 degrees)
constexpr double kTanBendNone = 0.087488663525924;     // tan(5 degrees)
// The lateral twists fade in as the reference's component across the bone grows (sine).
constexpr double kLateralNone = 0.05, kLateralFull = 0.2;
// A pelvis whose hips joint lies this close to the hip line (share of the hip width) takes its
// orientation from the spine instead of the triangle.
constexpr double kTriangleMin = 0.05, kTriangleFrameMin = 0.02;

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

Matrix3d about(const Vector3d& unit_axis, double angle) {
  return Eigen::AngleAxisd(angle, unit_axis).toRotationMatrix();
}

Matrix3d columns(const Vector3d& x, const Vector3d& y, const Vector3d& z) {
  Matrix3d m;
  m.col(0) = x;
  m.col(1) = y;
  m.col(2) = z;
  return m;
}

using Eigen::Quaterniond;

// x y z w of a unit rotation, w >= 0 (products of unit quaternions stay unit to rounding).
Eigen::Vector4d xyzw(const Quaterniond& q) {
  const double sign = q.w() < 0 ? -1.0 : 1.0;
  return {sign * q.x(), sign * q.y(), sign * q.z(), sign * q.w()};
}

// The smallest rotation taking unit a onto unit b: (1 + a.b, a x b), normalised.
Quaterniond swing_q(const Vector3d& a, const Vector3d& b) {
  const double c = a.dot(b);
  const Vector3d v = a.cross(b);
  // Normalised by its computed length (2 (1 + c) in exact arithmetic, not after rounding when a
  // and b are nearly opposite).
  const double n2 = (1.0 + c) * (1.0 + c) + v.squaredNorm();
  if (n2 > 1e-20) {
    const double k = 1.0 / std::sqrt(n2);
    return Quaterniond((1.0 + c) * k, v.x() * k, v.y() * k, v.z() * k);
  }
  // Opposite: half a turn about any axis across a.
  const Vector3d e = std::abs(a.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY();
  const Vector3d axis = a.cross(e).normalized();
  return Quaterniond(0.0, axis.x(), axis.y(), axis.z());
}

// The turn about unit `axis` taking `from` toward `to` (both across the axis), by the share w of
// its angle: always about the axis itself, so the bone's direction stays exact.
Quaterniond twist_q(const Vector3d& from, const Vector3d& to, const Vector3d& axis, double w) {
  const double c = from.dot(to), s = axis.dot(from.cross(to));
  if (w >= 1.0) {
    // (1 + cos t, sin t axis) is the half angle's direction; half a turn when t = pi.
    Quaterniond q(1.0 + c, s * axis.x(), s * axis.y(), s * axis.z());
    const double n = q.norm();
    if (n > 1e-12) return Quaterniond(q.coeffs() / n);
    return Quaterniond(0.0, axis.x(), axis.y(), axis.z());
  }
  const double half = 0.5 * w * std::atan2(s, c);
  const double sh = std::sin(half);
  return Quaterniond(std::cos(half), sh * axis.x(), sh * axis.y(), sh * axis.z());
}

double median(std::vector<double>& v) {
  if (v.empty()) return 0.0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  double m = v[mid];
  if (v.size() % 2 == 0) m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid)));
  return m;
}

// The extras of each layout, by joint name: one name, or two averaged ("a+b").
struct ExtraNames {
  int point;
  const char* a;
  const char* b;  // nullptr: one joint
};
struct LayoutExtras {
  const char* layout;
  std::vector<ExtraNames> names;
};
const std::vector<LayoutExtras>& layout_extras() {
  static const std::vector<LayoutExtras> table = {
      {"cmu",
       {{kPointSpineMid, "Spine", nullptr},
        {kPointLeftToe, "LeftToeBase", nullptr},
        {kPointRightToe, "RightToeBase", nullptr},
        {kPointLeftHandTip, "LeftHandIndex1", nullptr},
        {kPointRightHandTip, "RightHandIndex1", nullptr}}},
      {"mediapipe",
       {{kPointLeftToe, "left_foot_index", nullptr},
        {kPointRightToe, "right_foot_index", nullptr},
        {kPointLeftHandTip, "left_index", "left_pinky"},
        {kPointRightHandTip, "right_index", "right_pinky"},
        {kPointLeftHandA, "left_index", nullptr},
        {kPointLeftHandB, "left_pinky", nullptr},
        {kPointRightHandA, "right_index", nullptr},
        {kPointRightHandB, "right_pinky", nullptr},
        {kPointNose, "nose", nullptr},
        {kPointLeftEar, "left_ear", nullptr},
        {kPointRightEar, "right_ear", nullptr}}},
      {"kinect2",
       {{kPointLeftToe, "FootLeft", nullptr},
        {kPointRightToe, "FootRight", nullptr},
        {kPointLeftHandTip, "HandTipLeft", nullptr},
        {kPointRightHandTip, "HandTipRight", nullptr},
        {kPointLeftHandA, "ThumbLeft", nullptr},
        {kPointLeftHandB, "WristLeft", nullptr},
        {kPointRightHandA, "ThumbRight", nullptr},
        {kPointRightHandB, "WristRight", nullptr}}},
      {"azure-kinect",
       {{kPointLeftToe, "FOOT_LEFT", nullptr},
        {kPointRightToe, "FOOT_RIGHT", nullptr},
        {kPointLeftHandTip, "HANDTIP_LEFT", nullptr},
        {kPointRightHandTip, "HANDTIP_RIGHT", nullptr},
        {kPointLeftHandA, "THUMB_LEFT", nullptr},
        {kPointLeftHandB, "WRIST_LEFT", nullptr},
        {kPointRightHandA, "THUMB_RIGHT", nullptr},
        {kPointRightHandB, "WRIST_RIGHT", nullptr},
        {kPointNose, "NOSE", nullptr},
        {kPointLeftEar, "EAR_LEFT", nullptr},
        {kPointRightEar, "EAR_RIGHT", nullptr}}},
      {"xsens", {{kPointLeftToe, "LeftToe", nullptr}, {kPointRightToe, "RightToe", nullptr}}},
  };
  return table;
}

}  // namespace

double default_metres_per_unit(const std::string& layout) {
  if (layout == "cmu" || layout == "cmu-3dsmax" || layout == "daz") return 0.056444;
  if (layout == "azure-kinect") return 0.001;
  return 1.0;
}

Mapping make_mapping(const Skeleton& skeleton, const GpdMap& gpd, const std::string& layout, UpAxis axes,
                     double metres_per_unit) {
  Mapping m;
  m.gpd = gpd;
  m.axes = axes;
  m.metres_per_unit = metres_per_unit;
  m.input_joints = skeleton.joint_count();
  m.joint_names = skeleton.names;
  for (const LayoutExtras& e : layout_extras()) {
    if (layout != e.layout) continue;
    for (const ExtraNames& n : e.names) {
      const int a = skeleton.find(n.a);
      const int b = n.b ? skeleton.find(n.b) : -1;
      if (a < 0 || (n.b && b < 0)) continue;
      Mapping::Extra& x = m.extra[static_cast<size_t>(n.point - kGpdJoints)];
      x.count = n.b ? 2 : 1;
      x.joint = {a, n.b ? b : 0};
      x.weight = n.b ? std::array<float, 2>{0.5f, 0.5f} : std::array<float, 2>{1.0f, 0.0f};
    }
  }
  // A hand's turn needs both of its points, the head's all three.
  for (int side = 0; side < 2; ++side) {
    const int a = side ? kPointRightHandA : kPointLeftHandA, b = a + 1;
    if (!m.has(a) || !m.has(b)) {
      m.extra[static_cast<size_t>(a - kGpdJoints)].count = 0;
      m.extra[static_cast<size_t>(b - kGpdJoints)].count = 0;
    }
  }
  if (!m.has(kPointNose) || !m.has(kPointLeftEar) || !m.has(kPointRightEar))
    for (int p : {kPointNose, kPointLeftEar, kPointRightEar}) m.extra[static_cast<size_t>(p - kGpdJoints)].count = 0;
  return m;
}

Rig::Rig(Mapping mapping) : mapping_(std::move(mapping)) {
  const Mapping& m = mapping_;
  auto def = [&](int bone, int joint, int child, Vector3d axis, int twist, Vector3d secondary) {
    BoneDef& d = def_[static_cast<size_t>(bone)];
    d.joint = joint;
    d.child = child;
    d.axis = axis;
    d.twist = twist;
    d.secondary = secondary;
    placed_ |= 1u << bone;
  };
  const Vector3d x = Vector3d::UnitX(), y = Vector3d::UnitY(), z = Vector3d::UnitZ();
  const bool mid = m.has(kPointSpineMid);
  // The torso: Spine's joint on the hips'; with a spine joint between (CMU's Spine) Chest is that
  // joint and UpperChest GPD Chest, else Chest is GPD Chest.
  def_[kHips].joint = 0;
  placed_ |= 1u << kHips;
  def(kSpine, 0, mid ? kPointSpineMid : 1, y, kSwing, Vector3d::Zero());
  if (mid) {
    def(kChest, kPointSpineMid, 1, y, kSwing, Vector3d::Zero());
    def(kUpperChest, 1, 2, y, kShoulderLine, x);
  } else {
    def(kChest, 1, 2, y, kShoulderLine, x);
  }
  def(kNeck, 2, 3, y, kSwing, Vector3d::Zero());
  const bool face = m.has(kPointNose);
  def(kHead, 3, -1, y, face ? kFace : kSwing, Vector3d::Zero());
  for (int side = 0; side < 2; ++side) {
    const double s = side ? -1.0 : 1.0;  // left +X, right -X
    const int o = side ? 4 : 0;          // bone offset right vs left
    const int g = side ? 3 : 0;          // GPD offset
    const int tip = side ? kPointRightHandTip : kPointLeftHandTip;
    const bool lateral = m.has(side ? kPointRightHandA : kPointLeftHandA);
    def(kLeftShoulder + o, 1, 4 + g, s * x, kSwing, Vector3d::Zero());
    def(kLeftUpperArm + o, 4 + g, 5 + g, s * x, kBendForward, z);
    def(kLeftLowerArm + o, 5 + g, 6 + g, s * x, lateral ? kHandLateral : kSwing, z);
    def(kLeftHand + o, 6 + g, m.has(tip) ? tip : -1, s * x, lateral ? kHandLateral : kSwing, z);
    const int toe = side ? kPointRightToe : kPointLeftToe;
    def(kLeftUpperLeg + o, 10 + g, 11 + g, -y, kBendBack, -z);
    def(kLeftLowerLeg + o, 11 + g, 12 + g, -y, kSwing, Vector3d::Zero());
    def(kLeftFoot + o, 12 + g, m.has(toe) ? toe : -1, z, kSwing, Vector3d::Zero());
    if (m.has(toe)) def(kLeftToes + o, toe, -1, z, kSwing, Vector3d::Zero());
  }
  for (auto& o : rest_offset_) o = Vector3d::Zero();
  // measure() of one frame (a first frame posed) must not allocate: room for one sample each.
  for (auto& v : sample_lengths_) v.reserve(1);
  sample_share_.reserve(1);
  sample_tilt_.reserve(1);
  for (auto& side : sample_leg_spine_)
    for (auto& v : side) v.reserve(1);
  for (auto& side : sample_leg_triangle_)
    for (auto& v : side) v.reserve(1);
  // Each placed bone hangs from its nearest placed ancestor.
  for (int b = 1; b < kBoneCount; ++b) {
    int p = kBoneParents[static_cast<size_t>(b)];
    while (p > 0 && !(placed_ & (1u << p))) p = kBoneParents[static_cast<size_t>(p)];
    def_[static_cast<size_t>(b)].parent = p;
  }
  // The joints a frame must give: every one a point reads.
  std::vector<bool> read(static_cast<size_t>(m.input_joints), false);
  auto mark = [&](int j) {
    if (j >= 0 && j < m.input_joints) read[static_cast<size_t>(j)] = true;
  };
  for (int g = 0; g < kGpdJoints; ++g) {
    const int src = m.gpd.source[static_cast<size_t>(g)];
    if (src >= 0) {
      mark(src);
      continue;
    }
    const GpdBlend& bl = m.gpd.blend[static_cast<size_t>(g)];
    for (int k = 0; k < bl.count; ++k) mark(bl.joint[static_cast<size_t>(k)]);
    if (bl.offset != 0.0f)
      for (int j : bl.offset_joint) mark(j);
  }
  for (const Mapping::Extra& e : m.extra)
    for (int k = 0; k < e.count; ++k) mark(e.joint[static_cast<size_t>(k)]);
  for (int j = 0; j < m.input_joints; ++j)
    if (read[static_cast<size_t>(j)]) read_joints_.push_back(j);
}

int Rig::bone_source(int bone) const {
  if (bone < 0 || bone >= kBoneCount || !(placed_ & (1u << bone))) return -1;
  if (bone == kSpine || bone == kLeftShoulder || bone == kRightShoulder) return -1;  // on another bone's joint
  const int point = def_[static_cast<size_t>(bone)].joint;
  if (point < kGpdJoints) return mapping_.gpd.source[static_cast<size_t>(point)];
  const Mapping::Extra& e = mapping_.extra[static_cast<size_t>(point - kGpdJoints)];
  return e.count == 1 ? e.joint[0] : -1;
}

void Rig::points(const float* xyz, Points& out) const {
  const double scale = mapping_.metres_per_unit;
  float p[3];
  for (int g = 0; g < kGpdJoints; ++g) {
    map_gpd_joint(mapping_.gpd, mapping_.axes, g, xyz, p);
    out.p[static_cast<size_t>(g)] = scale * Vector3d(p[0], p[1], p[2]);
  }
  for (int i = 0; i < kExtraPoints; ++i) {
    const Mapping::Extra& e = mapping_.extra[static_cast<size_t>(i)];
    Vector3d v = Vector3d::Zero();
    for (int k = 0; k < e.count; ++k) {
      float q[3];
      to_y_up(mapping_.axes, xyz + 3 * e.joint[static_cast<size_t>(k)], q);
      v += static_cast<double>(e.weight[static_cast<size_t>(k)]) * Vector3d(q[0], q[1], q[2]);
    }
    out.p[static_cast<size_t>(kGpdJoints + i)] = scale * v;
  }
}

Matrix3d Rig::hips_frame(const Points& pts, uint32_t& degenerate) const {
  const Vector3d& h = pts.p[0];
  const Vector3d u = pts.p[10] - pts.p[13];  // left hip joint - right
  const double width = u.norm();
  if (!(width > kEpsilon)) {
    degenerate |= 1u << kHips;
    return Matrix3d::Identity();
  }
  const Vector3d ux = u / width;
  if (triangle_) {
    const Vector3d m = 0.5 * (pts.p[10] + pts.p[13]) - h;
    const Vector3d across = m - m.dot(ux) * ux;
    if (across.norm() > kTriangleFrameMin * width) {
      const Vector3d yt = -across.normalized();
      return columns(ux, yt, ux.cross(yt)) * tilt_.transpose();
    }
    degenerate |= 1u << kHips;  // the pelvis flattened this frame: the spine's frame
  }
  Vector3d s = pts.p[static_cast<size_t>(def_[kChest].joint)] - h;
  Vector3d yv = s - s.dot(ux) * ux;
  if (!(yv.norm() > kEpsilon)) {
    degenerate |= 1u << kHips;
    yv = Vector3d::UnitY() - ux.y() * ux;
    if (!(yv.norm() > 1e-6)) yv = Vector3d::UnitZ() - ux.z() * ux;
  }
  const Vector3d yn = yv.normalized();
  return columns(ux, yn, ux.cross(yn));
}

bool Rig::complete(const Points& pts) const {
  for (int b = 0; b < kBoneCount; ++b) {
    const BoneDef& d = def_[static_cast<size_t>(b)];
    if (!(placed_ & (1u << b)) || d.child < 0) continue;
    if (!((pts.p[static_cast<size_t>(d.child)] - pts.p[static_cast<size_t>(d.joint)]).norm() > kEpsilon)) return false;
  }
  return (pts.p[10] - pts.p[13]).norm() > kEpsilon;
}

void Rig::measure(const Points* frames, int n) {
  auto& lengths = sample_lengths_;
  auto& tri_share = sample_share_;
  auto& tilt = sample_tilt_;
  auto& leg_sp = sample_leg_spine_;
  auto& leg_tri = sample_leg_triangle_;
  const size_t want = static_cast<size_t>(std::max(n, 1));
  for (auto& v : lengths) v.clear(), v.reserve(want);
  tri_share.clear(), tri_share.reserve(want);
  tilt.clear(), tilt.reserve(want);
  for (int side = 0; side < 2; ++side)
    for (int c = 0; c < 3; ++c) {
      leg_sp[static_cast<size_t>(side)][static_cast<size_t>(c)].clear();
      leg_sp[static_cast<size_t>(side)][static_cast<size_t>(c)].reserve(want);
      leg_tri[static_cast<size_t>(side)][static_cast<size_t>(c)].clear();
      leg_tri[static_cast<size_t>(side)][static_cast<size_t>(c)].reserve(want);
    }
  for (int f = 0; f < n; ++f) {
    const Points& pts = frames[f];
    for (int b = 0; b < kBoneCount; ++b) {
      const BoneDef& d = def_[static_cast<size_t>(b)];
      if (!(placed_ & (1u << b)) || d.child < 0) continue;
      const double len = (pts.p[static_cast<size_t>(d.child)] - pts.p[static_cast<size_t>(d.joint)]).norm();
      if (len > kEpsilon) lengths[static_cast<size_t>(b)].push_back(len);
    }
    // The pelvis in the spine's frame and in the triangle's.
    const Vector3d& h = pts.p[0];
    const Vector3d u = pts.p[10] - pts.p[13];
    if (!(u.norm() > kEpsilon)) continue;
    const Vector3d ux = u.normalized();
    const Vector3d s = pts.p[static_cast<size_t>(def_[kChest].joint)] - h;
    const Vector3d yv = s - s.dot(ux) * ux;
    if (!(yv.norm() > kEpsilon)) continue;
    const Vector3d ys = yv.normalized();
    const Matrix3d fs = columns(ux, ys, ux.cross(ys));
    const Vector3d m = 0.5 * (pts.p[10] + pts.p[13]) - h;
    const Vector3d across = m - m.dot(ux) * ux;
    tri_share.push_back(across.norm() / u.norm());
    Matrix3d ft = fs;
    if (across.norm() > kEpsilon) {
      const Vector3d yt = -across.normalized();
      ft = columns(ux, yt, ux.cross(yt));
      const Vector3d in_spine = fs.transpose() * yt;  // (0, cos, sin)
      tilt.push_back(std::atan2(in_spine.z(), in_spine.y()));
    }
    for (int side = 0; side < 2; ++side) {
      const Vector3d v = pts.p[side ? 13u : 10u] - h;
      const Vector3d a = fs.transpose() * v, b = ft.transpose() * v;
      for (int c = 0; c < 3; ++c) {
        leg_sp[static_cast<size_t>(side)][static_cast<size_t>(c)].push_back(a[c]);
        leg_tri[static_cast<size_t>(side)][static_cast<size_t>(c)].push_back(b[c]);
      }
    }
  }
  for (int b = 0; b < kBoneCount; ++b) length_[static_cast<size_t>(b)] = median(lengths[static_cast<size_t>(b)]);
  triangle_ = !tilt.empty() && median(tri_share) >= kTriangleMin;
  std::array<Vector3d, 2> leg;
  if (triangle_) {
    const double alpha = median(tilt);
    tilt_ = about(Vector3d::UnitX(), alpha);
    for (int side = 0; side < 2; ++side) {
      Vector3d q;
      for (int c = 0; c < 3; ++c) q[c] = median(leg_tri[static_cast<size_t>(side)][static_cast<size_t>(c)]);
      leg[static_cast<size_t>(side)] = tilt_ * q;
    }
  } else {
    tilt_ = Matrix3d::Identity();
    for (int side = 0; side < 2; ++side)
      for (int c = 0; c < 3; ++c)
        leg[static_cast<size_t>(side)][c] = median(leg_sp[static_cast<size_t>(side)][static_cast<size_t>(c)]);
  }
  // The rest offsets (kata/humanoid.h "Rest").
  for (int b = 0; b < kBoneCount; ++b) rest_offset_[static_cast<size_t>(b)] = Vector3d::Zero();
  for (int b = 1; b < kBoneCount; ++b) {
    if (!(placed_ & (1u << b))) continue;
    const BoneDef& d = def_[static_cast<size_t>(b)];
    const BoneDef& p = def_[static_cast<size_t>(d.parent)];
    if (d.joint == p.joint) continue;  // on its parent's joint
    if (p.child == d.joint)
      rest_offset_[static_cast<size_t>(b)] = length_[static_cast<size_t>(d.parent)] * p.axis;
    else
      rest_offset_[static_cast<size_t>(b)] = leg[b == kRightUpperLeg ? 1u : 0u];
  }
  double hips_y = 0.0;
  for (int side = 0; side < 2; ++side) {
    const int o = side ? 4 : 0;
    hips_y = std::max(hips_y, -rest_offset_[static_cast<size_t>(kLeftUpperLeg + o)].y() +
                                  length_[static_cast<size_t>(kLeftUpperLeg + o)] +
                                  length_[static_cast<size_t>(kLeftLowerLeg + o)]);
  }
  rest_offset_[kHips] = Vector3d(0.0, hips_y, 0.0);
  rest_ready_ = true;
}

void Rig::rest_pose(Pose& out) const {
  out.placed = placed_;
  out.degenerate = 0;
  out.hips = rest_offset_[kHips];
  for (int b = 0; b < kBoneCount; ++b) {
    out.rotation[static_cast<size_t>(b)] = Eigen::Vector4d(0, 0, 0, 1);
    out.offset[static_cast<size_t>(b)] = rest_offset_[static_cast<size_t>(b)];
  }
}

void Rig::pose(const Points& pts, Pose& out) const {
  // World rotations as quaternions (the per-frame path: no matrix per bone, no trigonometry but
  // for a fading twist).
  std::array<Quaterniond, kBoneCount> world;
  uint32_t degenerate = 0;
  out.placed = placed_;
  out.hips = pts.p[0];
  world[kHips] = Quaterniond(hips_frame(pts, degenerate));
  world[kHips].normalize();  // from a matrix: normalised once
  out.rotation[kHips] = xyzw(world[kHips]);
  out.offset[kHips] = rest_offset_[kHips];
  for (int b = 1; b < kBoneCount; ++b) {
    const size_t bi = static_cast<size_t>(b);
    const BoneDef& d = def_[bi];
    if (!(placed_ & (1u << b))) {
      world[bi] = world[static_cast<size_t>(d.parent < 0 ? 0 : d.parent)];
      out.rotation[bi] = Eigen::Vector4d(0, 0, 0, 1);
      out.offset[bi] = Vector3d::Zero();
      continue;
    }
    const Quaterniond& parent = world[static_cast<size_t>(d.parent)];
    Quaterniond g = parent;
    const Vector3d& at = pts.p[static_cast<size_t>(d.joint)];
    if (d.child >= 0) {
      const Vector3d dir = pts.p[static_cast<size_t>(d.child)] - at;
      const double len = dir.norm();
      if (len > kEpsilon) {
        const Vector3d dn = dir * (1.0 / len);
        g = swing_q(parent * d.axis, dn) * parent;
        if (d.twist != kSwing) {
          Vector3d s = Vector3d::Zero();
          switch (d.twist) {
            case kShoulderLine: s = pts.p[4] - pts.p[7]; break;
            case kBendForward:
            case kBendBack: {
              const BoneDef& c = def_[bi + 1];  // the lower arm / leg
              s = pts.p[static_cast<size_t>(c.child)] - pts.p[static_cast<size_t>(c.joint)];
              break;
            }
            case kHandLateral: {
              const bool right = b == kRightLowerArm || b == kRightHand;
              s = pts.p[right ? kPointRightHandA : kPointLeftHandA] - pts.p[right ? kPointRightHandB : kPointLeftHandB];
              break;
            }
            default: break;
          }
          const double sn = s.norm();
          const Vector3d across = s - s.dot(dn) * dn;
          const double an = across.norm();
          double w = 0.0;
          if (sn > kEpsilon && an > kEpsilon * sn) {
            if (d.twist == kBendForward || d.twist == kBendBack) {
              // Bent past kBendFull (tan compared, no atan2 on the common path): the full turn.
              const double along = s.dot(dn);
              if (along <= 0.0 || an >= kTanBendFull * along) {
                w = 1.0;
              } else if (an <= kTanBendNone * along) {
                w = 0.0;  // straight: no turn to read
              } else {
                const double bend = std::atan2(an, along);
                w = smoothstep((bend - kBendNone) / (kBendFull - kBendNone));
              }
            } else {
              const double r = an / sn;
              w = r >= kLateralFull ? 1.0 : smoothstep((r - kLateralNone) / (kLateralFull - kLateralNone));
            }
          }
          if (w > 0.0) {
            const Vector3d cur = g * d.secondary;
            const Vector3d target = across * (1.0 / an);
            g = twist_q(cur, target, dn, w) * g;
          } else if (d.twist != kBendForward && d.twist != kBendBack) {
            degenerate |= 1u << b;  // no turn to read: the smallest rotation
          }
        }
      } else {
        degenerate |= 1u << b;
      }
    } else if (d.twist == kFace) {
      const Vector3d ex = pts.p[kPointLeftEar] - pts.p[kPointRightEar];
      const Vector3d fwd = pts.p[kPointNose] - 0.5 * (pts.p[kPointLeftEar] + pts.p[kPointRightEar]);
      const double exn = ex.norm();
      const Vector3d xh = exn > kEpsilon ? Vector3d(ex / exn) : Vector3d::UnitX();
      const Vector3d zv = fwd - fwd.dot(xh) * xh;
      if (exn > kEpsilon && zv.norm() > kEpsilon) {
        const Vector3d zh = zv.normalized();
        g = Quaterniond(columns(xh, zh.cross(xh), zh));
        g.normalize();
      } else {
        degenerate |= 1u << b;
      }
    }
    world[bi] = g;
    out.rotation[bi] = xyzw(parent.conjugate() * g);
    out.offset[bi] = parent.conjugate() * (at - pts.p[static_cast<size_t>(def_[static_cast<size_t>(d.parent)].joint)]);
  }
  out.degenerate = degenerate;
}

}  // namespace kata::humanoid
