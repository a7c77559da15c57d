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
      solver_(static_cast<int>(parents.size())),
      cold_solver_(static_cast<int>(parents.size())) {
  init(rest_directions);
}

Retargeter::Retargeter(const Skeleton& student, const RetargetOptions& options)
    : table_(build_pair_table(student.parents)),
      options_(options),
      student_lengths_(rest_bone_lengths(student)),
      solver_(student.joint_count()),
      cold_solver_(student.joint_count()) {
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
  inverse_lengths_.assign(n, 0.0);
  for (int j = 1; j < n; ++j) inverse_lengths_[j] = 1.0 / student_lengths_[j];
  if (rest_directions.empty()) {
    rest_dirs_.assign(3 * static_cast<size_t>(n), 0.0);
    for (int j = 0; j < n; ++j) rest_dirs_[3 * j + 1] = 1.0;
  } else if (static_cast<int>(rest_directions.size()) == 3 * n) {
    rest_dirs_ = rest_directions;
  } else {
    throw Error(ErrorKind::kInvalidArgument, "Retargeter: rest directions must be joints x 3");
  }
  tau_student_.resize(m);
  own_.fit(n);
  path_weights(table_, student_lengths_.data(), own_.cumulative.data(), tau_student_.data());
  weight_.resize(m);
  update_weights();
  delta_.resize(m);
  x_.resize(3 * static_cast<size_t>(n));
  fade_.resize(3 * static_cast<size_t>(n));
  shown_.resize(3 * static_cast<size_t>(n));
  max_tau_student_ = *std::max_element(tau_student_.begin(), tau_student_.end());
  baseline_.resize(3 * static_cast<size_t>(n));
  previous_baseline_.resize(3 * static_cast<size_t>(n));
  solved_.resize(3 * static_cast<size_t>(n));
}

void Retargeter::Workspace::fit(int joints) {
  const size_t n = static_cast<size_t>(std::max(joints, 0)), m = n * (n > 0 ? n - 1 : 0) / 2;
  for (std::vector<double>* v : {&teacher_lengths, &cumulative})
    if (v->size() < n) v->resize(n);
  if (tau_teacher.size() < m) tau_teacher.resize(m);
  for (std::vector<double>* v : {&soa, &x_cold, &predicted})
    if (v->size() < 3 * n) v->resize(3 * n);
}

void Retargeter::update_weights() {
  for (int p = 0; p < table_.pairs; ++p)
    weight_[p] = table_.priority[p] * (table_.is_bone[p] ? options_.bone_weight : 1.0);
}

