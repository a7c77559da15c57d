// The per-stream retargeter (see retargeter.hpp).
#include "retarget/retargeter.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "common/error.hpp"

namespace kata::retarget {

namespace {
std::vector<double> rest_directions_of(const Skeleton& s) {
  std::vector<double> d(3 * static_cast<size_t>(s.joint_count()), 0.0);
  for (int j = 0; j < s.joint_count(); ++j) {
    const double len = s.offsets[j].norm();
    for (int k = 0; k < 3; ++k) d[3 * j + k] = len > 0.0 ? s.offsets[j][k] / len : (k == 1 ? 1.0 : 0.0);
  }
  return d;
}
}  // namespace

Retargeter::Retargeter(const std::vector<int>& parents, const std::vector<double>& student_lengths,
                       const RetargetOptions& options, const std::vector<double>& rest_directions)
    : table_(build_pair_table(parents)),
      options_(options),
      student_lengths_(student_lengths),
      solver_(static_cast<int>(parents.size())) {
  init(rest_directions);
}

Retargeter::Retargeter(const Skeleton& student, const RetargetOptions& options)
    : table_(build_pair_table(student.parents)),
      options_(options),
      student_lengths_(rest_bone_lengths(student)),
      solver_(student.joint_count()) {
  init(rest_directions_of(student));
}

void Retargeter::init(const std::vector<double>& rest_directions) {
  const int n = table_.joints, m = table_.pairs;
  if (static_cast<int>(student_lengths_.size()) != n) {
    throw Error(ErrorKind::kInvalidArgument, "Retargeter: one student bone length per joint expected");
  }
  for (int j = 1; j < n; ++j) {
    if (!(student_lengths_[j] > 0.0) || !std::isfinite(student_lengths_[j])) {
      throw Error(ErrorKind::kInvalidArgument, "Retargeter: student bone lengths must be positive and finite");
    }
  }
  student_lengths_[0] = 0.0;
  if (rest_directions.empty()) {
    rest_dirs_.assign(3 * static_cast<size_t>(n), 0.0);
    for (int j = 0; j < n; ++j) rest_dirs_[3 * j + 1] = 1.0;
  } else if (static_cast<int>(rest_directions.size()) == 3 * n) {
    rest_dirs_ = rest_directions;
  } else {
    throw Error(ErrorKind::kInvalidArgument, "Retargeter: rest directions must be joints x 3");
  }
  tau_student_.resize(m);
  cumulative_.resize(n);
  path_weights(table_, student_lengths_.data(), cumulative_.data(), tau_student_.data());
  weight_.resize(m);
  teacher_lengths_.resize(n);
  tau_teacher_.resize(m);
  delta_.resize(m);
  x_.resize(3 * static_cast<size_t>(n));
  baseline_.resize(3 * static_cast<size_t>(n));
  solved_.resize(3 * static_cast<size_t>(n));
}

StressInstance Retargeter::paper_instance() const {
  return StressInstance{table_.joints, table_.pairs, table_.u.data(), table_.v.data(), table_.priority.data(),
                        delta_.data()};
}

void Retargeter::forward_kinematics_baseline(const double* t, double* out) const {
  for (int k = 0; k < 3; ++k) out[k] = t[k];
  for (int j = 1; j < table_.joints; ++j) {
    const int p = table_.parents[j];
    double d[3] = {t[3 * j] - t[3 * p], t[3 * j + 1] - t[3 * p + 1], t[3 * j + 2] - t[3 * p + 2]};
    const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    const double* dir = len > 1e-12 * student_lengths_[j] ? d : &rest_dirs_[3 * j];
    const double scale = student_lengths_[j] / (len > 1e-12 * student_lengths_[j] ? len : 1.0);
    for (int k = 0; k < 3; ++k) out[3 * j + k] = out[3 * p + k] + scale * dir[k];
  }
}

void Retargeter::align_on_teacher(const double* t, double* x) {
  // Kabsch about the root: the rotation R maximising trace(R H), H = sum (x_j - x_0)(t_j - t_0)^T.
  const int n = table_.joints;
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (int j = 1; j < n; ++j) {
    const Eigen::Vector3d a(x[3 * j] - x[0], x[3 * j + 1] - x[1], x[3 * j + 2] - x[2]);
    const Eigen::Vector3d b(t[3 * j] - t[0], t[3 * j + 1] - t[1], t[3 * j + 2] - t[2]);
    h.noalias() += a * b.transpose();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d u = svd.matrixU(), v = svd.matrixV();
  const Eigen::Vector3d s = svd.singularValues();
  double sign = (v * u.transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  // The stress cannot tell a posture from its mirror image. When the best fit is a reflection
  // with a clearly 3-D spread (s3 not negligible), the optimum is the mirror: flip it back.
  if (sign < 0.0 && s[2] > 1e-3 * s[0]) {
    for (int j = 1; j < n; ++j)
      for (int k = 0; k < 3; ++k) x[3 * j + k] = 2.0 * x[k] - x[3 * j + k];
    // The flipped H is -H: same singular vectors with U negated, so R = V U'^T = -V U^T (proper).
    sign = 1.0;
    const Eigen::Matrix3d r = -(v * u.transpose());
    const Eigen::Vector3d root(x[0], x[1], x[2]);
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector3d a(x[3 * j] - root[0], x[3 * j + 1] - root[1], x[3 * j + 2] - root[2]);
      const Eigen::Vector3d b = r * a;
      for (int k = 0; k < 3; ++k) x[3 * j + k] = t[k] + b[k];
    }
    return;
  }
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = sign;
  const Eigen::Matrix3d r = v * d * u.transpose();
  const Eigen::Vector3d root(x[0], x[1], x[2]);
  for (int j = 0; j < n; ++j) {
    const Eigen::Vector3d a(x[3 * j] - root[0], x[3 * j + 1] - root[1], x[3 * j + 2] - root[2]);
    const Eigen::Vector3d b = r * a;
    for (int k = 0; k < 3; ++k) x[3 * j + k] = t[k] + b[k];
  }
}

void Retargeter::restore_bones(const double* reference, const double* x, double* out) const {
  for (int k = 0; k < 3; ++k) out[k] = x[k];
  for (int j = 1; j < table_.joints; ++j) {
    const int p = table_.parents[j];
    double d[3] = {x[3 * j] - x[3 * p], x[3 * j + 1] - x[3 * p + 1], x[3 * j + 2] - x[3 * p + 2]};
    double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(len > 1e-9 * student_lengths_[j])) {
      // Collapsed bone: no solved direction; take the reference's (the teacher's) instead.
      for (int k = 0; k < 3; ++k) d[k] = reference[3 * j + k] - reference[3 * p + k];
      len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      if (!(len > 0.0)) {
        for (int k = 0; k < 3; ++k) d[k] = rest_dirs_[3 * j + k];
        len = 1.0;
      }
    }
    const double scale = student_lengths_[j] / len;
    for (int k = 0; k < 3; ++k) out[3 * j + k] = out[3 * p + k] + scale * d[k];
  }
}

double Retargeter::max_bone_error(const double* x) const {
  double worst = 0.0;
  for (int j = 1; j < table_.joints; ++j) {
    const int p = table_.parents[j];
    const double dx = x[3 * j] - x[3 * p], dy = x[3 * j + 1] - x[3 * p + 1], dz = x[3 * j + 2] - x[3 * p + 2];
    const double len = std::sqrt(dx * dx + dy * dy + dz * dz);
    worst = std::max(worst, std::fabs(len - student_lengths_[j]) / student_lengths_[j]);
  }
  return worst;
}

const RetargetReport& Retargeter::retarget(const double* teacher, double* ghost) {
  const int n = table_.joints, m = table_.pairs;
  // 1. Targets: delta = tau_student * |t_u - t_v| / tau_teacher (tau_teacher of this frame).
  bone_lengths(table_, teacher, teacher_lengths_.data());
  path_weights(table_, teacher_lengths_.data(), cumulative_.data(), tau_teacher_.data());
  const int* pu = table_.u.data();
  const int* pv = table_.v.data();
  for (int p = 0; p < m; ++p) {
    const int a = 3 * pu[p], b = 3 * pv[p];
    const double dx = teacher[a] - teacher[b], dy = teacher[a + 1] - teacher[b + 1], dz = teacher[a + 2] - teacher[b + 2];
    const double dist = std::sqrt(dx * dx + dy * dy + dz * dz);
    // A teacher path of zero length (degenerate bones) carries no shape: keep the student's own.
    delta_[p] = tau_teacher_[p] > 0.0 ? tau_student_[p] * dist / tau_teacher_[p] : tau_student_[p];
    weight_[p] = table_.priority[p] * (table_.is_bone[p] ? options_.bone_weight : 1.0);
  }
  const StressInstance paper = paper_instance();
  const StressInstance solve{n, m, pu, pv, weight_.data(), delta_.data()};

  // 2. Start point and SPG.
  forward_kinematics_baseline(teacher, baseline_.data());
  report_ = RetargetReport{};
  report_.stress_baseline = stress(paper, baseline_.data(), nullptr);
  report_.warm = options_.warm_start && has_previous_;
  if (!report_.warm) std::copy(baseline_.begin(), baseline_.end(), x_.begin());
  SpgOptions spg = options_.solver;
  if (report_.warm && spg.initial_step <= 0.0) spg.initial_step = last_step_;
  const bool paper_weights = options_.bone_weight == 1.0;
  if (!paper_weights) report_.stress_start = stress(paper, x_.data(), nullptr);
  const SpgResult r = solver_.minimize(solve, x_.data(), spg);
  last_step_ = r.last_step;
  report_.iterations = r.iterations;
  report_.evaluations = r.evaluations;
  report_.converged = r.converged;
  if (paper_weights) report_.stress_start = r.stress_start;
  report_.stress = paper_weights ? r.stress : stress(paper, x_.data(), nullptr);

  // 3. Rigid placement on the teacher; this aligned optimum is also the next warm start.
  align_on_teacher(teacher, x_.data());
  has_previous_ = true;
  std::copy(x_.begin(), x_.end(), solved_.begin());
  report_.max_bone_error_solved = max_bone_error(solved_.data());

  // 4. Bone-length restoring step.
  if (options_.restore_bone_lengths) {
    restore_bones(teacher, solved_.data(), ghost);
  } else {
    std::copy(solved_.begin(), solved_.end(), ghost);
  }
  report_.max_bone_error = max_bone_error(ghost);
  report_.stress_output = stress(paper, ghost, nullptr);
  return report_;
}

void place_over_student(int joints, const double* student, double* ghost) {
  // The yaw theta maximising sum_j s_j . R_y(theta) g_j over horizontal components (relative to
  // the roots): theta = atan2(sum (g_z s_x - g_x s_z), sum (g_x s_x + g_z s_z)).
  double c = 0.0, s = 0.0;
  for (int j = 1; j < joints; ++j) {
    const double gx = ghost[3 * j] - ghost[0], gz = ghost[3 * j + 2] - ghost[2];
    const double sx = student[3 * j] - student[0], sz = student[3 * j + 2] - student[2];
    c += gx * sx + gz * sz;
    s += gz * sx - gx * sz;
  }
  const double theta = (c == 0.0 && s == 0.0) ? 0.0 : std::atan2(s, c);
  const double ct = std::cos(theta), st = std::sin(theta);
  const double r0[3] = {ghost[0], ghost[1], ghost[2]};
  for (int j = 0; j < joints; ++j) {
    const double gx = ghost[3 * j] - r0[0], gy = ghost[3 * j + 1] - r0[1], gz = ghost[3 * j + 2] - r0[2];
    // R_y(theta) (x, z) = (cos x + sin z, -sin x + cos z).
    ghost[3 * j] = student[0] + ct * gx + st * gz;
    ghost[3 * j + 1] = student[1] + gy;
    ghost[3 * j + 2] = student[2] - st * gx + ct * gz;
  }
}

}  // namespace kata::retarget
