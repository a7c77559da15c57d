// Sparse representation of every unlabeled pose by the others (paper eq. 15-16):
//   a_i = argmin_a |x_i - X a|^2 + gamma |a|_1   subject to a_ii = 0,
// solved exactly on the shared Gram matrix G = X^T X by coordinate descent over a growing
// working set, polished by a Newton step on the support (the sign-fixed normal equations), and
// stopped by the Lasso optimality (KKT) conditions checked over all N coordinates.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

namespace kata::train {

// Compressed sparse rows. In `sparse_code`'s output row i holds a_i (the paper's column i of A).
struct CsrMatrix {
  int rows = 0, cols = 0;
  std::vector<int64_t> row_ptr;  // rows + 1
  std::vector<int> col;
  std::vector<double> val;
  int64_t nnz() const { return row_ptr.empty() ? 0 : row_ptr.back(); }
};

struct LassoOptions {
  double gamma = 0.05;       // weight of |a|_1 in |y - X a|^2 + gamma |a|_1
  double tol = 1e-9;         // stop when every KKT condition holds to this (gradient units)
  int max_outer = 200;       // working-set growths
  int max_sweeps = 2000;     // coordinate-descent sweeps per working set
  int threads = 2;           // sparse_code: problems solved in parallel
};

// One Lasso problem in Gram form: min_a |y|^2 - 2 a^T b + a^T G a + gamma |a|_1, where
// b = X^T y; coordinate `exclude` (or none when < 0) is held at 0.
struct LassoProblem {
  const Eigen::MatrixXd* gram = nullptr;  // N x N, symmetric
  const double* b = nullptr;              // N
  double yy = 0.0;                        // |y|^2 (for the objective and the duality gap)
  int exclude = -1;
};

struct LassoSolution {
  std::vector<int> index;     // support, ascending
  std::vector<double> value;  // a at the support
  double kkt = 0.0;           // max KKT violation (gradient units) over all coordinates
  double gap = 0.0;           // duality gap of |y - Xa|^2 + gamma |a|_1
  double objective = 0.0;
  int sweeps = 0;
};

// Reusable scratch memory for one thread.
struct LassoWorkspace {
  std::vector<double> grad;  // N
  std::vector<double> dense_a;
  Eigen::MatrixXd gss;       // working-set Gram
};

LassoSolution solve_lasso(const LassoProblem& problem, const LassoOptions& options, LassoWorkspace& ws);

// Max violation of the Lasso optimality conditions of a candidate (index/value sparse) in
// gradient units: for a_j != 0, |2 (b - G a)_j - gamma sign(a_j)|; for a_j = 0 (j != exclude),
// max(0, |2 (b - G a)_j| - gamma). Independent of the solver (used by the tests).
double lasso_kkt_violation(const LassoProblem& problem, double gamma, const std::vector<int>& index,
                           const std::vector<double>& value);
// |y - Xa|^2 + gamma |a|_1 in Gram form.
double lasso_objective(const LassoProblem& problem, double gamma, const std::vector<int>& index,
                       const std::vector<double>& value);

struct SparseCodingStats {
  double max_kkt = 0.0;  // over all problems
  double max_gap = 0.0;
  double mean_support = 0.0;
  int max_support = 0;
  double seconds = 0.0;
};

// a_i for every column i of X given G = X^T X (N x N): row i of the result is a_i, a_ii = 0.
// `progress(done, total)` is called from the calling thread now and then (may be empty).
CsrMatrix sparse_code(const Eigen::MatrixXd& gram, const LassoOptions& options, SparseCodingStats* stats,
                      const std::function<void(int, int)>& progress = {});

}  // namespace kata::train
