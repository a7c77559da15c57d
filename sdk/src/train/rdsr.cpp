#include "train/rdsr.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "common/error.hpp"
#include "gpd/gpd.hpp"
#include "train/linalg.hpp"

namespace kata::train {
namespace {

constexpr int kBlockStart[10] = {gpd::kOffsetJc,  gpd::kOffsetJJd, gpd::kOffsetJJo, gpd::kOffsetJLd, gpd::kOffsetLLa,
                                 gpd::kOffsetJPd, gpd::kOffsetLPa, gpd::kOffsetPPa, gpd::kOffsetJk,  gpd::kDims};

std::string fmt(const char* f, double a, double b = 0, double c = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b, c);
  return buf;
}

}  // namespace

void Normaliser::apply(const float* x, double* out) const {
  double sumsq = 0.0;
  for (int i = 0; i < gpd::kDims; ++i) {
    double v;
    if (kind == metric::Normalisation::kBlockBalanced) {
      v = (static_cast<double>(x[i]) - shift[i]) * scale[i];
    } else {
      const double range = static_cast<double>(max[i]) - min[i];
      v = range > 0 ? (static_cast<double>(x[i]) - min[i]) / range : 0.0;
    }
    out[i] = v;
    sumsq += v * v;
  }
  if (sumsq > 0) {
    const double inv = 1.0 / std::sqrt(sumsq);
    for (int i = 0; i < gpd::kDims; ++i) out[i] *= inv;
  }
}

Eigen::VectorXd Normaliser::operator()(const float* x) const {
  Eigen::VectorXd v(gpd::kDims);
  apply(x, v.data());
  return v;
}

void weigh_kinetics(Normaliser& n, double gain) {
  if (!(gain > 0.0) || !std::isfinite(gain))
    throw Error(ErrorKind::kInvalidArgument, "normalisation: the kinetic weight must be finite and > 0");
  if (n.kind == metric::Normalisation::kMinMaxUnit) {
    n.shift.assign(gpd::kDims, 0.0f);
    n.scale.assign(gpd::kDims, 0.0f);
    for (int i = 0; i < gpd::kDims; ++i) {
      const double range = static_cast<double>(n.max[i]) - n.min[i];
      n.shift[i] = n.min[i];
      n.scale[i] = range > 0 ? static_cast<float>(1.0 / range) : 0.0f;
    }
    n.kind = metric::Normalisation::kBlockBalanced;
  }
  for (int i = gpd::kOffsetJk; i < gpd::kDims; ++i) n.scale[i] = static_cast<float>(n.scale[i] * gain);
}

Normaliser fit_normaliser(const std::vector<const float*>& rows, metric::Normalisation kind) {
  if (rows.empty()) throw Error(ErrorKind::kInvalidArgument, "normalisation: no training poses");
  Normaliser n;
  n.kind = kind;
  n.min.assign(gpd::kDims, 0.0f);
  n.max.assign(gpd::kDims, 0.0f);
  std::vector<double> mean(gpd::kDims, 0.0), m2(gpd::kDims, 0.0);
  for (int i = 0; i < gpd::kDims; ++i) n.min[i] = n.max[i] = rows[0][i];
  for (const float* r : rows)
    for (int i = 0; i < gpd::kDims; ++i) {
      n.min[i] = std::min(n.min[i], r[i]);
      n.max[i] = std::max(n.max[i], r[i]);
      mean[i] += r[i];
    }
  if (kind == metric::Normalisation::kBlockBalanced) {
    for (double& m : mean) m /= static_cast<double>(rows.size());
    for (const float* r : rows)
      for (int i = 0; i < gpd::kDims; ++i) m2[i] += (r[i] - mean[i]) * (r[i] - mean[i]);
    n.shift.resize(gpd::kDims);
    n.scale.resize(gpd::kDims);
    for (int b = 0; b < 9; ++b) {
      // z-score each dimension; each block then gets total variance 1 (weight 1/sqrt(#non-constant)).
      int live = 0;
      for (int i = kBlockStart[b]; i < kBlockStart[b + 1]; ++i)
        if (m2[i] / static_cast<double>(rows.size()) > 1e-12) ++live;
      const double wb = live ? 1.0 / std::sqrt(static_cast<double>(live)) : 0.0;
      for (int i = kBlockStart[b]; i < kBlockStart[b + 1]; ++i) {
        const double var = m2[i] / static_cast<double>(rows.size());
        n.shift[i] = static_cast<float>(mean[i]);
        n.scale[i] = var > 1e-12 ? static_cast<float>(wb / std::sqrt(var)) : 0.0f;
      }
    }
  }
  return n;
}

