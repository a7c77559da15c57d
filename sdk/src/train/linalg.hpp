// Dense products of the trainer, split over std::threads (Eigen is built without OpenMP).
#pragma once

#include <Eigen/Core>

namespace kata::train {

// X^T X for X (d x n): the n x n Gram matrix.
Eigen::MatrixXd gram_matrix(const Eigen::MatrixXd& x, int threads);
// R R^T for R (d x n): a d x d symmetric matrix (both triangles filled).
Eigen::MatrixXd outer_product(const Eigen::MatrixXd& r, int threads);

// The k largest eigenvalues of a symmetric matrix (descending) and, if `vectors` is not null,
// their eigenvectors as columns.
Eigen::VectorXd top_eigen(const Eigen::MatrixXd& m, int k, Eigen::MatrixXd* vectors);
// The k smallest eigenvalues (ascending) and, optionally, their eigenvectors.
Eigen::VectorXd bottom_eigen(const Eigen::MatrixXd& m, int k, Eigen::MatrixXd* vectors);

}  // namespace kata::train
