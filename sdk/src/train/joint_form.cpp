#include "train/joint_form.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <Eigen/Dense>

#include "common/error.hpp"
#include "gpd/gpd.hpp"

namespace kata::train {
namespace {

constexpr int kFormJoints = 15;  // GPD joints 1..15 (the hip is the local frame's origin)
constexpr int kAxes = 3;
// The anchor: the Hip-Chest distance (a bone length, constant for a body), shifted by -kAnchor
// so that it dominates |x'| and the unit-length step divides every pose by the same norm.
constexpr int kAnchorDim = gpd::kOffsetJJd;
constexpr double kAnchor = 1e5;

int position_dim(int joint, int axis) { return gpd::kOffsetJc + 3 * joint + axis; }
int kinetic_dim(int joint, int term, int axis) {  // term 1: velocity, 2: acceleration
  return gpd::kOffsetJk + 6 * joint + 3 * (term - 1) + axis;
}
float term_value(const float* x, int joint, int term, int axis) {
  return term == 0 ? x[position_dim(joint, axis)] : x[kinetic_dim(joint, term, axis)];
}

// Per pair and axis, the Gram matrix of the joints' difference vectors u (terms x terms).
struct Grams {
  int terms = 3;
  std::vector<Eigen::Matrix3d> g;  // pair-major: g[n * kAxes + axis]
};

Grams pair_grams(const PairRows& pairs, int terms) {
  Grams out;
  out.terms = terms;
  out.g.assign(pairs.label.size() * kAxes, Eigen::Matrix3d::Zero());
  for (size_t n = 0; n < pairs.label.size(); ++n)
    for (int axis = 0; axis < kAxes; ++axis) {
      Eigen::Matrix3d& g = out.g[n * kAxes + static_cast<size_t>(axis)];
      for (int j = 0; j < kFormJoints; ++j) {
        Eigen::Vector3d u = Eigen::Vector3d::Zero();
        for (int t = 0; t < terms; ++t)
          u(t) = static_cast<double>(term_value(pairs.a[n], j, t, axis)) - term_value(pairs.b[n], j, t, axis);
        g += u * u.transpose();
      }
    }
  return out;
}

// Parameters: per axis the lower triangle of Theta (terms (terms + 1) / 2), then log slope and
// offset. L = S Theta with S = diag(1 / rms of each term), a fixed preconditioner.
struct Layout {
  int terms, per_axis, size;
  explicit Layout(int t) : terms(t), per_axis(t * (t + 1) / 2), size(kAxes * t * (t + 1) / 2 + 2) {}
};

Eigen::Matrix3d unpack(const Layout& l, const Eigen::VectorXd& p, int axis) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  int k = axis * l.per_axis;
  for (int r = 0; r < l.terms; ++r)
    for (int c = 0; c <= r; ++c) m(r, c) = p(k++);
  return m;
}

double trace_product(const Eigen::Matrix3d& g, const Eigen::Matrix3d& m) { return (g.cwiseProduct(m)).sum(); }

double softplus(double z) { return z > 0 ? z + std::log1p(std::exp(-z)) : std::log1p(std::exp(z)); }
double sigmoid(double z) { return z >= 0 ? 1.0 / (1.0 + std::exp(-z)) : std::exp(z) / (1.0 + std::exp(z)); }

// Mean logistic loss of the label on log d^2 and its gradient; grams already preconditioned.
double loss_and_gradient(const Layout& l, const Grams& gr, const std::vector<int>& label, const Eigen::VectorXd& p,
                         Eigen::VectorXd* grad) {
  const size_t n = label.size();
  std::array<Eigen::Matrix3d, kAxes> theta, m, h;
  for (int a = 0; a < kAxes; ++a) {
    theta[a] = unpack(l, p, a);
    m[a] = theta[a] * theta[a].transpose();
    h[a].setZero();
  }
  const double slope = std::exp(p(l.size - 2)), offset = p(l.size - 1);
  double loss = 0.0, g_slope = 0.0, g_offset = 0.0;
  for (size_t i = 0; i < n; ++i) {
    double d = 0.0;
    for (int a = 0; a < kAxes; ++a) d += trace_product(gr.g[i * kAxes + static_cast<size_t>(a)], m[a]);
    d = std::max(d, 1e-300);
    const double log_d = std::log(d);
    const double z = offset - slope * log_d;
    loss += label[i] == 1 ? softplus(-z) : softplus(z);
    const double r = sigmoid(z) - (label[i] == 1 ? 1.0 : 0.0);  // d loss / d z
    g_offset += r;
    g_slope += -r * slope * log_d;
    const double c = -r * slope / d;  // d loss / d d
    for (int a = 0; a < kAxes; ++a) h[a] += c * gr.g[i * kAxes + static_cast<size_t>(a)];
  }
  const double inv_n = 1.0 / static_cast<double>(n);
  if (grad) {
    grad->setZero(l.size);
    for (int a = 0; a < kAxes; ++a) {
      const Eigen::Matrix3d gt = 2.0 * inv_n * h[a] * theta[a];  // d tr(G Theta Theta^T) = 2 G Theta
      int k = a * l.per_axis;
      for (int r = 0; r < l.terms; ++r)
        for (int c = 0; c <= r; ++c) (*grad)(k++) = gt(r, c);
    }
    (*grad)(l.size - 2) = g_slope * inv_n;
    (*grad)(l.size - 1) = g_offset * inv_n;
  }
  return loss * inv_n;
}

}  // namespace