Precision best_threshold(const std::vector<double>& distance, const std::vector<int>& label) {
  if (distance.size() != label.size()) throw Error(ErrorKind::kInvalidArgument, "precision: sizes differ");
  Precision p;
  p.total = static_cast<int>(distance.size());
  if (distance.empty()) return p;
  std::vector<size_t> order(distance.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return distance[a] < distance[b]; });
  // delta below every distance: all predicted negative.
  int correct = 0;
  for (int l : label) correct += (l == 0);
  int best = correct;
  double best_delta = distance[order[0]] - 1.0;
  size_t k = 0;
  while (k < order.size()) {
    // Move delta past the group of equal distances starting at k.
    const double v = distance[order[k]];
    size_t e = k;
    while (e < order.size() && distance[order[e]] == v) {
      correct += label[order[e]] == 1 ? 1 : -1;
      ++e;
    }
    if (correct > best) {
      best = correct;
      best_delta = e < order.size() ? 0.5 * (v + distance[order[e]]) : v + 1.0;
    }
    k = e;
  }
  p.correct = best;
  p.precision = static_cast<double>(best) / static_cast<double>(p.total);
  p.threshold = best_delta;
  return p;
}

Eigen::MatrixXd within_scatter(const Eigen::MatrixXd& pa, const Eigen::MatrixXd& pb, int threads) {
  const Eigen::MatrixXd d = pa - pb;
  return outer_product(d, threads);
}

Eigen::MatrixXd laplacian_scatter(const Eigen::MatrixXd& x, const CsrMatrix& codes, int threads) {
  Eigen::MatrixXd r = x;  // column i: x_i - X a_i
  for (int i = 0; i < codes.rows; ++i)
    for (int64_t k = codes.row_ptr[i]; k < codes.row_ptr[i + 1]; ++k) r.col(i) -= codes.val[k] * x.col(codes.col[k]);
  return outer_product(r, threads);
}

Eigen::MatrixXd centered_scatter(const Eigen::MatrixXd& x, int threads) {
  const Eigen::VectorXd mean = x.rowwise().mean();
  const Eigen::MatrixXd c = x.colwise() - mean;
  return outer_product(c, threads);
}

std::vector<int> block_dimensions(const std::vector<int>& blocks) {
  std::vector<int> dims;
  if (blocks.empty()) {
    dims.resize(gpd::kDims);
    std::iota(dims.begin(), dims.end(), 0);
    return dims;
  }
  std::vector<int> sorted = blocks;
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < sorted.size(); ++i) {
    if (sorted[i] < 1 || sorted[i] > 9)
      throw Error(ErrorKind::kInvalidArgument, "rdsr: GPD block " + std::to_string(sorted[i]) + " is not in 1..9");
    if (i > 0 && sorted[i] == sorted[i - 1])
      throw Error(ErrorKind::kInvalidArgument, "rdsr: GPD block " + std::to_string(sorted[i]) + " named twice");
    for (int k = kBlockStart[sorted[i] - 1]; k < kBlockStart[sorted[i]]; ++k) dims.push_back(k);
  }
  return dims;
}

double projected_distance(const Eigen::MatrixXd& w, const Eigen::VectorXd& x, const Eigen::VectorXd& y) {
  return (w.transpose() * (x - y)).norm();
}

