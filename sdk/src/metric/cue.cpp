#include "metric/cue.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "metric/pose_error.hpp"

namespace kata::metric {

namespace {

constexpr double kDegrees = 180.0 / 3.14159265358979323846;
// Per bone c: the joint to move (cue.hpp), and the parent bone it is measured against (0: none,
// the bone hangs from a body frame).
constexpr int kCueJoint[gpd::kJoints] = {-1, 0, 1, 2, 4, 4, 5, 7, 7, 8, 10, 10, 11, 13, 13, 14};
constexpr int kParentBone[gpd::kJoints] = {0, 0, 1, 0, 0, 0, 5, 0, 0, 8, 0, 0, 11, 0, 0, 14};
enum class Kind { kHinge, kElevation, kLean, kHead };
constexpr Kind kKind[gpd::kJoints] = {Kind::kLean,      Kind::kLean,      Kind::kLean,      Kind::kHead,
                                      Kind::kElevation, Kind::kElevation, Kind::kHinge,     Kind::kElevation,
                                      Kind::kElevation, Kind::kHinge,     Kind::kElevation, Kind::kElevation,
                                      Kind::kHinge,     Kind::kElevation, Kind::kElevation, Kind::kHinge};
constexpr const char* kJointWords[gpd::kJoints] = {
    "lower back", "chest", "neck", "", "left shoulder", "left elbow", "", "right shoulder",
    "right elbow", "", "left hip", "left knee", "", "right hip", "right knee", ""};
constexpr const char* kActionWords[] = {"bend", "straighten", "raise", "lower", "turn"};

double dot(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
void cross(const double* a, const double* b, double* o) {
  o[0] = a[1] * b[2] - a[2] * b[1];
  o[1] = a[2] * b[0] - a[0] * b[2];
  o[2] = a[0] * b[1] - a[1] * b[0];
}
// The angle between unit vectors, degrees, from the cross and dot products (accurate near 0 and 180).
double angle(const double* a, const double* b) {
  double c[3];
  cross(a, b, c);
  return std::atan2(std::sqrt(dot(c, c)), dot(a, b)) * kDegrees;
}
// v turned by the smallest rotation taking unit a onto unit b (Rodrigues, k = a x b, cos = a.b):
// v cos + k x v + k (k.v) / (1 + cos). False when a and b are (nearly) opposite: no unique rotation.
bool turn_onto(const double* a, const double* b, const double* v, double* o) {
  const double c = dot(a, b);
  if (!(c > -1.0 + 1e-6)) return false;
  double k[3], kv[3];
  cross(a, b, k);
  cross(k, v, kv);
  const double f = dot(k, v) / (1.0 + c);
  for (int i = 0; i < 3; ++i) o[i] = v[i] * c + kv[i] + k[i] * f;
  return true;
}
double elevation(const double* d) { return std::asin(std::clamp(d[1], -1.0, 1.0)) * kDegrees; }
double lean(const double* d) { return std::atan2(d[2], d[1]) * kDegrees; }
// a - b wrapped to [-180, 180].
double wrapped(double a, double b) {
  double d = a - b;
  while (d > 180.0) d -= 360.0;
  while (d < -180.0) d += 360.0;
  return d;
}

}  // namespace

void bone_cue(const float* s, const float* t, BoneCue& out) {
  out.degrees[0] = out.change[0] = 0.0f;
  for (int c = 1; c < gpd::kJoints; ++c) {
    out.degrees[c] = out.change[c] = 0.0f;
    double a[3], b[3];
    if (!bone_direction(s, c, a) || !bone_direction(t, c, b)) continue;  // degenerate: nothing known
    const int p = kParentBone[c];
    double pa[3] = {0.0, 0.0, 0.0}, pb[3] = {0.0, 0.0, 0.0};
    const bool parent = p > 0 && bone_direction(s, p, pa) && bone_direction(t, p, pb);
    double at[3];
    // At the joint: the student's parent bone turned onto the teacher's, the bone with it.
    if (parent && turn_onto(pa, pb, a, at))
      out.degrees[c] = static_cast<float>(angle(at, b));
    else
      out.degrees[c] = static_cast<float>(angle(a, b));
    double change = 0.0;
    switch (kKind[c]) {
      case Kind::kHinge:
        // Inner angle 180 - angle(parent, bone); student minus teacher.
        if (parent) change = angle(pb, b) - angle(pa, a);
        break;
      case Kind::kElevation:
        change = elevation(a) - elevation(b);
        break;
      case Kind::kLean:
        change = wrapped(lean(a), lean(b));
        if (parent) change = wrapped(change, wrapped(lean(pa), lean(pb)));
        break;
      case Kind::kHead:
        change = wrapped(lean(a), lean(b));
        break;
    }
    out.change[c] = static_cast<float>(change);
  }
}

int cue_joint(int bone) { return bone >= 1 && bone < gpd::kJoints ? kCueJoint[bone] : -1; }

CueAction cue_action(int bone, double degrees, double change) {
  if (bone < 1 || bone >= gpd::kJoints) return CueAction::kNone;
  // Mostly sideways or a twist: the signed change is under half the angle.
  if (!(std::fabs(change) >= 0.5 * degrees) || !(degrees > 0.0)) return CueAction::kTurn;
  const bool more = change > 0.0;
  switch (kKind[bone]) {
    case Kind::kHinge:
      return more ? CueAction::kBend : CueAction::kStraighten;
    case Kind::kElevation:
      return more ? CueAction::kLower : CueAction::kRaise;
    case Kind::kLean:
      return more ? CueAction::kStraighten : CueAction::kBend;
    case Kind::kHead:
      return more ? CueAction::kRaise : CueAction::kLower;
  }
  return CueAction::kTurn;
}

const char* cue_joint_words(int joint) { return joint >= 0 && joint < gpd::kJoints ? kJointWords[joint] : ""; }

const char* cue_action_word(int action) { return action >= 0 && action <= 4 ? kActionWords[action] : ""; }

int cue_text(int joint, float degrees, int action, char* buf, size_t n) {
  const char* words = cue_joint_words(joint);
  const char* verb = cue_action_word(action);
  if (!*words || !*verb) {
    if (n > 0) buf[0] = '\0';
    return 0;
  }
  const double d = std::isfinite(degrees) ? std::clamp(static_cast<double>(degrees), 0.0, 180.0) : 0.0;
  return std::snprintf(buf, n, "%s: %s %.0f deg%s", words, verb, d,
                       action == static_cast<int>(CueAction::kBend) ? " more" : "");
}

}  // namespace kata::metric