JointForm fit_joint_form(const PairRows& pairs, const JointFormOptions& options) {
  const int terms = options.acceleration ? 3 : 2;
  const bool has_pos = std::find(pairs.label.begin(), pairs.label.end(), 1) != pairs.label.end();
  const bool has_neg = std::find(pairs.label.begin(), pairs.label.end(), 0) != pairs.label.end();
  if (!has_pos || !has_neg)
    throw Error(ErrorKind::kInvalidArgument, "joint form: the pairs need both labels (good and bad transitions)");
  Grams gr = pair_grams(pairs, terms);
  // Preconditioner: each term scaled to unit mean square over pairs, joints and axes.
  Eigen::Vector3d rms = Eigen::Vector3d::Ones();
  for (int t = 0; t < terms; ++t) {
    double s = 0.0;
    for (const auto& g : gr.g) s += g(t, t);
    s /= static_cast<double>(gr.g.size());
    rms(t) = s > 0 ? std::sqrt(s) : 1.0;
  }
  Eigen::Matrix3d precondition = Eigen::Matrix3d::Identity();
  for (int t = 0; t < terms; ++t) precondition(t, t) = 1.0 / rms(t);
  for (auto& g : gr.g) g = precondition * g * precondition;

  // Start: every term and axis weighed equally after preconditioning, slope 1, offset at the
  // median log d^2 (half the pairs on each side).
  const Layout l(terms);
  Eigen::VectorXd p = Eigen::VectorXd::Zero(l.size);
  for (int a = 0; a < kAxes; ++a) {
    int k = a * l.per_axis;
    for (int r = 0; r < terms; ++r)
      for (int c = 0; c <= r; ++c) p(k++) = r == c ? 1.0 / std::sqrt(static_cast<double>(terms * kAxes)) : 0.0;
  }
  {
    std::vector<double> logs(pairs.label.size());
    for (size_t i = 0; i < logs.size(); ++i) {
      double d = 0.0;
      for (int a = 0; a < kAxes; ++a) {
        const Eigen::Matrix3d th = unpack(l, p, a);
        d += trace_product(gr.g[i * kAxes + static_cast<size_t>(a)], th * th.transpose());
      }
      logs[i] = std::log(std::max(d, 1e-300));
    }
    std::nth_element(logs.begin(), logs.begin() + static_cast<std::ptrdiff_t>(logs.size() / 2), logs.end());
    p(l.size - 1) = logs[logs.size() / 2];
  }

  // BFGS with a backtracking (Armijo) line search.
  Eigen::VectorXd g(l.size), g_new(l.size);
  double f = loss_and_gradient(l, gr, pairs.label, p, &g);
  Eigen::MatrixXd inv_h = Eigen::MatrixXd::Identity(l.size, l.size);
  int it = 0;
  for (; it < options.max_iterations; ++it) {
    Eigen::VectorXd dir = -inv_h * g;
    if (dir.dot(g) >= 0) {  // not a descent direction: restart from steepest descent
      inv_h.setIdentity();
      dir = -g;
    }
    double step = 1.0, f_new = f;
    Eigen::VectorXd p_new = p;
    bool moved = false;
    for (int k = 0; k < 60; ++k, step *= 0.5) {
      p_new = p + step * dir;
      f_new = loss_and_gradient(l, gr, pairs.label, p_new, &g_new);
      if (std::isfinite(f_new) && f_new <= f + 1e-4 * step * dir.dot(g)) {
        moved = true;
        break;
      }
    }
    if (!moved) break;
    const Eigen::VectorXd s = p_new - p, y = g_new - g;
    const double sy = s.dot(y);
    const double improvement = f - f_new;
    p = p_new;
    g = g_new;
    f = f_new;
    if (sy > 1e-300) {
      const double rho = 1.0 / sy;
      const Eigen::MatrixXd e = Eigen::MatrixXd::Identity(l.size, l.size) - rho * s * y.transpose();
      inv_h = e * inv_h * e.transpose() + rho * s * s.transpose();
    }
    if (improvement < options.tolerance * std::max(1.0, std::abs(f)) || g.norm() < 1e-12) break;
  }

  JointForm out;
  out.terms = terms;
  out.loss = f;
  out.iterations = it;
  out.slope = std::exp(p(l.size - 2));
  out.offset = p(l.size - 1);
  // L = S Theta (raw units); scaled so that its largest entry is 1 (d's scale is arbitrary: the
  // offset absorbs it, offset' = offset + slope log(c^2) for L' = L / c).
  double largest = 0.0;
  for (int a = 0; a < kAxes; ++a) {
    out.lower[static_cast<size_t>(a)] = precondition * unpack(l, p, a);
    largest = std::max(largest, out.lower[static_cast<size_t>(a)].cwiseAbs().maxCoeff());
  }
  if (!(largest > 0.0) || !std::isfinite(largest))
    throw Error(ErrorKind::kInvalidArgument, "joint form: the fit did not converge (no finite form)");
  for (auto& m : out.lower) m /= largest;
  out.offset += out.slope * std::log(largest * largest);
  return out;
}