RdsrResult train_rdsr(const Eigen::MatrixXd& x, const Eigen::MatrixXd& pa, const Eigen::MatrixXd& pb,
                      const RdsrOptions& opt, const Log& log, const Eigen::MatrixXd& na, const Eigen::MatrixXd& nb) {
  const Eigen::Index d = pa.rows();
  if (pb.rows() != d || pa.cols() != pb.cols() || (x.cols() > 0 && x.rows() != d))
    throw Error(ErrorKind::kInvalidArgument, "rdsr: inconsistent matrix sizes");
  // W's support (RdsrOptions::blocks): the scatter matrices are cut to these rows and columns
  // and the solution put back on them, zero elsewhere.
  const bool restricted = !opt.blocks.empty();
  if (restricted && d != gpd::kDims)
    throw Error(ErrorKind::kInvalidArgument, "rdsr: blocks need whole GPD vectors (" + std::to_string(gpd::kDims) + " rows)");
  const std::vector<int> dims = restricted ? block_dimensions(opt.blocks) : std::vector<int>();
  const Eigen::Index d_solve = restricted ? static_cast<Eigen::Index>(dims.size()) : d;
  auto cut = [&](const Eigen::MatrixXd& m) { return restricted ? Eigen::MatrixXd(m(dims, dims)) : m; };
  auto put_back = [&](const Eigen::MatrixXd& w) {
    if (!restricted) return w;
    Eigen::MatrixXd full = Eigen::MatrixXd::Zero(d, w.cols());
    full(dims, Eigen::all) = w;
    return full;
  };
  if (opt.rank < 1 || opt.rank > d_solve) throw Error(ErrorKind::kInvalidArgument, "rdsr: rank out of range");
  if (pa.cols() == 0 && x.cols() == 0) throw Error(ErrorKind::kInvalidArgument, "rdsr: no data");
  RdsrResult res;
  auto say = [&](const std::string& s) {
    if (log) log(s);
  };
  using clock = std::chrono::steady_clock;
  auto stage_start = clock::now();
  auto stage = [&](const std::string& name) {
    const double s = std::chrono::duration<double>(clock::now() - stage_start).count();
    res.stages.push_back({name, s});
    say("  [stage] " + name + fmt(": %.2f s", s));
    stage_start = clock::now();
  };

  const Eigen::MatrixXd sw = cut(within_scatter(pa, pb, opt.threads));
  res.trace_sw = sw.trace();
  stage("S_W (eq. 13)");
  if (x.cols() == 0) {
    // Eq. 46: minimise Tr(W^T S_W W): the r smallest eigenvectors of S_W.
    Eigen::MatrixXd w;
    bottom_eigen(sw, opt.rank, &w);
    res.w = put_back(w);
    ++res.eigen_solves;
    stage("eq. 46 eigenvectors");
    return res;
  }
  const Eigen::Index n = x.cols();
  say(fmt("  Gram matrix G = X^T X: %.0f x %.0f", static_cast<double>(n), static_cast<double>(n)));
  const Eigen::MatrixXd g = gram_matrix(x, opt.threads);
  stage("Gram matrix");
  LassoOptions lo = opt.lasso;
  lo.threads = opt.threads;
  auto last = clock::now();
  const CsrMatrix codes = sparse_code(g, lo, &res.coding, [&](int done, int total) {
    if (std::chrono::duration<double>(clock::now() - last).count() < 2.0 && done < total) return;
    last = clock::now();
    say(fmt("  sparse coding: %.0f / %.0f", done, total));
  });
  say(fmt("  sparse codes: mean support %.1f, max support %.0f, max KKT violation %.2e", res.coding.mean_support,
          res.coding.max_support, res.coding.max_kkt) +
      fmt(", max duality gap %.2e", res.coding.max_gap));
  stage("sparse coding (eq. 16)");
  const Eigen::MatrixXd sl = cut(laplacian_scatter(x, codes, opt.threads));
  res.trace_sl = sl.trace();
  stage("X S_L X^T (eq. 17-18)");
  Eigen::MatrixXd a = cut(centered_scatter(x, opt.threads));
  res.trace_sc = a.trace();
  stage("A = X S_C X^T (eq. 23)");
  if (restricted)
    say(fmt("  W restricted to %.0f of %.0f dimensions (the chosen GPD blocks)", static_cast<double>(d_solve),
            static_cast<double>(d)));
  if (opt.negative_weight > 0.0) {
    if (na.cols() == 0 || na.cols() != nb.cols() || na.rows() != d || nb.rows() != d)
      throw Error(ErrorKind::kInvalidArgument, "rdsr: the negative weight needs negative pairs");
    const Eigen::MatrixXd sb = cut(within_scatter(na, nb, opt.threads));
    res.trace_sb = sb.trace();
    res.beta_absolute = opt.negative_weight * res.trace_sc / std::max(res.trace_sb, 1e-300);
    a += res.beta_absolute * sb;
    say(fmt("  A += beta S_B: %.0f negative pairs, Tr(S_B) = %.6g, ", static_cast<double>(na.cols()), res.trace_sb) +
        fmt("beta = %.6g (absolute)", res.beta_absolute));
    stage("S_B (negative pairs)");
  }
  res.alpha_absolute = opt.alpha_relative ? opt.alpha * res.trace_sl / std::max(res.trace_sw, 1e-300) : opt.alpha;
  const Eigen::MatrixXd b = sl + res.alpha_absolute * sw;
  say(fmt("  Tr(X S_L X^T) = %.6g, Tr(S_W) = %.6g, alpha = %.6g (absolute)", res.trace_sl, res.trace_sw,
          res.alpha_absolute));
  stage("B = X S_L X^T + alpha S_W");
  auto progress = [&](int it, double eta) { say(fmt("  trace ratio iteration %.0f: eta = %.15g", it, eta)); };
  // Optional PCA restriction: solve in the basis P of the top principal directions.
  Eigen::MatrixXd basis;
  if (opt.pca > 0) {
    if (opt.pca < opt.rank || opt.pca > d_solve)
      throw Error(ErrorKind::kInvalidArgument, "rdsr: pca must be in [rank, d] (d: the dimensions of the blocks W may use)");
    top_eigen(a, opt.pca, &basis);
    ++res.eigen_solves;
    say(fmt("  PCA restriction: W in the span of the top %.0f principal directions", opt.pca));
    stage("PCA basis");
  }
  const bool use_pca = opt.pca > 0;
  const Eigen::MatrixXd a_s = use_pca ? Eigen::MatrixXd(basis.transpose() * a * basis) : Eigen::MatrixXd();
  const Eigen::MatrixXd sl_s = use_pca ? Eigen::MatrixXd(basis.transpose() * sl * basis) : Eigen::MatrixXd();
  const Eigen::MatrixXd sw_s = use_pca ? Eigen::MatrixXd(basis.transpose() * sw * basis) : Eigen::MatrixXd();
  const Eigen::MatrixXd& a_use = use_pca ? a_s : a;
  const Eigen::MatrixXd b_s = use_pca ? Eigen::MatrixXd(sl_s + res.alpha_absolute * sw_s) : Eigen::MatrixXd();
  const Eigen::MatrixXd& b_use = use_pca ? b_s : b;
  auto lift = [&](const Eigen::MatrixXd& v) { return put_back(use_pca ? Eigen::MatrixXd(basis * v) : v); };
  if (opt.solver == "newton" || opt.solver == "both") {
    TraceRatioResult tr = trace_ratio_newton(a_use, b_use, opt.rank, 1e-11, 100, progress, opt.solver == "both");
    res.w = lift(tr.w);
    res.eta = tr.eta;
    res.bounds = tr.bounds;
    res.eigen_solves += tr.iterations;
    say(fmt("  Newton: eta* = %.15g, f(eta*) = %.3e, ", tr.eta, tr.f_at_eta) +
        fmt("%.0f eigen-decompositions, eq. 29 lower bound %.6g", tr.iterations, tr.bounds.lower) +
        (tr.bounds.upper > 0 ? fmt(", eq. 30 upper bound %.6g", tr.bounds.upper) : std::string()));
    stage("trace ratio (Newton)");
  }
  if (opt.solver == "bisection" || opt.solver == "both") {
    TraceRatioResult tb = trace_ratio_bisection(a_use, b_use, opt.rank, 1e-10, 200, progress);
    res.eta_bisection = tb.eta;
    res.eigen_solves += tb.iterations;
    res.bounds = tb.bounds;
    say(fmt("  bisection: eta* = %.15g, f(eta*) = %.3e", tb.eta, tb.f_at_eta));
    if (opt.solver == "bisection") {
      res.w = lift(tb.w);
      res.eta = tb.eta;
    } else if (std::abs(tb.eta - res.eta) > 1e-8 * std::abs(res.eta)) {
      throw Error(ErrorKind::kInvalidArgument,
                  fmt("trace ratio: Newton (%.15g) and bisection (%.15g) disagree", res.eta, tb.eta));
    }
    stage("trace ratio (bisection)");
  }
  if (opt.solver != "newton" && opt.solver != "bisection" && opt.solver != "both")
    throw Error(ErrorKind::kInvalidArgument, "unknown trace-ratio solver '" + opt.solver + "'");
  std::vector<double> alphas = opt.sweep_alphas;
  std::vector<int> ranks = opt.sweep_ranks;
  if (alphas.empty() && !ranks.empty()) alphas.push_back(opt.alpha);
  if (ranks.empty() && !alphas.empty()) ranks.push_back(opt.rank);
  for (double al : alphas) {
    const double abs_alpha = opt.alpha_relative ? al * res.trace_sl / std::max(res.trace_sw, 1e-300) : al;
    const Eigen::MatrixXd bb = use_pca ? Eigen::MatrixXd(sl_s + abs_alpha * sw_s) : Eigen::MatrixXd(sl + abs_alpha * sw);
    for (int rk : ranks) {
      if (rk < 1 || rk > a_use.rows()) throw Error(ErrorKind::kInvalidArgument, "rdsr: sweep rank out of range");
      TraceRatioResult tr = trace_ratio_newton(a_use, bb, rk, 1e-11, 100, {}, false);
      res.variants.push_back({al, abs_alpha, tr.eta, rk, lift(tr.w)});
      res.eigen_solves += tr.iterations;
      say(fmt("  sweep alpha = %.6g, r = %.0f: ", al, rk) + fmt("eta* = %.12g (%.0f decompositions)", tr.eta, tr.iterations));
    }
  }
  if (!alphas.empty()) stage("sweep");
  return res;
}

}  // namespace kata::train