void Retargeter::set_options(const RetargetOptions& options) {
  options_ = options;
  update_weights();
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

bool detail::proper_best_rotation(const double* h, double bound, double* r) {
  const double sxx = h[0], sxy = h[1], sxz = h[2], syx = h[3], syy = h[4], syz = h[5], szx = h[6], szy = h[7],
               szz = h[8];
  const double det_h = sxx * (syy * szz - syz * szy) - sxy * (syx * szz - syz * szx) + sxz * (syx * szy - syy * szx);
  if (!(det_h > 0.0)) return false;
  // Horn's key matrix K: q^T K q = sum_j b_j . R(q) a_j for unit quaternions q (w, x, y, z).
  const double k[4][4] = {{sxx + syy + szz, syz - szy, szx - sxz, sxy - syx},
                          {syz - szy, sxx - syy - szz, sxy + syx, szx + sxz},
                          {szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy},
                          {sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz}};
  // det(K - l I) = l^4 + c2 l^2 + c1 l + c0 (trace K = 0): c2 = -2 |H|^2, c1 = -8 det H, c0 = det K.
  double h2 = 0.0;
  for (int i = 0; i < 9; ++i) h2 += h[i] * h[i];
  const double c2 = -2.0 * h2, c1 = -8.0 * det_h;
  const auto det3 = [](double a, double b, double c, double d, double e, double f, double g, double hh, double i) {
    return a * (e * i - f * hh) - b * (d * i - f * g) + c * (d * hh - e * g);
  };
  double c0 = 0.0;
  for (int j = 0, sign = 1; j < 4; ++j, sign = -sign) {  // expansion along row 0
    int c[3], m = 0;
    for (int q = 0; q < 4; ++q)
      if (q != j) c[m++] = q;
    c0 += sign * k[0][j] * det3(k[1][c[0]], k[1][c[1]], k[1][c[2]], k[2][c[0]], k[2][c[1]], k[2][c[2]], k[3][c[0]], k[3][c[1]], k[3][c[2]]);
  }
  // Newton from above the largest root (sigma_1 + sigma_2 + sigma_3 of H, at most sqrt(3) |H|
  // and at most `bound`): the polynomial and its derivatives are positive there, so the iterates
  // decrease monotonically onto it.
  double lambda = std::min(bound, std::sqrt(3.0 * h2));
  bool settled = false;
  for (int it = 0; it < 50 && !settled; ++it) {
    const double l2 = lambda * lambda;
    const double p = (l2 + c2) * l2 + c1 * lambda + c0;
    const double dp = 4.0 * l2 * lambda + 2.0 * c2 * lambda + c1;
    if (!(dp > 0.0)) return false;
    const double next = lambda - p / dp;
    settled = std::fabs(next - lambda) <= 1e-14 * std::fabs(next);
    lambda = next;
  }
  if (!settled || !(lambda > 0.0)) return false;
  // The adjugate of A = K - lambda I is (prod of the other eigenvalues' gaps) v v^T: its
  // largest column is the eigenvector, scaled.
  double a[4][4];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) a[i][j] = k[i][j] - (i == j ? lambda : 0.0);
  double best[4] = {0, 0, 0, 0}, best_norm = 0.0;
  for (int col = 0; col < 4; ++col) {
    double v[4], norm = 0.0;
    for (int row = 0; row < 4; ++row) {  // cofactor (col, row) of the symmetric A: adj(A)[row][col]
      int ri[3], ci[3], mr = 0, mc = 0;
      for (int q = 0; q < 4; ++q) {
        if (q != col) ri[mr++] = q;
        if (q != row) ci[mc++] = q;
      }
      const double minor = det3(a[ri[0]][ci[0]], a[ri[0]][ci[1]], a[ri[0]][ci[2]], a[ri[1]][ci[0]], a[ri[1]][ci[1]],
                                a[ri[1]][ci[2]], a[ri[2]][ci[0]], a[ri[2]][ci[1]], a[ri[2]][ci[2]]);
      v[row] = ((row + col) % 2 ? -minor : minor);
      norm += v[row] * v[row];
    }
    if (norm > best_norm) {
      best_norm = norm;
      for (int q = 0; q < 4; ++q) best[q] = v[q];
    }
  }
  // The largest |adj column| is prod_i |lambda - lambda_i| |v_col| >= prod / 2, and the product
  // about 4 lambda^2 (lambda - lambda_2): below 1e-2 lambda^3 (a gap to the next eigenvalue
  // under about 0.25% of lambda, H near rank 1) the rounding of lambda would show in v.
  const double floor = 1e-2 * lambda * lambda * lambda;
  if (!(best_norm > floor * floor) || !std::isfinite(best_norm)) return false;
  const double inv = 1.0 / std::sqrt(best_norm);
  const double w = best[0] * inv, qx = best[1] * inv, qy = best[2] * inv, qz = best[3] * inv;
  r[0] = 1.0 - 2.0 * (qy * qy + qz * qz);
  r[1] = 2.0 * (qx * qy - w * qz);
  r[2] = 2.0 * (qx * qz + w * qy);
  r[3] = 2.0 * (qx * qy + w * qz);
  r[4] = 1.0 - 2.0 * (qx * qx + qz * qz);
  r[5] = 2.0 * (qy * qz - w * qx);
  r[6] = 2.0 * (qx * qz - w * qy);
  r[7] = 2.0 * (qy * qz + w * qx);
  r[8] = 1.0 - 2.0 * (qx * qx + qy * qy);
  return true;
}