double joint_form_distance2(const JointForm& form, const float* a, const float* b) {
  double d = 0.0;
  for (int axis = 0; axis < kAxes; ++axis) {
    const Eigen::Matrix3d& l = form.lower[static_cast<size_t>(axis)];
    for (int j = 0; j < kFormJoints; ++j) {
      Eigen::Vector3d u = Eigen::Vector3d::Zero();
      for (int t = 0; t < form.terms; ++t)
        u(t) = static_cast<double>(term_value(a, j, t, axis)) - term_value(b, j, t, axis);
      d += (l.transpose() * u).squaredNorm();
    }
  }
  return d;
}

metric::Model joint_form_model(const JointForm& form, const Normaliser& ranges, gpd::Stencil stencil) {
  metric::Model m;
  m.stencil = stencil;
  m.normalisation = metric::Normalisation::kBlockBalanced;  // per-dimension shift/scale
  m.min = ranges.min;
  m.max = ranges.max;
  m.shift.assign(gpd::kDims, 0.0f);
  m.scale.assign(gpd::kDims, 0.0f);
  for (int j = 0; j < kFormJoints; ++j)
    for (int axis = 0; axis < kAxes; ++axis) {
      m.scale[static_cast<size_t>(position_dim(j, axis))] = 1.0f;
      for (int t = 1; t < form.terms; ++t) m.scale[static_cast<size_t>(kinetic_dim(j, t, axis))] = 1.0f;
    }
  m.shift[kAnchorDim] = static_cast<float>(-kAnchor);
  m.scale[kAnchorDim] = 1.0f;
  // The unit-length step divides by |x'| = A (1 + O(|x_raw|^2 / A^2)): W = A L undoes it.
  m.rank = kFormJoints * kAxes * form.terms;
  m.w.assign(static_cast<size_t>(gpd::kDims) * static_cast<size_t>(m.rank), 0.0f);
  int col = 0;
  for (int j = 0; j < kFormJoints; ++j)
    for (int axis = 0; axis < kAxes; ++axis) {
      const Eigen::Matrix3d& l = form.lower[static_cast<size_t>(axis)];
      for (int c = 0; c < form.terms; ++c, ++col)
        for (int t = 0; t < form.terms; ++t) {
          const int dim = t == 0 ? position_dim(j, axis) : kinetic_dim(j, t, axis);
          m.w[static_cast<size_t>(col) * gpd::kDims + static_cast<size_t>(dim)] = static_cast<float>(kAnchor * l(t, c));
        }
    }
  return m;
}

std::string joint_form_json(const JointForm& form) {
  std::ostringstream s;
  s.precision(6);
  s << "{\"terms\":\"" << (form.terms == 3 ? "p,v,a" : "p,v") << "\"";
  const char* names[kAxes] = {"x", "y", "z"};
  for (int a = 0; a < kAxes; ++a) {
    const Eigen::Matrix3d m = form.form(a);
    s << ",\"M_" << names[a] << "\":[";
    for (int r = 0; r < form.terms; ++r) {
      s << (r ? "," : "") << "[";
      for (int c = 0; c < form.terms; ++c) s << (c ? "," : "") << m(r, c);
      s << "]";
    }
    s << "]";
  }
  s << ",\"slope\":" << form.slope << ",\"offset\":" << form.offset << ",\"logistic_loss\":" << form.loss
    << ",\"iterations\":" << form.iterations << "}";
  return s.str();
}

}  // namespace kata::train
