#include "train/linalg.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

namespace kata::train {

Eigen::MatrixXd gram_matrix(const Eigen::MatrixXd& x, int threads) {
  const Eigen::MatrixXd xt = x.transpose();
  return outer_product(xt, threads);
}

Eigen::MatrixXd outer_product(const Eigen::MatrixXd& r, int threads) {
  const Eigen::Index d = r.rows(), n = r.cols();
  const int nt = std::max(1, threads);
  std::vector<Eigen::MatrixXd> part(nt, Eigen::MatrixXd::Zero(d, d));
  std::vector<std::thread> pool;
  for (int t = 0; t < nt; ++t) {
    pool.emplace_back([&, t]() {
      const Eigen::Index c0 = n * t / nt, c1 = n * (t + 1) / nt;
      if (c1 <= c0) return;
      part[t].selfadjointView<Eigen::Lower>().rankUpdate(r.middleCols(c0, c1 - c0));
    });
  }
  for (auto& th : pool) th.join();
  Eigen::MatrixXd out = part[0];
  for (int t = 1; t < nt; ++t) out += part[t];
  for (Eigen::Index c = 0; c < d; ++c)
    for (Eigen::Index rr = 0; rr < c; ++rr) out(rr, c) = out(c, rr);
  return out;
}

namespace {

// Solves (T - sigma I) x = b in place for a symmetric tridiagonal T (diagonal d, off-diagonal e)
// by Gaussian elimination with partial pivoting (LAPACK dgttrf/dgttrs); zero pivots are replaced
// by `tiny` (inverse iteration wants the near-singular solve).
class TridiagonalSolver {
 public:
  TridiagonalSolver(const Eigen::VectorXd& d, const Eigen::VectorXd& e, double sigma, double tiny) {
    const Eigen::Index n = d.size();
    dd_ = d.array() - sigma;
    dl_ = e;
    du_ = e;
    du2_ = Eigen::VectorXd::Zero(std::max<Eigen::Index>(n - 2, 0));
    piv_.assign(static_cast<size_t>(std::max<Eigen::Index>(n - 1, 0)), 0);
    for (Eigen::Index i = 0; i + 1 < n; ++i) {
      if (std::abs(dd_[i]) >= std::abs(dl_[i])) {
        if (dd_[i] == 0.0) dd_[i] = tiny;
        const double fact = dl_[i] / dd_[i];
        dl_[i] = fact;
        dd_[i + 1] -= fact * du_[i];
      } else {
        const double fact = dd_[i] / dl_[i];
        dd_[i] = dl_[i];
        dl_[i] = fact;
        const double temp = du_[i];
        du_[i] = dd_[i + 1];
        dd_[i + 1] = temp - fact * dd_[i + 1];
        if (i + 2 < n) {
          du2_[i] = du_[i + 1];
          du_[i + 1] = -fact * du_[i + 1];
        }
        piv_[static_cast<size_t>(i)] = 1;
      }
    }
    if (n > 0 && dd_[n - 1] == 0.0) dd_[n - 1] = tiny;
  }
  void solve(Eigen::VectorXd& b) const {
    const Eigen::Index n = b.size();
    for (Eigen::Index i = 0; i + 1 < n; ++i) {
      if (!piv_[static_cast<size_t>(i)]) {
        b[i + 1] -= dl_[i] * b[i];
      } else {
        const double temp = b[i];
        b[i] = b[i + 1];
        b[i + 1] = temp - dl_[i] * b[i];
      }
    }
    b[n - 1] /= dd_[n - 1];
    if (n > 1) b[n - 2] = (b[n - 2] - du_[n - 2] * b[n - 1]) / dd_[n - 2];
    for (Eigen::Index i = n - 3; i >= 0; --i) b[i] = (b[i] - du_[i] * b[i + 1] - du2_[i] * b[i + 2]) / dd_[i];
  }