void Retargeter::align_on_teacher(const double* t, double* x, double* map) {
  // Kabsch about the root: the rotation R maximising trace(R H), H = sum (x_j - x_0)(t_j - t_0)^T.
  const int n = table_.joints;
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (int j = 1; j < n; ++j) {
    const Eigen::Vector3d a(x[3 * j] - x[0], x[3 * j + 1] - x[1], x[3 * j + 2] - x[2]);
    const Eigen::Vector3d b(t[3 * j] - t[0], t[3 * j + 1] - t[1], t[3 * j + 2] - t[2]);
    h.noalias() += a * b.transpose();
  }
  const Eigen::Vector3d root(x[0], x[1], x[2]);
  {
    // The rule on a warm stream: a proper best fit, from Horn's quaternion (a few scalar Newton
    // steps instead of the polar iteration's chain of 3 x 3 inverses and square roots).
    double bound = 0.0;
    for (int j = 1; j < n; ++j) {
      for (int k = 0; k < 3; ++k) {
        const double a = x[3 * j + k] - x[k], b = t[3 * j + k] - t[k];
        bound += 0.5 * (a * a + b * b);
      }
    }
    double hr[9], r[9];
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) hr[3 * i + k] = h(i, k);
    if (detail::proper_best_rotation(hr, bound, r)) {
      for (int i = 0; i < 9; ++i) map[i] = r[i];
      for (int j = 0; j < n; ++j) {
        const double a[3] = {x[3 * j] - root[0], x[3 * j + 1] - root[1], x[3 * j + 2] - root[2]};
        for (int k = 0; k < 3; ++k) x[3 * j + k] = t[k] + r[3 * k] * a[0] + r[3 * k + 1] * a[1] + r[3 * k + 2] * a[2];
      }
      return;
    }
  }
  // A proper best fit (det H > 0, the rule on a warm stream): R = V U^T is the orthogonal polar
  // factor of H^T, reached by the scaled Newton iteration X <- (g X + X^-T / g) / 2 (Higham) in
  // a few 3 x 3 inverses instead of a Jacobi SVD. A reflection, or an iteration that does not
  // settle (H near singular), goes through the SVD below.
  if (h.determinant() > 0.0) {
    Eigen::Matrix3d q = h.transpose();
    bool settled = false;
    for (int it = 0; it < 30 && !settled; ++it) {
      const Eigen::Matrix3d inv_t = q.inverse().transpose();
      // The scaling (|X^-T| / |X|)^(1/2) speeds the first steps; from the squared norms (one
      // square root fewer in the iteration's chain of dependent square roots and divisions).
      const double g = it < 8 ? std::sqrt(std::sqrt(inv_t.squaredNorm() / q.squaredNorm())) : 1.0;
      const Eigen::Matrix3d next = 0.5 * (g * q + inv_t * (1.0 / g));
      settled = (next - q).squaredNorm() <= 1e-28 * next.squaredNorm();  // |next - q| <= 1e-14 |next|
      q = next;
    }
    if (settled && std::isfinite(q.sum())) {
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) map[3 * i + k] = q(i, k);
      for (int j = 0; j < n; ++j) {
        const Eigen::Vector3d a(x[3 * j] - root[0], x[3 * j + 1] - root[1], x[3 * j + 2] - root[2]);
        const Eigen::Vector3d b = q * a;
        for (int k = 0; k < 3; ++k) x[3 * j + k] = t[k] + b[k];
      }
      return;
    }
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
    // Relative to the root, the flip negates and r rotates: the map is -r.
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) map[3 * i + k] = -r(i, k);
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
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) map[3 * i + k] = r(i, k);
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
    worst = std::max(worst, std::fabs(len - student_lengths_[j]) * inverse_lengths_[j]);
  }
  return worst;
}

namespace {
// joints x 3 row-major <-> SoA (all x, all y, all z): the solver works in SoA.
void to_soa(int n, const double* rows, double* soa) {
  for (int j = 0; j < n; ++j)
    for (int k = 0; k < 3; ++k) soa[k * n + j] = rows[3 * j + k];
}
void from_soa(int n, const double* soa, double* rows) {
  for (int j = 0; j < n; ++j)
    for (int k = 0; k < 3; ++k) rows[3 * j + k] = soa[k * n + j];
}
}  // namespace

