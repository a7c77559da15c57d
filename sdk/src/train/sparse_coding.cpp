#include "train/sparse_coding.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <numeric>
#include <thread>

#include <Eigen/Cholesky>

#include "common/error.hpp"

namespace kata::train {
namespace {

double soft(double v, double t) {
  if (v > t) return v - t;
  if (v < -t) return v + t;
  return 0.0;
}

double sign(double v) { return v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0); }

// KKT violation of one coordinate from its residual correlation r_j = (b - G a)_j.
double coord_violation(double r, double a, double gamma) {
  if (a != 0.0) return std::abs(2.0 * r - gamma * sign(a));
  return std::max(0.0, std::abs(2.0 * r) - gamma);
}

}  // namespace

double lasso_kkt_violation(const LassoProblem& p, double gamma, const std::vector<int>& index,
                           const std::vector<double>& value) {
  const Eigen::MatrixXd& g = *p.gram;
  const int n = static_cast<int>(g.rows());
  Eigen::VectorXd r = Eigen::Map<const Eigen::VectorXd>(p.b, n);
  Eigen::VectorXd a = Eigen::VectorXd::Zero(n);
  for (size_t k = 0; k < index.size(); ++k) {
    a[index[k]] = value[k];
    r -= value[k] * g.col(index[k]);
  }
  double worst = 0.0;
  for (int j = 0; j < n; ++j) {
    if (j == p.exclude) {
      if (a[j] != 0.0) worst = std::max(worst, std::abs(a[j]) * 1e300);  // must be exactly zero
      continue;
    }
    worst = std::max(worst, coord_violation(r[j], a[j], gamma));
  }
  return worst;
}

double lasso_objective(const LassoProblem& p, double gamma, const std::vector<int>& index,
                       const std::vector<double>& value) {
  const Eigen::MatrixXd& g = *p.gram;
  double ab = 0.0, aga = 0.0, l1 = 0.0;
  for (size_t k = 0; k < index.size(); ++k) {
    ab += value[k] * p.b[index[k]];
    l1 += std::abs(value[k]);
    for (size_t m = 0; m < index.size(); ++m) aga += value[k] * value[m] * g(index[k], index[m]);
  }
  return p.yy - 2.0 * ab + aga + gamma * l1;
}

LassoSolution solve_lasso(const LassoProblem& p, const LassoOptions& opt, LassoWorkspace& ws) {
  const Eigen::MatrixXd& g = *p.gram;
  const int n = static_cast<int>(g.rows());
  const double gamma = opt.gamma;
  const double half = 0.5 * gamma;
  ws.grad.assign(n, 0.0);
  ws.dense_a.assign(n, 0.0);
  std::vector<double>& a = ws.dense_a;
  std::vector<double>& r = ws.grad;  // r = b - G a
  std::vector<int> work;             // working set
  std::vector<char> in_work(n, 0);
  LassoSolution sol;

  Eigen::VectorXd aw, bw, cw, z;
  for (int outer = 0; outer <= opt.max_outer; ++outer) {
    // Full residual correlations from the current support.
    for (int j = 0; j < n; ++j) r[j] = p.b[j];
    for (int k : work) {
      if (a[k] == 0.0) continue;
      const double* col = g.col(k).data();
      const double ak = a[k];
      for (int j = 0; j < n; ++j) r[j] -= ak * col[j];
    }
    double worst = 0.0;
    std::vector<std::pair<double, int>> viol;
    for (int j = 0; j < n; ++j) {
      if (j == p.exclude) continue;
      const double v = coord_violation(r[j], a[j], gamma);
      worst = std::max(worst, v);
      if (!in_work[j] && v > opt.tol) viol.emplace_back(v, j);
    }
    sol.kkt = worst;
    if (worst <= opt.tol || outer == opt.max_outer) break;
    // Drop working-set coordinates that stayed at zero, then grow by the worst violators.
    std::vector<int> kept;
    for (int k : work) {
      if (a[k] != 0.0) kept.push_back(k);
      else in_work[k] = 0;
    }
    work.swap(kept);
    const size_t add = std::min(viol.size(), std::max<size_t>(10, work.size()));
    std::partial_sort(viol.begin(), viol.begin() + static_cast<long>(add), viol.end(),
                      [](const auto& x, const auto& y) { return x.first > y.first; });
    for (size_t k = 0; k < add; ++k) {
      work.push_back(viol[k].second);
      in_work[viol[k].second] = 1;
    }
    // Working-set problem.
    const int m = static_cast<int>(work.size());
    ws.gss.resize(m, m);
    aw.resize(m);
    bw.resize(m);
    for (int c = 0; c < m; ++c) {
      for (int rr = 0; rr < m; ++rr) ws.gss(rr, c) = g(work[rr], work[c]);
      aw[c] = a[work[c]];
      bw[c] = p.b[work[c]];
    }
    cw = ws.gss * aw;
    for (int sweep = 0; sweep < opt.max_sweeps; ++sweep) {
      ++sol.sweeps;
      for (int k = 0; k < m; ++k) {
        const double gkk = ws.gss(k, k);
        if (gkk <= 0.0) continue;
        const double rk = bw[k] - cw[k] + gkk * aw[k];
        const double nv = soft(rk, half) / gkk;
        const double d = nv - aw[k];
        if (d != 0.0) {
          cw.noalias() += d * ws.gss.col(k);
          aw[k] = nv;
        }
      }
      if (sweep % 4 == 3) cw.noalias() = ws.gss * aw;  // limit round-off drift
      double wv = 0.0;
      for (int k = 0; k < m; ++k) wv = std::max(wv, coord_violation(bw[k] - cw[k], aw[k], gamma));
      if (wv <= 0.1 * opt.tol) break;
      if (sweep % 3 != 2) continue;
      // Newton polish on the current support with its signs fixed.
      std::vector<int> sup;
      for (int k = 0; k < m; ++k)
        if (aw[k] != 0.0) sup.push_back(k);
      if (sup.empty()) continue;
      const int s = static_cast<int>(sup.size());
      Eigen::MatrixXd gpp(s, s);
      Eigen::VectorXd rhs(s);
      for (int c = 0; c < s; ++c) {
        for (int rr = 0; rr < s; ++rr) gpp(rr, c) = ws.gss(sup[rr], sup[c]);
        rhs[c] = bw[sup[c]] - half * sign(aw[sup[c]]);
      }
      Eigen::LDLT<Eigen::MatrixXd> ldlt(gpp);
      if (ldlt.info() != Eigen::Success) continue;
      z = ldlt.solve(rhs);
      if (!z.allFinite() || (gpp * z - rhs).norm() > 1e-8 * (1.0 + rhs.norm())) continue;
      // Move from aw toward z, stopping at the first sign change (the objective is a convex
      // quadratic on the sign orthant, so every step along the segment inside it descends).
      double t = 1.0;
      int hit = -1;
      for (int c = 0; c < s; ++c) {
        const double from = aw[sup[c]];
        if (sign(z[c]) != sign(from)) {
          const double tc = from / (from - z[c]);
          if (tc < t) {
            t = tc;
            hit = c;
          }
        }
      }
      for (int c = 0; c < s; ++c) aw[sup[c]] += t * (z[c] - aw[sup[c]]);
      if (hit >= 0) aw[sup[hit]] = 0.0;
      cw.noalias() = ws.gss * aw;
      wv = 0.0;
      for (int k = 0; k < m; ++k) wv = std::max(wv, coord_violation(bw[k] - cw[k], aw[k], gamma));
      if (wv <= 0.1 * opt.tol) break;
    }
    for (int c = 0; c < m; ++c) a[work[c]] = aw[c];
  }
  // Output, objective and duality gap.
  double ab = 0.0, ar = 0.0, l1 = 0.0, rmax = 0.0;
  for (int j = 0; j < n; ++j) {
    if (j != p.exclude) rmax = std::max(rmax, std::abs(r[j]));
    if (a[j] == 0.0) continue;
    sol.index.push_back(j);
    sol.value.push_back(a[j]);
    ab += a[j] * p.b[j];
    ar += a[j] * r[j];
    l1 += std::abs(a[j]);
  }
  const double rr = std::max(0.0, p.yy - ab - ar);  // |y - X a|^2
  sol.objective = rr + gamma * l1;
  const double s = rmax > 0 ? std::min(1.0, gamma / (2.0 * rmax)) : 1.0;
  const double dual = 2.0 * s * (p.yy - ab) - s * s * rr;
  sol.gap = std::max(0.0, sol.objective - dual);
  return sol;
}