 private:
  Eigen::VectorXd dd_, dl_, du_, du2_;
  std::vector<char> piv_;
};

// Eigenvectors of the tridiagonal (d, e) for the given eigenvalues (sorted, descending) by
// inverse iteration, re-orthogonalised within clusters of close eigenvalues (as LAPACK dstein).
Eigen::MatrixXd tridiagonal_vectors(const Eigen::VectorXd& d, const Eigen::VectorXd& e, const Eigen::VectorXd& vals) {
  const Eigen::Index n = d.size(), k = vals.size();
  double norm = 0.0;
  for (Eigen::Index i = 0; i < n; ++i)
    norm = std::max(norm, std::abs(d[i]) + (i > 0 ? std::abs(e[i - 1]) : 0.0) + (i + 1 < n ? std::abs(e[i]) : 0.0));
  if (norm == 0.0) norm = 1.0;
  const double eps = std::numeric_limits<double>::epsilon();
  const double ortol = 1e-3 * norm;
  Eigen::MatrixXd v(n, k);
  Eigen::Index cluster_start = 0;
  double prev_sigma = 0.0;
  for (Eigen::Index j = 0; j < k; ++j) {
    if (j > 0 && std::abs(vals[j - 1] - vals[j]) > ortol) cluster_start = j;
    double sigma = vals[j];
    if (j > cluster_start && std::abs(sigma - prev_sigma) < 10 * eps * norm) sigma = prev_sigma - 10 * eps * norm;
    prev_sigma = sigma;
    TridiagonalSolver solver(d, e, sigma, eps * norm);
    Eigen::VectorXd x(n);
    for (Eigen::Index i = 0; i < n; ++i) x[i] = 1.0 + 0.5 * std::sin(0.7 * static_cast<double>(i * (j + 3)));  // deterministic start
    x.normalize();
    for (int it = 0; it < 4; ++it) {
      solver.solve(x);
      for (Eigen::Index c = cluster_start; c < j; ++c) x -= v.col(c).dot(x) * v.col(c);
      const double nx = x.norm();
      if (!(nx > 0) || !std::isfinite(nx)) {
        x = Eigen::VectorXd::Unit(n, j % n);
        continue;
      }
      x /= nx;
    }
    v.col(j) = x;
  }
  return v;
}

}  // namespace

Eigen::VectorXd top_eigen(const Eigen::MatrixXd& m, int k, Eigen::MatrixXd* vectors) {
  if (m.rows() <= 64) {
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(m, vectors ? Eigen::ComputeEigenvectors : Eigen::EigenvaluesOnly);
    if (vectors) *vectors = es.eigenvectors().rightCols(k).rowwise().reverse();
    return es.eigenvalues().tail(k).reverse();
  }
  // Householder tridiagonalisation (the O(n^3) part), eigenvalues of the tridiagonal (O(n^2)),
  // then only k eigenvectors: inverse iteration on the tridiagonal, back-transformed, and a final
  // Rayleigh-Ritz step on the k-dimensional subspace. Far cheaper than all n eigenvectors.
  Eigen::Tridiagonalization<Eigen::MatrixXd> tri(m);
  const Eigen::VectorXd diag = tri.diagonal();
  const Eigen::VectorXd sub = tri.subDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es;
  es.computeFromTridiagonal(diag, sub, Eigen::EigenvaluesOnly);
  Eigen::VectorXd vals = es.eigenvalues().tail(k).reverse();
  if (!vectors) return vals;
  Eigen::MatrixXd v = tridiagonal_vectors(diag, sub, vals);
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(v);
  v = qr.householderQ() * Eigen::MatrixXd::Identity(v.rows(), k);
  Eigen::MatrixXd w = tri.matrixQ() * v;
  const Eigen::MatrixXd h = w.transpose() * m * w;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> small(h);
  *vectors = w * small.eigenvectors().rowwise().reverse();
  return small.eigenvalues().reverse();
}

Eigen::VectorXd bottom_eigen(const Eigen::MatrixXd& m, int k, Eigen::MatrixXd* vectors) {
  return -top_eigen(-m, k, vectors);
}

}  // namespace kata::train