double Retargeter::paper_stress(const double* rows) {
  to_soa(table_.joints, rows, ws_->soa.data());
  return stress(paper_instance(), ws_->soa.data(), nullptr);
}

const RetargetReport& Retargeter::retarget(const double* teacher, double* ghost) {
  return retarget(teacher, ghost, own_);
}

const RetargetReport& Retargeter::retarget(const double* teacher, double* ghost, Workspace& ws) {
  const int n = table_.joints, m = table_.pairs;
  ws_ = &ws;
  double* const teacher_lengths = ws.teacher_lengths.data();
  double* const soa = ws.soa.data();
  double* const x_cold = ws.x_cold.data();
  double* const predicted = ws.predicted.data();
  // 1. Targets: delta = tau_student * |t_u - t_v| / tau_teacher (tau_teacher of this frame),
  // row by row over SoA teacher positions so the loop reads contiguous memory.
  bone_lengths(table_, teacher, teacher_lengths);
  path_weights(table_, teacher_lengths, ws.cumulative.data(), ws.tau_teacher.data());
  to_soa(n, teacher, soa);
  detail::targets(n, soa, tau_student_.data(), ws.tau_teacher.data(), delta_.data());
  const StressInstance solve{n, m, table_.u.data(), table_.v.data(), weight_.data(), delta_.data()};
  const bool paper_weights = options_.bone_weight == 1.0;

  // 2. Start point and SPG (in SoA layout). Warm: the previous optimum moved by what the FK
  // baseline moved since the previous frame (first-order prediction of this frame's optimum).
  std::copy(baseline_.begin(), baseline_.end(), previous_baseline_.begin());
  forward_kinematics_baseline(teacher, baseline_.data());
  report_ = RetargetReport{};
  if (options_.diagnostics) report_.stress_baseline = paper_stress(baseline_.data());
  report_.warm = options_.warm_start && has_previous_;
  if (!report_.warm) {
    to_soa(n, baseline_.data(), x_.data());
  } else if (options_.predict) {
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < 3; ++k) x_[k * n + j] += baseline_[3 * j + k] - previous_baseline_[3 * j + k];
  }
  SpgOptions spg = options_.solver;
  if (report_.warm && spg.initial_step <= 0.0) spg.initial_step = last_step_;
  spg.keep_curvature = report_.warm && options_.warm_curvature;
  if (report_.warm) spg.gradient_tolerance *= options_.warm_tolerance_factor;
  if (!paper_weights) report_.stress_start = stress(paper_instance(), x_.data(), nullptr);
  // In a caller's workspace the solves run in its buffers too (the warm solver keeps its pairs).
  const bool shared = &ws != &own_;
  SpgResult r = shared ? solver_.minimize(solve, x_.data(), spg, ws.solve, false) : solver_.minimize(solve, x_.data(), spg);
  report_.iterations = r.iterations;
  report_.evaluations = r.evaluations;
  // Basin check: a warm stream can follow a local minimum that the motion slowly makes worse
  // (on CMU dance/wash clips, up to 3x the stress the FK-started solve reaches, then a jump when
  // it vanishes). Every cold_check_interval warm frames, also solve from the FK baseline and
  // keep whichever optimum is lower.
  if (report_.warm && options_.cold_check_interval > 0 && ++warm_frames_ >= options_.cold_check_interval) {
    warm_frames_ = 0;
    to_soa(n, baseline_.data(), x_cold);
    SpgOptions cold = options_.solver;
    if (options_.cold_check_probe > 0) cold.max_iterations = std::min(cold.max_iterations, options_.cold_check_probe);
    SpgResult rc = shared ? cold_solver_.minimize(solve, x_cold, cold, ws.solve, true)
                          : cold_solver_.minimize(solve, x_cold, cold);
    report_.iterations += rc.iterations;
    report_.evaluations += rc.evaluations;
    if (!rc.converged && rc.iterations < options_.solver.max_iterations && rc.stress < r.stress) {
      // Below the warm optimum already: a lower basin; the solve goes on to convergence.
      SpgOptions rest = options_.solver;
      rest.max_iterations = options_.solver.max_iterations - rc.iterations;
      rest.initial_step = rc.last_step;
      rest.keep_curvature = true;  // the probe's own pairs
      const SpgResult more = shared ? cold_solver_.minimize(solve, x_cold, rest, ws.solve, true)
                                    : cold_solver_.minimize(solve, x_cold, rest);
      report_.iterations += more.iterations;
      report_.evaluations += more.evaluations;
      rc.stress = more.stress;
      rc.converged = more.converged;
      rc.last_step = more.last_step;
    }
    report_.cold_checked = true;
    if (rc.stress < r.stress * (1.0 - 1e-6)) {
      std::copy(x_cold, x_cold + 3 * n, x_.begin());
      r.stress = rc.stress;
      r.converged = rc.converged;
      r.last_step = rc.last_step;
      report_.switched = true;
      solver_.forget_curvature();  // the warm solve's pairs describe the basin it left
    }
  }
  last_step_ = r.last_step;
  report_.converged = r.converged;
  if (paper_weights) report_.stress_start = r.stress_start;
  report_.stress = paper_weights ? r.stress : stress(paper_instance(), x_.data(), nullptr);

  // 3. Rigid placement on the teacher; this aligned optimum is also the next warm start. The
  // prediction of this frame from the previous optimum (in the same aligned frame) measures
  // how far the solve moved the joints.
  const bool had_previous = has_previous_;
  double jump = 0.0;
  if (had_previous) {
    for (int i = 0; i < 3 * n; ++i) predicted[i] = solved_[i] + baseline_[i] - previous_baseline_[i];
  }
  from_soa(n, x_.data(), solved_.data());
  double map[9];
  align_on_teacher(teacher, solved_.data(), map);
  // The curvature pairs are differences of points and of gradients: they move with the optimum.
  solver_.rotate_curvature(map);
  to_soa(n, solved_.data(), x_.data());
  has_previous_ = true;
  report_.max_bone_error_solved = max_bone_error(solved_.data());
  if (had_previous && report_.warm) {
    for (int j = 0; j < n; ++j) {
      double d2 = 0.0;
      for (int k = 0; k < 3; ++k) d2 += (solved_[3 * j + k] - predicted[3 * j + k]) * (solved_[3 * j + k] - predicted[3 * j + k]);
      jump = std::max(jump, std::sqrt(d2));
    }
  }
  report_.solve_jump = jump;

  // Cross-fade a basin change: the optimum itself jumps (the objective's global minimum moves
  // from one local minimum to another), the output glides from the prediction to it.
  const double* shown = solved_.data();
  if (options_.fade_frames > 0 && report_.warm) {
    if (jump > options_.jump_fraction * max_tau_student_) {
      for (int i = 0; i < 3 * n; ++i) fade_[i] = predicted[i] - solved_[i] + (fade_left_ > 0 ? fade_[i] * fade_left_ / (options_.fade_frames + 1.0) : 0.0);
      fade_left_ = options_.fade_frames;
      report_.faded = true;
    }
    if (fade_left_ > 0) {
      const double weight = fade_left_ / (options_.fade_frames + 1.0);
      for (int i = 0; i < 3 * n; ++i) shown_[i] = solved_[i] + weight * fade_[i];
      --fade_left_;
      shown = shown_.data();
    }
  } else if (!report_.warm) {
    fade_left_ = 0;
  }

  // 4. Bone-length restoring step.
  if (options_.restore_bone_lengths) {
    restore_bones(teacher, shown, ghost);
  } else {
    std::copy(shown, shown + 3 * n, ghost);
  }
  report_.max_bone_error = max_bone_error(ghost);
  if (options_.diagnostics) report_.stress_output = paper_stress(ghost);
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
