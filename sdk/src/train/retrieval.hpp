// Content-based pose retrieval, the paper's section 6: per subject, K k-means pose centres
// (clustered on block 1 of GPD = joint coordinates in the yaw-free local frame, the domain of the
// simple pose distance of eq. 35); each centre is a real pose (the member nearest its centroid,
// since GPD's kinetic blocks and every learned metric need a real pose). Every centre is a query
// against the rest of the pool (the paper: one of the 3000 against the other 2999), and precision
// at scope s is the fraction of the top s retrieved with the query's motion category.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "train/clips.hpp"

namespace kata::train {

// file name -> "motion type" column of the data folder's README.md table (CMU developer set).
std::map<std::string, std::string> read_motion_types(const std::string& readme);

// Subject number of a CMU file name "NN_TT.bvh" (-1 if none).
int clip_subject(const std::string& file);

struct RetrievalPose {
  std::string clip;
  int frame = 0;
  int subject = -1;
  int category = -1;
  const float* row = nullptr;  // raw GPD features (owned by the ClipStore)
};

struct RetrievalSet {
  std::vector<RetrievalPose> poses;
  std::vector<std::string> categories;  // index -> name
};

// K centres per subject over `clips` (frames 1..F-1 every `stride`-th), k-means++ seeded.
RetrievalSet build_retrieval_set(ClipStore& store, const std::vector<std::string>& clips,
                                 const std::map<std::string, std::string>& motion_type, int clusters, uint64_t seed,
                                 int stride = 4, int iterations = 50);

enum class RetrievalPool {
  kAll,            // the paper: every other centre (same subject included)
  kOtherSubjects,  // only centres of other subjects
};

// Mean over queries of precision at each scope; dist is n x n (symmetric; the diagonal is ignored).
// Ties are broken by index. Queries with fewer than s candidates use all of them.
std::vector<double> retrieval_precision(const Eigen::MatrixXd& dist, const std::vector<int>& category,
                                        const std::vector<int>& subject, const std::vector<int>& scopes,
                                        RetrievalPool pool = RetrievalPool::kAll);

// Squared Euclidean distances between the columns of x (d x n), and of a diagonal metric
// sum_k w_k (x_k - y_k)^2.
Eigen::MatrixXd pairwise_sq_l2(const Eigen::MatrixXd& x);
Eigen::MatrixXd pairwise_diag(const Eigen::MatrixXd& x, const Eigen::VectorXd& w);

}  // namespace kata::train