CsrMatrix sparse_code(const Eigen::MatrixXd& gram, const LassoOptions& options, SparseCodingStats* stats,
                      const std::function<void(int, int)>& progress) {
  const int n = static_cast<int>(gram.rows());
  if (gram.cols() != n) throw Error(ErrorKind::kInvalidArgument, "sparse_code: the Gram matrix must be square");
  if (!(options.gamma > 0)) throw Error(ErrorKind::kInvalidArgument, "sparse_code: gamma must be > 0");
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<LassoSolution> sols(n);
  std::atomic<int> next{0}, done{0};
  auto worker = [&]() {
    LassoWorkspace ws;
    for (;;) {
      const int i = next.fetch_add(1);
      if (i >= n) break;
      LassoProblem p;
      p.gram = &gram;
      p.b = gram.col(i).data();
      p.yy = gram(i, i);
      p.exclude = i;
      sols[i] = solve_lasso(p, options, ws);
      done.fetch_add(1);
    }
  };
  const int nt = std::max(1, options.threads);
  std::vector<std::thread> pool;
  for (int t = 0; t < nt; ++t) pool.emplace_back(worker);
  while (done.load() < n) {
    if (progress) progress(done.load(), n);
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  for (auto& th : pool) th.join();
  if (progress) progress(n, n);

  CsrMatrix out;
  out.rows = out.cols = n;
  out.row_ptr.assign(n + 1, 0);
  SparseCodingStats st;
  for (int i = 0; i < n; ++i) {
    out.row_ptr[i + 1] = out.row_ptr[i] + static_cast<int64_t>(sols[i].index.size());
    st.max_kkt = std::max(st.max_kkt, sols[i].kkt);
    st.max_gap = std::max(st.max_gap, sols[i].gap);
    st.max_support = std::max(st.max_support, static_cast<int>(sols[i].index.size()));
  }
  out.col.reserve(out.nnz());
  out.val.reserve(out.nnz());
  for (int i = 0; i < n; ++i) {
    out.col.insert(out.col.end(), sols[i].index.begin(), sols[i].index.end());
    out.val.insert(out.val.end(), sols[i].value.begin(), sols[i].value.end());
  }
  st.mean_support = n ? static_cast<double>(out.nnz()) / n : 0.0;
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (stats) *stats = st;
  return out;
}

}  // namespace kata::train
